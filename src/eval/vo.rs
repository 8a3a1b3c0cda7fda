//! Suite 6 (the paper's SLAM experiment, with our own front end): monocular
//! visual odometry over the KITTI sequence with [`crate::vo::run_suite`], for
//! FAST-9, ORB and the four L-FAST variants; the absolute trajectory error
//! after SE(3) and Sim(3) alignment, counts and times. Everything on the CPU.

use super::format::{Csv, csv_f, num, table};
use super::output::write_section;
use super::plot::{Bars, Panel, figure};
use super::{EvalError, Options, Result, Suite, Variant, colour_of, label};
use crate::vo::{FrontEnd, SuiteTable, VoOptions};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Frames of a quick run.
pub const QUICK_FRAMES: usize = 5;

/// One front end's run.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct VoRow {
    /// Detector key (`fast9`, `orb`, `lfast-...`).
    pub key: String,
    /// Frames processed.
    pub frames: usize,
    /// Frame pairs whose motion could not be estimated.
    pub lost: usize,
    /// Mean keypoints per frame.
    pub keypoints: f64,
    /// Mean RANSAC inliers per frame pair.
    pub inliers: f64,
    /// ATE RMSE after SE(3) alignment, metres (when ground truth allows it).
    pub ate_rmse: Option<f64>,
    /// ATE RMSE after Sim(3) alignment, metres.
    pub sim3_rmse: Option<f64>,
    /// Why the ATE is missing, if it is.
    pub ate_note: Option<String>,
    /// Mean detection + description ms per frame.
    pub detect_ms: f64,
    /// Mean matching ms per frame.
    pub match_ms: f64,
    /// Mean total ms per frame.
    pub total_ms: f64,
}

/// What the suite leaves for the report.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct VoSummary {
    /// The sequence folder.
    pub sequence: String,
    /// Per front end.
    pub rows: Vec<VoRow>,
}

/// The sequence folder of a KITTI-format folder: itself when it has
/// `image_0/`, else its first sub-folder (sorted) that has one.
pub fn sequence_dir(dir: &Path) -> Result<PathBuf> {
    if dir.join("image_0").is_dir() {
        return Ok(dir.to_path_buf());
    }
    let mut subs: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| EvalError::Data { path: dir.to_path_buf(), reason: e.to_string() })?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.join("image_0").is_dir())
        .collect();
    subs.sort();
    subs.into_iter().next().ok_or_else(|| EvalError::Data {
        path: dir.to_path_buf(),
        reason: "visual odometry needs a sequence folder with image_0/ and calib.txt".into(),
    })
}

fn rows_of(t: &SuiteTable, key: impl Fn(FrontEnd) -> String) -> Vec<VoRow> {
    t.rows
        .iter()
        .map(|r| {
            let m = &r.summary;
            VoRow {
                key: key(r.features),
                frames: m.frames,
                lost: m.lost_frames,
                keypoints: m.mean_keypoints,
                inliers: m.mean_inliers,
                ate_rmse: m.ate_se3.as_ref().map(|a| a.stats.rmse),
                sim3_rmse: m.ate_sim3.as_ref().map(|a| a.stats.rmse),
                ate_note: m.ate_note.clone(),
                detect_ms: m.mean_ms.detect,
                match_ms: m.mean_ms.matching,
                total_ms: m.mean_ms.total,
            }
        })
        .collect()
}

