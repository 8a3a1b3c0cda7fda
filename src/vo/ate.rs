//! Absolute trajectory error: Umeyama alignment of the estimated positions
//! onto the ground truth (SE(3) or Sim(3)), then statistics of the
//! per-frame translation errors. Computes what evo's
//! `evo_ape kitti GT EST -a` (`-as` for Sim(3)) computes.

use super::{Pose, VoError};
use nalgebra::{Matrix3, Vector3};

/// How the estimate is aligned before the errors are taken.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Align {
    /// No alignment (evo without `-a`).
    None,
    /// Rotation and translation (evo `-a`).
    #[default]
    Se3,
    /// Rotation, translation and scale (evo `-as`).
    Sim3,
}

impl std::fmt::Display for Align {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Align::None => "none",
            Align::Se3 => "se3",
            Align::Sim3 => "sim3",
        })
    }
}

/// A similarity `y = s R x + t`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Similarity {
    /// Rotation.
    #[serde(serialize_with = "rows3")]
    pub rotation: Matrix3<f64>,
    /// Translation.
    #[serde(serialize_with = "vec3")]
    pub translation: Vector3<f64>,
    /// Scale (1 for SE(3)).
    pub scale: f64,
}

// nalgebra is built without its serde feature: plain arrays in JSON
fn rows3<S: serde::Serializer>(m: &Matrix3<f64>, s: S) -> Result<S::Ok, S::Error> {
    serde::Serialize::serialize(
        &[[m[(0, 0)], m[(0, 1)], m[(0, 2)]], [m[(1, 0)], m[(1, 1)], m[(1, 2)]], [m[(2, 0)], m[(2, 1)], m[(2, 2)]]],
        s,
    )
}

fn vec3<S: serde::Serializer>(v: &Vector3<f64>, s: S) -> Result<S::Ok, S::Error> {
    serde::Serialize::serialize(&[v.x, v.y, v.z], s)
}

impl Similarity {
    /// The identity.
    pub fn identity() -> Self {
        Self { rotation: Matrix3::identity(), translation: Vector3::zeros(), scale: 1.0 }
    }

    /// `s R x + t`.
    pub fn apply(&self, x: &Vector3<f64>) -> Vector3<f64> {
        self.scale * (self.rotation * x) + self.translation
    }
}

/// Umeyama's least-squares similarity (1991) taking the points `x` onto `y`,
/// as evo's `umeyama_alignment`: covariance `1/n sum (y - ȳ)(x - x̄)^T`,
/// reflection fixed through the sign of `det(U) det(V)`, scale
/// `trace(D S) / σx²` when `with_scale`. Errors with fewer than 3 points
/// or a covariance of rank below 2 (collinear points), as evo does.
pub fn umeyama(x: &[Vector3<f64>], y: &[Vector3<f64>], with_scale: bool) -> Result<Similarity, VoError> {
    let n = x.len();
    if n != y.len() {
        return Err(VoError::Trajectory { reason: format!("{n} estimated positions but {} reference ones", y.len()) });
    }
    if n < 3 {
        return Err(VoError::Trajectory { reason: format!("alignment needs at least 3 positions, got {n}") });
    }
    let nf = n as f64;
    let mx = x.iter().sum::<Vector3<f64>>() / nf;
    let my = y.iter().sum::<Vector3<f64>>() / nf;
    let sigma_x = x.iter().map(|p| (p - mx).norm_squared()).sum::<f64>() / nf;
    let cov = x.iter().zip(y).map(|(a, b)| (b - my) * (a - mx).transpose()).sum::<Matrix3<f64>>() / nf;
    let svd = cov.svd(true, true);
    let (u, vt) = match (svd.u, svd.v_t) {
        (Some(u), Some(vt)) => (u, vt),
        _ => return Err(VoError::Trajectory { reason: "SVD of the covariance failed".into() }),
    };
    let d = svd.singular_values;
    if d.iter().filter(|&&v| v > f64::EPSILON).count() < 2 {
        return Err(VoError::Trajectory {
            reason: "degenerate covariance rank (collinear or coincident positions): Umeyama alignment is not possible"
                .into(),
        });
    }
    let mut s = Matrix3::identity();
    if u.determinant() * vt.determinant() < 0.0 {
        // flip the axis of the smallest singular value (evo: the last one, as numpy sorts)
        let k = (0..3).min_by(|&i, &j| d[i].total_cmp(&d[j])).unwrap_or(2);
        s[(k, k)] = -1.0;
    }
    let rotation = u * s * vt;
    let scale = if with_scale {
        if sigma_x.is_nan() || sigma_x <= 0.0 {
            return Err(VoError::Trajectory { reason: "estimated positions all coincide: no scale".into() });
        }
        (0..3).map(|i| d[i] * s[(i, i)]).sum::<f64>() / sigma_x
    } else {
        1.0
    };
    let translation = my - scale * (rotation * mx);
    Ok(Similarity { rotation, translation, scale })
}

