//! Two-view geometry on normalised image coordinates (`K^-1` applied): the
//! normalised eight-point essential matrix, RANSAC around it (seeded, so
//! deterministic), and pose recovery with the cheirality check.
//!
//! Convention: a point `X1` in camera-1 coordinates is `X2 = R X1 + t` in
//! camera 2, and `x2^T E x1 = 0` with `E = [t]x R`.

use nalgebra::{DMatrix, Matrix3, Vector2, Vector3};

/// A 2D point in normalised image coordinates.
pub type Point = Vector2<f64>;

/// Hartley's isotropic normalisation: centroid to the origin, mean distance
/// sqrt(2). `None` when all points coincide.
fn normaliser(x: &[Point]) -> Option<Matrix3<f64>> {
    let n = x.len() as f64;
    let c = x.iter().fold(Vector2::zeros(), |a, p| a + p) / n;
    let d = x.iter().map(|p| (p - c).norm()).sum::<f64>() / n;
    if d.is_nan() || d <= 1e-12 {
        return None;
    }
    let s = std::f64::consts::SQRT_2 / d;
    Some(Matrix3::new(s, 0.0, -s * c.x, 0.0, s, -s * c.y, 0.0, 0.0, 1.0))
}

/// Projects a 3x3 matrix onto the essential manifold (singular values
/// `(1, 1, 0)`), Frobenius-normalised.
pub fn project_essential(m: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    let svd = m.svd(true, true);
    let (u, vt) = (svd.u?, svd.v_t?);
    // nalgebra does not promise an order: sort the singular values
    let mut idx = [0usize, 1, 2];
    idx.sort_by(|&a, &b| svd.singular_values[b].total_cmp(&svd.singular_values[a]));
    let mut d = Matrix3::zeros();
    d[(idx[0], idx[0])] = 1.0;
    d[(idx[1], idx[1])] = 1.0;
    let e = u * d * vt;
    let n = e.norm();
    (n > 0.0 && n.is_finite()).then(|| e / n)
}

/// The normalised eight-point algorithm on `n >= 8` correspondences
/// `x2^T E x1 = 0` (least squares for `n > 8`). `None` when degenerate.
pub fn eight_point(x1: &[Point], x2: &[Point]) -> Option<Matrix3<f64>> {
    eight_point_weighted(x1, x2, None)
}

/// [`eight_point`] with each equation weighted by `w[i]` (least squares).
pub fn eight_point_weighted(x1: &[Point], x2: &[Point], w: Option<&[f64]>) -> Option<Matrix3<f64>> {
    let n = x1.len();
    if n < 8 || x2.len() != n || w.is_some_and(|w| w.len() != n) {
        return None;
    }
    let (t1, t2) = (normaliser(x1)?, normaliser(x2)?);
    // at least 9 rows, so the thin SVD's V^T is 9x9 and holds the null vector
    let mut a = DMatrix::<f64>::zeros(n.max(9), 9);
    for i in 0..n {
        let p = t1 * x1[i].push(1.0);
        let q = t2 * x2[i].push(1.0);
        let row = [q.x * p.x, q.x * p.y, q.x, q.y * p.x, q.y * p.y, q.y, p.x, p.y, 1.0];
        let wi = w.map_or(1.0, |w| w[i]);
        for (k, v) in row.iter().enumerate() {
            a[(i, k)] = wi * v;
        }
    }
    let svd = a.svd(false, true);
    let vt = svd.v_t?;
    let k =
        (0..svd.singular_values.len()).min_by(|&i, &j| svd.singular_values[i].total_cmp(&svd.singular_values[j]))?;
    let f = vt.row(k);
    let en = Matrix3::new(f[0], f[1], f[2], f[3], f[4], f[5], f[6], f[7], f[8]);
    project_essential(&(t2.transpose() * en * t1))
}

