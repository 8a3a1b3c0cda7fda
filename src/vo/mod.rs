//! Monocular visual odometry and absolute trajectory error: the paper's SLAM
//! experiment (Tables 3-5, Figs 11-12) with our own front end.
//!
//! - [`kitti`]: `calib.txt` and poses files.
//! - [`geometry`]: normalised eight-point essential matrix, seeded RANSAC,
//!   pose recovery with the cheirality check.
//! - [`ate`]: Umeyama SE(3)/Sim(3) alignment and the error statistics evo reports.
//! - [`run_sequence`]: features (L-FAST, FAST-9 or ORB) in each frame,
//!   Hamming matching of consecutive frames ([`crate::cpu::matcher`] or the
//!   GPU's [`crate::gpu::matcher`], identical), E with RANSAC, R and t,
//!   chained; the scale of each step from the ground truth when there is one
//!   (the standard monocular protocol), else 1.
//! - [`write_outputs`]: trajectory (KITTI format), per-frame times, ATE, plots.
//! - [`run_suite`]: all three front ends on one sequence, side by side.
//!
//! See docs/vo.md.

pub mod ate;
pub mod geometry;
pub mod kitti;
mod output;
mod pipeline;
mod plot;

pub use ate::{Align, Ate, Stats};
pub use output::{Summary, write_outputs};
pub use pipeline::{FrameRecord, FrontEnd, InputFrame, MatcherBackend, VoOptions, VoRun, run_frames, run_sequence};

use nalgebra::{Matrix3, Vector3};
use std::path::PathBuf;

/// What can go wrong in visual odometry and trajectory evaluation.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum VoError {
    /// From the detector, the matcher, the GPU or file I/O.
    #[error(transparent)]
    Lib(#[from] crate::Error),
    /// A calibration or poses file is malformed (`line` 1-based; 0 = the whole file).
    #[error("{}{}: {reason}", path.display(), if *line > 0 { format!(", line {line}") } else { String::new() })]
    Parse {
        /// The file.
        path: PathBuf,
        /// Line number.
        line: usize,
        /// What is wrong.
        reason: String,
    },
    /// The sequence folder is not usable (no frames, no calibration, too few poses).
    #[error("sequence {}: {reason}", path.display())]
    Sequence {
        /// The folder.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// Trajectories cannot be compared (lengths differ, degenerate alignment).
    #[error("trajectory: {reason}")]
    Trajectory {
        /// What is wrong.
        reason: String,
    },
    /// An option is out of range.
    #[error("invalid option `{field}`: {reason}")]
    Options {
        /// The option.
        field: &'static str,
        /// What is wrong.
        reason: String,
    },
    /// A plot could not be drawn or written.
    #[error("plot {}: {reason}", path.display())]
    Plot {
        /// The PNG file.
        path: PathBuf,
        /// The plotting library's message.
        reason: String,
    },
}

/// A rigid camera pose `[R | t]`; for KITTI poses, camera-to-world.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Rotation.
    pub rotation: Matrix3<f64>,
    /// Translation (the camera centre, for camera-to-world poses).
    pub translation: Vector3<f64>,
}

impl Pose {
    /// The identity.
    pub fn identity() -> Self {
        Self { rotation: Matrix3::identity(), translation: Vector3::zeros() }
    }

    /// A pure translation.
    pub fn from_translation(t: Vector3<f64>) -> Self {
        Self { rotation: Matrix3::identity(), translation: t }
    }

    /// `self * other` (apply `other` first).
    pub fn compose(&self, other: &Pose) -> Pose {
        Pose {
            rotation: self.rotation * other.rotation,
            translation: self.rotation * other.translation + self.translation,
        }
    }

    /// The inverse `[R^T | -R^T t]`.
    pub fn inverse(&self) -> Pose {
        let rt = self.rotation.transpose();
        Pose { rotation: rt, translation: -(rt * self.translation) }
    }
}