/// Statistics of a set of errors, as evo reports them (`std` is the
/// population standard deviation, `median` numpy's).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Stats {
    /// Root mean square.
    pub rmse: f64,
    /// Mean.
    pub mean: f64,
    /// Median (mean of the middle two for an even count).
    pub median: f64,
    /// Standard deviation (divided by n).
    pub std: f64,
    /// Smallest.
    pub min: f64,
    /// Largest.
    pub max: f64,
    /// Sum of squares.
    pub sse: f64,
}

impl Stats {
    /// The statistics of `e` (all zero when empty).
    pub fn of(e: &[f64]) -> Self {
        if e.is_empty() {
            return Self::default();
        }
        let n = e.len() as f64;
        let sse = e.iter().map(|v| v * v).sum::<f64>();
        let mean = e.iter().sum::<f64>() / n;
        let var = e.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / n;
        let mut s = e.to_vec();
        s.sort_by(f64::total_cmp);
        let m = s.len() / 2;
        let median = if s.len() % 2 == 1 { s[m] } else { 0.5 * (s[m - 1] + s[m]) };
        Self { rmse: (sse / n).sqrt(), mean, median, std: var.sqrt(), min: s[0], max: s[s.len() - 1], sse }
    }
}

/// The absolute trajectory error of an estimate.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Ate {
    /// Alignment used.
    pub align: Align,
    /// The similarity applied to the estimate.
    pub alignment: Similarity,
    /// Per-frame translation error after alignment, metres.
    pub errors: Vec<f64>,
    /// Their statistics.
    pub stats: Stats,
}