/// Sampson's first-order approximation of the squared geometric distance of
/// a correspondence to `E` (normalised units squared).
pub fn sampson(e: &Matrix3<f64>, x1: &Point, x2: &Point) -> f64 {
    let (p, q) = (x1.push(1.0), x2.push(1.0));
    let ep = e * p;
    let etq = e.transpose() * q;
    let r = q.dot(&ep);
    let den = ep.x * ep.x + ep.y * ep.y + etq.x * etq.x + etq.y * etq.y;
    if den > 0.0 { r * r / den } else { f64::INFINITY }
}

/// RANSAC settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RansacOptions {
    /// Inlier threshold on the Sampson distance, in pixels.
    pub threshold_px: f64,
    /// Stop when an all-inlier sample has been drawn with this probability.
    pub confidence: f64,
    /// Samples drawn at least, even when the adaptive bound is lower: with
    /// many inliers that bound is a few dozen samples, and the best of so few
    /// eight-point models varies from seed to seed.
    pub min_iterations: usize,
    /// Upper bound on the number of samples.
    pub max_iterations: usize,
    /// RNG seed (the same seed and input give the same result).
    pub seed: u64,
}

impl Default for RansacOptions {
    fn default() -> Self {
        Self { threshold_px: 1.0, confidence: 0.999, min_iterations: 1000, max_iterations: 2000, seed: 0x5eed }
    }
}

/// An essential matrix with its inliers.
#[derive(Clone, Debug, PartialEq)]
pub struct Essential {
    /// E, Frobenius norm 1.
    pub e: Matrix3<f64>,
    /// Per correspondence: within the threshold.
    pub inliers: Vec<bool>,
    /// Number of `true` in `inliers`.
    pub n_inliers: usize,
    /// Samples drawn.
    pub iterations: usize,
}

pub use crate::rng::SplitMix64;

/// Inliers of `e`: Sampson distance below `thr2 * sigma[i]^2` (`thr2` in
/// normalised units squared). Returns the mask and its count.
pub fn score(e: &Matrix3<f64>, x1: &[Point], x2: &[Point], sigma: Option<&[f64]>, thr2: f64) -> (Vec<bool>, usize) {
    let s2 = |i: usize| sigma.map_or(1.0, |s| s[i] * s[i]);
    let inl: Vec<bool> = (0..x1.len()).map(|i| sampson(e, &x1[i], &x2[i]) < thr2 * s2(i)).collect();
    let n = inl.iter().filter(|&&v| v).count();
    (inl, n)
}

fn subset(x: &[Point], keep: &[bool]) -> Vec<Point> {
    x.iter().zip(keep).filter(|(_, k)| **k).map(|(p, _)| *p).collect()
}

