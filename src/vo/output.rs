//! What `lfast vo` writes: the trajectory (KITTI format), the ground truth
//! of the same frames, per-frame times and errors (CSV), a JSON summary and
//! two plots.

use super::ate::{Align, Ate, ate};
use super::pipeline::{FrontEnd, MatcherBackend, VoRun};
use super::{VoError, kitti, plot};
use std::path::Path;

/// Mean per-frame times in milliseconds (frame 0, which has nothing to
/// match, is left out of every mean).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct MeanTimes {
    /// Image decoding (not in `total`).
    pub load: f64,
    /// Detection and description.
    pub detect: f64,
    /// Matching.
    pub matching: f64,
    /// RANSAC, pose recovery, chaining.
    pub pose: f64,
    /// detect + matching + pose.
    pub total: f64,
}

/// A run in numbers.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Summary {
    /// Front end.
    pub features: FrontEnd,
    /// Where detection ran.
    pub detector_backend: String,
    /// Where matching ran.
    pub matcher_backend: MatcherBackend,
    /// Frames processed.
    pub frames: usize,
    /// Frame pairs whose motion could not be estimated.
    pub lost_frames: usize,
    /// Mean keypoints per frame.
    pub mean_keypoints: f64,
    /// Mean matches per frame pair.
    pub mean_matches: f64,
    /// Mean RANSAC inliers per frame pair.
    pub mean_inliers: f64,
    /// Mean times.
    pub mean_ms: MeanTimes,
    /// Whether steps were scaled by the ground truth.
    pub gt_scale: bool,
    /// ATE after SE(3) alignment (when ground truth exists and alignment is possible).
    pub ate_se3: Option<Ate>,
    /// ATE after Sim(3) alignment.
    pub ate_sim3: Option<Ate>,
    /// Why the ATE is missing despite ground truth (e.g. too few frames to align).
    pub ate_note: Option<String>,
}

fn mean(v: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    if n == 0 { 0.0 } else { s / n as f64 }
}

impl Summary {
    /// Computes the summary of a run (the ATE included, when it has ground truth).
    pub fn of(run: &VoRun) -> Result<Self, VoError> {
        let r = &run.records;
        let pairs = || r.iter().skip(1);
        let (mut ate_se3, mut ate_sim3, mut ate_note) = (None, None, None);
        if let Some(gt) = &run.gt {
            match (ate(gt, &run.poses, Align::Se3), ate(gt, &run.poses, Align::Sim3)) {
                (Ok(a), Ok(b)) => (ate_se3, ate_sim3) = (Some(a), Some(b)),
                (Err(e), _) | (_, Err(e)) => ate_note = Some(e.to_string()),
            }
        }
        Ok(Self {
            features: run.options.features,
            detector_backend: run.detector_backend.to_string(),
            matcher_backend: run.matcher_backend,
            frames: r.len(),
            lost_frames: r.iter().filter(|f| !f.tracked).count(),
            mean_keypoints: mean(r.iter().map(|f| f.keypoints as f64)),
            mean_matches: mean(pairs().map(|f| f.matches as f64)),
            mean_inliers: mean(pairs().map(|f| f.inliers as f64)),
            mean_ms: MeanTimes {
                load: mean(pairs().map(|f| f.load_ms)),
                detect: mean(pairs().map(|f| f.detect_ms)),
                matching: mean(pairs().map(|f| f.match_ms)),
                pose: mean(pairs().map(|f| f.pose_ms)),
                total: mean(pairs().map(|f| f.total_ms)),
            },
            gt_scale: run.gt.is_some() && run.options.gt_scale,
            ate_se3,
            ate_sim3,
            ate_note,
        })
    }
}

fn write(path: &Path, bytes: &[u8]) -> Result<(), VoError> {
    Ok(crate::io::write_atomic(path, bytes)?)
}

/// Writes a run's outputs into `dir` (created if missing):
/// `trajectory.txt` (KITTI format), `gt.txt` (the ground truth of the same
/// frames, when there is one), `times.csv`, `errors.csv`, `summary.json`,
/// `trajectory.png` (top down, x-z) and `error_cdf.png`. Returns the summary.
pub fn write_outputs(run: &VoRun, dir: &Path) -> Result<Summary, VoError> {
    std::fs::create_dir_all(dir).map_err(|source| crate::Error::Io { path: dir.to_path_buf(), source })?;
    let summary = Summary::of(run)?;
    write(&dir.join("trajectory.txt"), kitti::format_poses(&run.poses).as_bytes())?;
    if let Some(gt) = &run.gt {
        write(&dir.join("gt.txt"), kitti::format_poses(gt).as_bytes())?;
    }
    let mut csv =
        String::from("frame,name,load_ms,detect_ms,match_ms,pose_ms,total_ms,keypoints,matches,inliers,good,tracked\n");
    for f in &run.records {
        csv.push_str(&format!(
            "{},{},{:.3},{:.3},{:.3},{:.3},{:.3},{},{},{},{},{}\n",
            f.frame,
            f.name,
            f.load_ms,
            f.detect_ms,
            f.match_ms,
            f.pose_ms,
            f.total_ms,
            f.keypoints,
            f.matches,
            f.inliers,
            f.good,
            f.tracked
        ));
    }
    write(&dir.join("times.csv"), csv.as_bytes())?;
    if let (Some(a), Some(b)) = (&summary.ate_se3, &summary.ate_sim3) {
        let mut e = String::from("frame,error_se3_m,error_sim3_m\n");
        for (i, (x, y)) in a.errors.iter().zip(&b.errors).enumerate() {
            e.push_str(&format!("{i},{x:.6},{y:.6}\n"));
        }
        write(&dir.join("errors.csv"), e.as_bytes())?;
    }
    let json = serde_json::to_string_pretty(&summary)
        .map_err(|e| VoError::Trajectory { reason: format!("summary serialisation: {e}") })?;
    write(&dir.join("summary.json"), json.as_bytes())?;
    let title = format!(
        "{} — {}",
        run.options.features,
        run.sequence.file_name().map(|n| n.to_string_lossy()).unwrap_or_default()
    );
    plot::trajectory(&dir.join("trajectory.png"), &title, run.gt.as_deref(), &run.poses)?;
    if let Some(a) = &summary.ate_se3 {
        let mut curves = vec![("SE(3)".to_string(), a.errors.clone())];
        if let Some(b) = &summary.ate_sim3 {
            curves.push(("Sim(3)".to_string(), b.errors.clone()));
        }
        plot::error_cdf(&dir.join("error_cdf.png"), &title, &curves)?;
    }
    Ok(summary)
}