/// Runs the suite: `vo.csv`, `vo.png`, the section.
pub fn run(opts: &Options) -> Result<()> {
    let seq = sequence_dir(&opts.kitti)?;
    let base =
        VoOptions { backend: crate::Backend::Cpu, frames: opts.quick.then_some(QUICK_FRAMES), ..VoOptions::default() };
    let vo_err = |e: crate::vo::VoError| EvalError::Data { path: seq.clone(), reason: format!("visual odometry: {e}") };
    let mut rows = Vec::new();
    for v in Variant::ALL {
        let t = crate::vo::run_suite(&seq, &[FrontEnd::Lfast], &VoOptions { config: v.config(), ..base.clone() }, None)
            .map_err(vo_err)?;
        rows.extend(rows_of(&t, |_| v.key()));
    }
    let t =
        crate::vo::run_suite(&seq, &[FrontEnd::Fast, FrontEnd::Orb, FrontEnd::Orbslam], &base, None).map_err(vo_err)?;
    rows.extend(rows_of(&t, |f| match f {
        FrontEnd::Fast => "fast9".into(),
        other => other.name().into(),
    }));

    let opt = |v: Option<f64>| v.unwrap_or(f64::NAN);
    let mut csv = Csv::new(&[
        "detector",
        "frames",
        "lost",
        "keypoints",
        "inliers",
        "ate_rmse_se3_m",
        "ate_rmse_sim3_m",
        "detect_ms",
        "match_ms",
        "total_ms",
        "note",
    ]);
    for r in &rows {
        csv.row(vec![
            r.key.clone(),
            r.frames.to_string(),
            r.lost.to_string(),
            csv_f(r.keypoints),
            csv_f(r.inliers),
            csv_f(opt(r.ate_rmse)),
            csv_f(opt(r.sim3_rmse)),
            csv_f(r.detect_ms),
            csv_f(r.match_ms),
            csv_f(r.total_ms),
            r.ate_note.clone().unwrap_or_default(),
        ]);
    }
    csv.write(&opts.out.join("vo.csv"))?;
    figure(
        &opts.out.join("vo.png"),
        (1000, 480),
        (1, 1),
        &[Panel::Bar {
            title: "Visual odometry: ATE RMSE after SE(3) and Sim(3) alignment".into(),
            y_desc: "m".into(),
            categories: vec!["ATE RMSE".into(), "Sim(3) RMSE".into()],
            bars: rows
                .iter()
                .map(|r| Bars {
                    name: label(&r.key),
                    colour: colour_of(&r.key),
                    values: vec![opt(r.ate_rmse), opt(r.sim3_rmse)],
                })
                .collect(),
        }],
    )?;
    let trow: Vec<Vec<String>> = rows
        .iter()
        .map(|r| {
            vec![
                label(&r.key),
                r.frames.to_string(),
                r.lost.to_string(),
                num(r.keypoints, 0),
                num(r.inliers, 0),
                r.ate_rmse.map_or_else(|| r.ate_note.clone().unwrap_or("–".into()), |v| num(v, 3)),
                num(opt(r.sim3_rmse), 3),
                num(r.detect_ms, 1),
                num(r.match_ms, 1),
                num(r.total_ms, 1),
            ]
        })
        .collect();
    let md = format!(
        "## 6. Visual odometry (the paper's SLAM experiment, with lfast's own front end)\n\n\
         `lfast::vo::run_suite` on `{}` ({} frames, CPU): consecutive-frame Hamming matching, essential matrix \
         with RANSAC, each step scaled by the ground truth (the monocular protocol), chained; ATE as evo's APE on \
         positions (docs/vo.md). Files: `vo.csv`, `vo.png`.\n\n{}\n\
         Paper: its trajectory experiment (Tables 3-5) runs a full SLAM system on its own sequences; those \
         numbers are not comparable with this odometry front end, so they are not set side by side.\n\n![vo](vo.png)\n",
        seq.display(),
        rows.first().map_or(0, |r| r.frames),
        table(
            &[
                "detector",
                "frames",
                "lost",
                "keypoints",
                "inliers",
                "ATE RMSE (m)",
                "Sim(3) RMSE (m)",
                "detect ms",
                "match ms",
                "total ms"
            ],
            &trow
        ),
    );
    write_section(&opts.out, Suite::Vo, &md, &VoSummary { sequence: seq.display().to_string(), rows })
}