/// RANSAC over eight-point samples, then refits on the inliers while that
/// adds inliers. `focal` (pixels) converts the pixel threshold to
/// normalised units. `sigma[i]` (default 1) scales correspondence `i`'s
/// threshold and weight: the pyramid scale of its keypoints, whose position
/// is that much less precise (as ORB-SLAM's per-level sigma). `None` with
/// fewer than 8 correspondences or no model.
pub fn ransac_essential(
    x1: &[Point],
    x2: &[Point],
    sigma: Option<&[f64]>,
    focal: f64,
    opts: &RansacOptions,
) -> Option<Essential> {
    let n = x1.len();
    if n < 8
        || x2.len() != n
        || focal.is_nan()
        || focal <= 0.0
        || sigma.is_some_and(|s| s.len() != n || s.iter().any(|v| v.is_nan() || *v <= 0.0))
    {
        return None;
    }
    let thr = opts.threshold_px / focal;
    let thr2 = thr * thr;
    let mut rng = SplitMix64::new(opts.seed);
    let mut best: Option<(Matrix3<f64>, Vec<bool>, usize)> = None;
    let mut needed = opts.max_iterations;
    let mut it = 0;
    let (mut s1, mut s2) = (Vec::with_capacity(8), Vec::with_capacity(8));
    let mut picked = [usize::MAX; 8];
    while it < needed.max(opts.min_iterations).min(opts.max_iterations) {
        it += 1;
        // eight distinct indices
        for k in 0..8 {
            picked[k] = loop {
                let c = rng.below(n);
                if !picked[..k].contains(&c) {
                    break c;
                }
            };
        }
        s1.clear();
        s2.clear();
        for &i in &picked {
            s1.push(x1[i]);
            s2.push(x2[i]);
        }
        let Some(e) = eight_point(&s1, &s2) else { continue };
        let (inl, cnt) = score(&e, x1, x2, sigma, thr2);
        if best.as_ref().is_none_or(|b| cnt > b.2) {
            // adaptive stopping: samples so that P(all-inlier sample) >= confidence
            let w = cnt as f64 / n as f64;
            let p_good = w.powi(8);
            // ln_1p: for a tiny p_good, ln(1 - p_good) would round to 0
            let denom = (-p_good).ln_1p();
            needed = if p_good >= 1.0 {
                it
            } else if denom >= 0.0 || !denom.is_finite() {
                opts.max_iterations
            } else {
                ((1.0 - opts.confidence).ln() / denom).ceil().clamp(1.0, opts.max_iterations as f64) as usize
            };
            best = Some((e, inl, cnt));
        }
    }
    let (mut e, mut inl, mut cnt) = best?;
    // local refinement: least squares on all inliers, kept while it gains
    for _ in 0..4 {
        if cnt < 8 {
            break;
        }
        let w: Option<Vec<f64>> =
            sigma.map(|s| s.iter().zip(&inl).filter(|(_, k)| **k).map(|(v, _)| 1.0 / v).collect());
        let Some(e2) = eight_point_weighted(&subset(x1, &inl), &subset(x2, &inl), w.as_deref()) else { break };
        let (inl2, cnt2) = score(&e2, x1, x2, sigma, thr2);
        if cnt2 < cnt {
            break;
        }
        let same = inl2 == inl;
        (e, inl, cnt) = (e2, inl2, cnt2);
        if same {
            break;
        }
    }
    Some(Essential { e, inliers: inl, n_inliers: cnt, iterations: it })
}

/// A relative pose: `X2 = R X1 + t`, `|t| = 1`.
#[derive(Clone, Debug, PartialEq)]
pub struct RelativePose {
    /// Rotation from camera 1 to camera 2 coordinates.
    pub rotation: Matrix3<f64>,
    /// Unit translation (camera-2 coordinates).
    pub translation: Vector3<f64>,
    /// Correspondences triangulated in front of both cameras (and nearer
    /// than `max_depth`).
    pub n_good: usize,
    /// Per correspondence: one of those.
    pub good: Vec<bool>,
}

/// Depths `(z1, z2)` of the point seen at `x1`, `x2` under `(R, t)`: least
/// squares of `z2 x2 - z1 R x1 = t`. `None` for (near-)parallel rays.
pub fn depths(r: &Matrix3<f64>, t: &Vector3<f64>, x1: &Point, x2: &Point) -> Option<(f64, f64)> {
    let a = -(r * x1.push(1.0));
    let b = x2.push(1.0);
    // normal equations of [a b] (z1, z2)^T = t
    let (aa, ab, bb) = (a.dot(&a), a.dot(&b), b.dot(&b));
    let det = aa * bb - ab * ab;
    if det <= 1e-12 * aa * bb {
        return None;
    }
    let (at, bt) = (a.dot(t), b.dot(t));
    Some(((bb * at - ab * bt) / det, (aa * bt - ab * at) / det))
}