/// One row of [`run_suite`]'s table.
#[derive(Clone, Debug, serde::Serialize)]
pub struct SuiteRow {
    /// The front end.
    pub features: FrontEnd,
    /// The run's summary (ATE, times, counts).
    pub summary: Summary,
}

/// [`run_suite`]'s result: one row per front end.
#[derive(Clone, Debug, serde::Serialize)]
pub struct SuiteTable {
    /// The sequence folder.
    pub sequence: PathBuf,
    /// Rows in the order run.
    pub rows: Vec<SuiteRow>,
}

impl SuiteTable {
    /// A Markdown table: ATE (SE(3) and Sim(3)) and mean per-frame times.
    pub fn to_markdown(&self) -> String {
        let mut s = String::from(
            "| features | frames | keypoints | inliers | lost | ATE RMSE (m) | mean | median | std | min | max | Sim(3) RMSE (m) | detect (ms) | match (ms) | pose (ms) | total (ms) |\n\
             |---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
        );
        let f = |v: Option<f64>| v.map_or("–".to_string(), |v| format!("{v:.3}"));
        for r in &self.rows {
            let m = &r.summary;
            let a = m.ate_se3.as_ref().map(|a| a.stats);
            s.push_str(&format!(
                "| {} | {} | {:.0} | {:.0} | {} | {} | {} | {} | {} | {} | {} | {} | {:.1} | {:.1} | {:.1} | {:.1} |\n",
                r.features,
                m.frames,
                m.mean_keypoints,
                m.mean_inliers,
                m.lost_frames,
                f(a.map(|a| a.rmse)),
                f(a.map(|a| a.mean)),
                f(a.map(|a| a.median)),
                f(a.map(|a| a.std)),
                f(a.map(|a| a.min)),
                f(a.map(|a| a.max)),
                f(m.ate_sim3.as_ref().map(|a| a.stats.rmse)),
                m.mean_ms.detect,
                m.mean_ms.matching,
                m.mean_ms.pose,
                m.mean_ms.total,
            ));
        }
        s
    }
}

/// The `vo` evaluation suite: runs every front end in `features` on the
/// sequence `seq_dir` with `base` options (its `features` field is
/// replaced), writing each run's outputs under `out_dir/<features>/` when
/// given, and returns the side-by-side table.
pub fn run_suite(
    seq_dir: &std::path::Path,
    features: &[FrontEnd],
    base: &VoOptions,
    out_dir: Option<&std::path::Path>,
) -> Result<SuiteTable, VoError> {
    let mut rows = Vec::new();
    for &f in features {
        let opts = VoOptions { features: f, ..base.clone() };
        let run = run_sequence(seq_dir, &opts)?;
        let summary = match out_dir {
            Some(d) => write_outputs(&run, &d.join(f.to_string()))?,
            None => Summary::of(&run)?,
        };
        rows.push(SuiteRow { features: f, summary });
    }
    Ok(SuiteTable { sequence: seq_dir.to_path_buf(), rows })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;

    #[test]
    fn pose_compose_and_inverse() {
        let a = Pose {
            rotation: *Rotation3::from_euler_angles(0.1, 0.2, 0.3).matrix(),
            translation: Vector3::new(1.0, 2.0, 3.0),
        };
        let b = Pose {
            rotation: *Rotation3::from_euler_angles(-0.3, 0.0, 0.5).matrix(),
            translation: Vector3::new(0.0, -1.0, 4.0),
        };
        let p = Vector3::new(0.5, 0.25, -2.0);
        let ab = a.compose(&b);
        assert!(
            (ab.rotation * p + ab.translation - (a.rotation * (b.rotation * p + b.translation) + a.translation)).norm()
                < 1e-12
        );
        let id = a.compose(&a.inverse());
        assert!((id.rotation - Matrix3::identity()).norm() < 1e-12 && id.translation.norm() < 1e-12);
    }
}