/// ATE of `est` against `gt` (same length, frame by frame): positions only,
/// as evo's APE on the translation part.
///
/// ```
/// use lfast::vo::{Pose, ate::{ate, Align}};
/// let gt: Vec<Pose> = (0..5).map(|i| Pose::from_translation([i as f64, 0.0, (i * i) as f64].into())).collect();
/// // the same path, twice as large and shifted: Sim(3) removes both
/// let est: Vec<Pose> = gt.iter().map(|p| Pose::from_translation(p.translation * 2.0 + nalgebra::Vector3::new(1.0, 2.0, 3.0))).collect();
/// let a = ate(&gt, &est, Align::Sim3).unwrap();
/// assert!(a.stats.rmse < 1e-12 && (a.alignment.scale - 0.5).abs() < 1e-12);
/// ```
pub fn ate(gt: &[Pose], est: &[Pose], align: Align) -> Result<Ate, VoError> {
    if gt.len() != est.len() {
        return Err(VoError::Trajectory {
            reason: format!(
                "the ground truth has {} poses and the estimate {}; they must match frame for frame",
                gt.len(),
                est.len()
            ),
        });
    }
    if gt.is_empty() {
        return Err(VoError::Trajectory { reason: "empty trajectories".into() });
    }
    let x: Vec<Vector3<f64>> = est.iter().map(|p| p.translation).collect();
    let y: Vec<Vector3<f64>> = gt.iter().map(|p| p.translation).collect();
    let alignment = match align {
        Align::None => Similarity::identity(),
        Align::Se3 => umeyama(&x, &y, false)?,
        Align::Sim3 => umeyama(&x, &y, true)?,
    };
    let errors: Vec<f64> = x.iter().zip(&y).map(|(a, b)| (alignment.apply(a) - b).norm()).collect();
    let stats = Stats::of(&errors);
    Ok(Ate { align, alignment, errors, stats })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SplitMix64;
    use nalgebra::Rotation3;

    fn cloud(n: usize, seed: u64) -> Vec<Vector3<f64>> {
        let mut r = SplitMix64::new(seed);
        (0..n).map(|_| Vector3::new(r.next_f64() * 10.0, r.next_f64() * 3.0 - 1.0, r.next_f64() * 50.0)).collect()
    }

    #[test]
    fn umeyama_recovers_a_known_similarity() {
        let x = cloud(30, 1);
        let rot = *Rotation3::from_euler_angles(0.3, -1.1, 2.0).matrix();
        let (s, t) = (2.5, Vector3::new(-4.0, 7.0, 0.5));
        let y: Vec<_> = x.iter().map(|p| s * (rot * p) + t).collect();
        let sim = umeyama(&x, &y, true).unwrap();
        assert!((sim.rotation - rot).norm() < 1e-10);
        assert!((sim.scale - s).abs() < 1e-10);
        assert!((sim.translation - t).norm() < 1e-9);
        // SE(3) mode keeps the scale at 1 and still finds the rotation
        let se3 = umeyama(&x, &y, false).unwrap();
        assert_eq!(se3.scale, 1.0);
        assert!((se3.rotation - rot).norm() < 1e-10);
    }

    #[test]
    fn umeyama_never_returns_a_reflection() {
        let x = cloud(20, 2);
        // mirrored copy: the best proper rotation, det +1
        let y: Vec<_> = x.iter().map(|p| Vector3::new(-p.x, p.y, p.z)).collect();
        let sim = umeyama(&x, &y, false).unwrap();
        assert!((sim.rotation.determinant() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn umeyama_rejects_degenerate_input() {
        let line: Vec<_> = (0..5).map(|i| Vector3::new(i as f64, 0.0, 0.0)).collect();
        assert!(umeyama(&line, &line, false).unwrap_err().to_string().contains("degenerate"));
        assert!(umeyama(&line[..2], &line[..2], false).is_err());
        assert!(umeyama(&line, &line[..4], false).is_err());
    }

    #[test]
    fn stats_as_numpy() {
        let s = Stats::of(&[3.0, 1.0, 4.0, 1.0]);
        assert_eq!((s.min, s.max, s.median, s.mean, s.sse), (1.0, 4.0, 2.0, 2.25, 27.0));
        assert!((s.rmse - (27.0f64 / 4.0).sqrt()).abs() < 1e-15);
        assert!((s.std - (1.6875f64).sqrt()).abs() < 1e-15);
        assert_eq!(Stats::of(&[5.0, 1.0, 2.0]).median, 2.0);
    }

    #[test]
    fn ate_unaligned_is_the_raw_distance() {
        let gt: Vec<Pose> = (0..4).map(|i| Pose::from_translation(Vector3::new(i as f64, 0.0, 0.0))).collect();
        let est: Vec<Pose> =
            gt.iter().map(|p| Pose::from_translation(p.translation + Vector3::new(0.0, 3.0, 4.0))).collect();
        let a = ate(&gt, &est, Align::None).unwrap();
        assert_eq!(a.errors, vec![5.0; 4]);
        assert!(ate(&gt, &est[..3], Align::Se3).is_err());
    }
}