/// The four decompositions of `E` and the one that puts the most inlier
/// correspondences in front of both cameras (cheirality). Points farther
/// than `max_depth` baselines count as neither (as OpenCV's `recoverPose`,
/// which uses 50): they constrain the sign of `t` poorly.
pub fn recover_pose(
    e: &Matrix3<f64>,
    x1: &[Point],
    x2: &[Point],
    inliers: &[bool],
    max_depth: f64,
) -> Option<RelativePose> {
    let svd = e.svd(true, true);
    let (mut u, mut vt) = (svd.u?, svd.v_t?);
    // order the columns so that the smallest singular value is last
    let k = (0..3).min_by(|&i, &j| svd.singular_values[i].total_cmp(&svd.singular_values[j]))?;
    if k != 2 {
        u.swap_columns(k, 2);
        vt.swap_rows(k, 2);
    }
    if u.determinant() < 0.0 {
        u = -u;
    }
    if vt.determinant() < 0.0 {
        vt = -vt;
    }
    let w = Matrix3::new(0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0);
    let r1 = u * w * vt;
    let r2 = u * w.transpose() * vt;
    let t: Vector3<f64> = u.column(2).into_owned();
    let candidates = [(r1, t), (r1, -t), (r2, t), (r2, -t)];
    let mut best: Option<RelativePose> = None;
    for (r, t) in candidates {
        let (good, n_good) = cheirality(&r, &t, x1, x2, inliers, max_depth);
        if best.as_ref().is_none_or(|b| n_good > b.n_good) {
            best = Some(RelativePose { rotation: r, translation: t, n_good, good });
        }
    }
    best.filter(|b| b.n_good > 0)
}

/// Which inliers triangulate in front of both cameras under `(R, t)`, nearer
/// than `max_depth` baselines; and their count.
pub fn cheirality(
    r: &Matrix3<f64>,
    t: &Vector3<f64>,
    x1: &[Point],
    x2: &[Point],
    inliers: &[bool],
    max_depth: f64,
) -> (Vec<bool>, usize) {
    let good: Vec<bool> = (0..x1.len())
        .map(|i| {
            inliers[i]
                && depths(r, t, &x1[i], &x2[i])
                    .is_some_and(|(z1, z2)| z1 > 0.0 && z2 > 0.0 && z1 < max_depth && z2 < max_depth)
        })
        .collect();
    let n = good.iter().filter(|&&g| g).count();
    (good, n)
}

/// Two unit vectors completing `t` (unit) to an orthonormal basis.
fn tangent_basis(t: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let a = if t.x.abs() < 0.9 { Vector3::x() } else { Vector3::y() };
    let b1 = t.cross(&a).normalize();
    (b1, t.cross(&b1))
}

/// `(exp([d0 d1 d2]x) R, normalise(t + d3 b1 + d4 b2))`: the 5-DoF update.
fn perturb(r: &Matrix3<f64>, t: &Vector3<f64>, d: &[f64; 5]) -> (Matrix3<f64>, Vector3<f64>) {
    let rot = nalgebra::Rotation3::new(Vector3::new(d[0], d[1], d[2])).into_inner() * r;
    let (b1, b2) = tangent_basis(t);
    (rot, (t + d[3] * b1 + d[4] * b2).normalize())
}

/// Signed Sampson residuals `(x2^T E x1) / sqrt(den) / sigma` of the chosen correspondences.
fn residuals(
    r: &Matrix3<f64>,
    t: &Vector3<f64>,
    x1: &[Point],
    x2: &[Point],
    idx: &[usize],
    sigma: Option<&[f64]>,
) -> Vec<f64> {
    let e = t.cross_matrix() * r;
    idx.iter()
        .map(|&i| {
            let (p, q) = (x1[i].push(1.0), x2[i].push(1.0));
            let (ep, etq) = (e * p, e.transpose() * q);
            let den = (ep.x * ep.x + ep.y * ep.y + etq.x * etq.x + etq.y * etq.y).max(1e-300);
            q.dot(&ep) / den.sqrt() / sigma.map_or(1.0, |s| s[i])
        })
        .collect()
}

/// Refines `(R, t)` (`|t| = 1`) by Levenberg-Marquardt on the Sampson errors
/// of the inliers, weighted by `1 / sigma`: 5 degrees of freedom (a rotation
/// increment, and `t` moved on the unit sphere). The linear eight-point
/// estimate minimises an algebraic error; this minimises the (first-order)
/// geometric one. Returns the input when there is nothing to gain.
pub fn refine_pose(
    r: &Matrix3<f64>,
    t: &Vector3<f64>,
    x1: &[Point],
    x2: &[Point],
    inliers: &[bool],
    sigma: Option<&[f64]>,
    iterations: usize,
) -> (Matrix3<f64>, Vector3<f64>) {
    let idx: Vec<usize> = (0..x1.len()).filter(|&i| inliers[i]).collect();
    let (mut r, mut t) = (*r, *t);
    if idx.len() < 6 {
        return (r, t);
    }
    let cost = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>();
    let mut res = residuals(&r, &t, x1, x2, &idx, sigma);
    let mut c = cost(&res);
    let mut lambda = 1e-3;
    for _ in 0..iterations {
        // forward-difference Jacobian, n x 5
        let h = 1e-7;
        let mut jac = DMatrix::<f64>::zeros(idx.len(), 5);
        for k in 0..5 {
            let mut d = [0.0; 5];
            d[k] = h;
            let (rk, tk) = perturb(&r, &t, &d);
            for (i, v) in residuals(&rk, &tk, x1, x2, &idx, sigma).iter().enumerate() {
                jac[(i, k)] = (v - res[i]) / h;
            }
        }
        let jtj = jac.transpose() * &jac;
        let jtr = jac.transpose() * nalgebra::DVector::from_column_slice(&res);
        let mut improved = false;
        for _ in 0..8 {
            let mut a = jtj.clone();
            for k in 0..5 {
                a[(k, k)] += lambda * jtj[(k, k)].max(1e-12);
            }
            let Some(step) = a.lu().solve(&(-&jtr)) else { break };
            let d = [step[0], step[1], step[2], step[3], step[4]];
            let (rn, tn) = perturb(&r, &t, &d);
            let rn_res = residuals(&rn, &tn, x1, x2, &idx, sigma);
            let cn = cost(&rn_res);
            if cn < c {
                improved = (c - cn) > 1e-12 * c;
                (r, t, res, c) = (rn, tn, rn_res, cn);
                lambda = (lambda * 0.3).max(1e-9);
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    (r, t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;

    /// A scene in front of both cameras and its two views.
    fn scene(n: usize, seed: u64, r: &Matrix3<f64>, t: &Vector3<f64>) -> (Vec<Point>, Vec<Point>) {
        let mut rng = SplitMix64::new(seed);
        let (mut a, mut b) = (Vec::new(), Vec::new());
        while a.len() < n {
            let p = Vector3::new(rng.next_f64() * 20.0 - 10.0, rng.next_f64() * 8.0 - 4.0, 4.0 + rng.next_f64() * 30.0);
            let q = r * p + t;
            if q.z > 0.5 {
                a.push(p.xy() / p.z);
                b.push(q.xy() / q.z);
            }
        }
        (a, b)
    }

    /// Replaces every `i % 10 < 3` second view (30%) by a random point at
    /// least 10 px (focal 700) off its true epipolar line.
    fn corrupt(x1: &[Point], x2: &mut [Point], r: &Matrix3<f64>, t: &Vector3<f64>, seed: u64) -> Vec<bool> {
        let e = t.cross_matrix() * r;
        let mut rng = SplitMix64::new(seed);
        let far = (10.0f64 / 700.0).powi(2);
        let mut outlier = vec![false; x1.len()];
        for i in (0..x1.len()).filter(|i| i % 10 < 3) {
            x2[i] = loop {
                let c = Point::new(rng.next_f64() - 0.5, rng.next_f64() * 0.6 - 0.3);
                if sampson(&e, &x1[i], &c) > far {
                    break c;
                }
            };
            outlier[i] = true;
        }
        outlier
    }

    fn motion() -> (Matrix3<f64>, Vector3<f64>) {
        let r = *Rotation3::from_euler_angles(0.02, -0.09, 0.01).matrix();
        (r, Vector3::new(0.15, -0.05, -0.98).normalize())
    }

    fn assert_pose(p: &RelativePose, r: &Matrix3<f64>, t: &Vector3<f64>, tol: f64) {
        assert!((p.rotation - r).norm() < tol, "R error {}", (p.rotation - r).norm());
        assert!((p.translation - t).norm() < tol, "t error {}", (p.translation - t).norm());
    }

    #[test]
    fn eight_point_recovers_a_known_motion_exactly() {
        let (r, t) = motion();
        for n in [8, 9, 40, 300] {
            let (x1, x2) = scene(n, n as u64, &r, &t);
            let e = eight_point(&x1, &x2).unwrap();
            // E is [t]x R up to sign
            let want = project_essential(&(t.cross_matrix() * r)).unwrap();
            assert!((e - want).norm().min((e + want).norm()) < 1e-9, "n = {n}");
            for (a, b) in x1.iter().zip(&x2) {
                assert!(sampson(&e, a, b) < 1e-20);
            }
            let p = recover_pose(&e, &x1, &x2, &vec![true; n], 1e9).unwrap();
            assert_pose(&p, &r, &t, 1e-6);
            assert_eq!(p.n_good, n);
        }
    }

    #[test]
    fn cheirality_picks_the_sign_of_a_forward_motion() {
        // pure forward motion along +z (the KITTI case) and a sideways one
        for t in [Vector3::new(0.0, 0.0, -1.0), Vector3::new(1.0, 0.0, 0.0), Vector3::new(0.0, 0.3, 1.0).normalize()] {
            let r = *Rotation3::from_euler_angles(0.0, 0.05, 0.0).matrix();
            let (x1, x2) = scene(60, 7, &r, &t);
            let e = eight_point(&x1, &x2).unwrap();
            let p = recover_pose(&e, &x1, &x2, &[true; 60], 1e9).unwrap();
            assert_pose(&p, &r, &t, 1e-6);
        }
    }

    #[test]
    fn degenerate_inputs_give_none() {
        let x = vec![Point::new(0.1, 0.2); 10];
        assert!(eight_point(&x, &x).is_none());
        assert!(eight_point(&x[..7], &x[..7]).is_none());
        assert!(ransac_essential(&x[..7], &x[..7], None, 700.0, &RansacOptions::default()).is_none());
    }

    #[test]
    fn ransac_with_30_percent_outliers() {
        let (r, t) = motion();
        let (mut x1, mut x2) = scene(140, 3, &r, &t);
        // 42 of 140 = 30% outliers
        let outlier = corrupt(&x1, &mut x2, &r, &t, 99);
        let mut rng = SplitMix64::new(98);
        // 0.5 px of noise on the inliers (focal 700)
        for p in x1.iter_mut().chain(x2.iter_mut()) {
            *p += Vector2::new(rng.next_f64() - 0.5, rng.next_f64() - 0.5) / 700.0;
        }
        let est = ransac_essential(&x1, &x2, None, 700.0, &RansacOptions { threshold_px: 1.5, ..Default::default() })
            .unwrap();
        let caught = est.inliers.iter().zip(&outlier).filter(|(i, o)| **o && !**i).count();
        let kept = est.inliers.iter().zip(&outlier).filter(|(i, o)| !**o && **i).count();
        assert_eq!(caught, 42, "every outlier rejected");
        assert!(kept >= 93, "inliers kept: {kept} of 98");
        let p = recover_pose(&est.e, &x1, &x2, &est.inliers, 1e9).unwrap();
        assert!((p.rotation - r).norm() < 2e-3, "R error {}", (p.rotation - r).norm());
        assert!((p.translation - t).norm() < 2e-2, "t error {}", (p.translation - t).norm());
        // deterministic
        let again = ransac_essential(&x1, &x2, None, 700.0, &RansacOptions { threshold_px: 1.5, ..Default::default() })
            .unwrap();
        assert_eq!(again, est);
    }

    #[test]
    fn ransac_without_noise_recovers_the_motion_to_1e6() {
        let (r, t) = motion();
        let (x1, mut x2) = scene(100, 5, &r, &t);
        corrupt(&x1, &mut x2, &r, &t, 1);
        let est = ransac_essential(&x1, &x2, None, 700.0, &RansacOptions::default()).unwrap();
        assert_eq!(est.n_inliers, 70);
        assert!(est.inliers.iter().enumerate().all(|(i, &v)| v == (i % 10 >= 3)));
        let p = recover_pose(&est.e, &x1, &x2, &est.inliers, 1e9).unwrap();
        assert_pose(&p, &r, &t, 1e-6);
        assert_eq!(est.iterations, 1000, "the minimum number of samples");
        // without a minimum, the adaptive bound for 70% inliers at 0.999:
        // ceil(ln(0.001) / ln(1 - 0.7^8)) = 117 samples at most
        let quick = ransac_essential(&x1, &x2, None, 700.0, &RansacOptions { min_iterations: 0, ..Default::default() });
        let quick = quick.unwrap();
        assert!(quick.iterations <= 117, "adaptive stop: {} samples", quick.iterations);
        assert_eq!(quick.inliers, est.inliers);
    }

    #[test]
    fn refinement_reduces_the_error_of_the_linear_estimate() {
        let (r, t) = motion();
        let (mut x1, mut x2) = scene(300, 11, &r, &t);
        let mut rng = SplitMix64::new(12);
        for p in x1.iter_mut().chain(x2.iter_mut()) {
            *p += Vector2::new(rng.next_f64() - 0.5, rng.next_f64() - 0.5) * (2.0 / 700.0); // +-1 px
        }
        let all = vec![true; 300];
        let lin = recover_pose(&eight_point(&x1, &x2).unwrap(), &x1, &x2, &all, 1e9).unwrap();
        let (rr, tr) = refine_pose(&lin.rotation, &lin.translation, &x1, &x2, &all, None, 20);
        let err = |a: &Matrix3<f64>, b: &Vector3<f64>| (a - r).norm() + (b - t).norm();
        let (before, after) = (err(&lin.rotation, &lin.translation), err(&rr, &tr));
        assert!(after < before, "refined {after:e} vs linear {before:e}");
        assert!((tr.norm() - 1.0).abs() < 1e-12 && (rr.determinant() - 1.0).abs() < 1e-9);
        let cost = |a: &Matrix3<f64>, b: &Vector3<f64>| {
            let e = b.cross_matrix() * a;
            x1.iter().zip(&x2).map(|(p, q)| sampson(&e, p, q)).sum::<f64>()
        };
        assert!(cost(&rr, &tr) < cost(&lin.rotation, &lin.translation));
        // exact data: already at the minimum, stays there
        let (y1, y2) = scene(50, 13, &r, &t);
        let (r0, t0) = refine_pose(&r, &t, &y1, &y2, &[true; 50], None, 20);
        assert!((r0 - r).norm() < 1e-9 && (t0 - t).norm() < 1e-9);
    }

    #[test]
    fn depths_of_a_known_point() {
        let (r, t) = motion();
        let p = Vector3::new(1.0, -0.5, 10.0);
        let q = r * p + t;
        let (z1, z2) = depths(&r, &t, &(p.xy() / p.z), &(q.xy() / q.z)).unwrap();
        assert!((z1 - 10.0).abs() < 1e-9 && (z2 - q.z).abs() < 1e-9);
    }

    #[test]
    fn splitmix_is_reproducible_and_in_range() {
        let mut a = SplitMix64::new(42);
        let mut b = SplitMix64::new(42);
        for _ in 0..1000 {
            let (x, y) = (a.below(7), b.below(7));
            assert_eq!(x, y);
            assert!(x < 7);
            let u = a.next_f64();
            b.next_f64();
            assert!((0.0..1.0).contains(&u));
        }
    }
}
