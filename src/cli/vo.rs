//! `lfast vo`: monocular visual odometry over a KITTI-format folder, and
//! `lfast ate`: the absolute trajectory error of a KITTI-format estimate.

use super::{CliError, Common};
use crate::cpu::matcher::MatchOptions;
use crate::vo::geometry::RansacOptions;
use crate::vo::{self, Align, FrontEnd, VoError, VoOptions, kitti};
use std::path::PathBuf;

mod recording;

pub(super) const VO_AFTER_HELP: &str = "\
SEQ_DIR is a KITTI odometry folder: image_0/*.png (sorted by name), calib.txt (P0, labelled
`P0:` or the first unlabelled row) and, optionally, poses.txt (ground truth, 3x4 camera-to-world).
It may also be a recording: an MCAP file (--topic, or its one image topic; the intrinsics from
its sensor_msgs/msg/CameraInfo topic, else --calib) or a video (--calib); --poses then gives the
ground truth, one pose per frame of the topic or video.
With poses, each step's length is the ground truth's (the monocular VO protocol) and the ATE
is computed. Outputs in OUT (OUT/<features>/ when several front ends are given):
  trajectory.txt  estimated poses, KITTI format      gt.txt      the ground truth of the same frames
  times.csv       per-frame times (ms) and counts    errors.csv  per-frame ATE (SE(3), Sim(3))
  summary.json    ATE statistics, mean times          trajectory.png, error_cdf.png
Several front ends (--features lfast,fast,orb) also write OUT/suite.md, a side-by-side table.
Check against evo: evo_ape kitti OUT/gt.txt OUT/trajectory.txt -a   (-as for Sim(3)).";

#[derive(clap::Args)]
pub(super) struct VoArgs {
    /// KITTI-format sequence folder, or a recording (MCAP file, video)
    seq_dir: PathBuf,
    /// Front end(s), comma-separated: lfast, fast, orb
    #[arg(long, value_enum, value_delimiter = ',', default_values_t = [FrontEnd::Lfast])]
    features: Vec<FrontEnd>,
    /// Output directory (created if missing)
    #[arg(long, short = 'o', value_name = "DIR")]
    out: PathBuf,
    /// Use only the first N frames, or frames START..END (0-based, END excluded)
    #[arg(long, value_name = "N|RANGE")]
    frames: Option<crate::recording::FrameRange>,
    /// Intrinsics (KITTI calib.txt: P0) for a recording without a CameraInfo topic, or to override it
    #[arg(long, value_name = "FILE")]
    calib: Option<PathBuf>,
    /// MCAP input: the image topic (default: the file's one image topic)
    #[arg(long, value_name = "NAME")]
    topic: Option<String>,
    /// Recordings: take every Nth frame
    #[arg(long, value_name = "N", default_value_t = 1, value_parser = clap::value_parser!(u64).range(1..))]
    every: u64,
    /// Recordings: times START..END in seconds from the first frame
    #[arg(long, value_name = "RANGE")]
    time: Option<crate::recording::TimeRange>,
    /// Ground-truth poses file (default: SEQ_DIR/poses.txt when present)
    #[arg(long, value_name = "FILE")]
    poses: Option<PathBuf>,
    /// Unit step length even when ground truth exists (the ATE is still computed)
    #[arg(long)]
    no_gt_scale: bool,
    /// FAST threshold of the fast and orb front ends
    #[arg(long, default_value_t = 20)]
    fast_threshold: i32,
    /// Keypoints per frame of the orb front end (when --n-features is not given)
    #[arg(long, default_value_t = 2000)]
    orb_features: u32,
    /// Lowe's ratio test threshold, in (0, 1]; 1 = off
    #[arg(long, default_value_t = 0.8)]
    ratio: f32,
    /// Largest Hamming distance of a match
    #[arg(long, default_value_t = 64)]
    max_distance: u32,
    /// Keep one-sided matches (no cross-check)
    #[arg(long)]
    no_cross_check: bool,
    /// RANSAC inlier threshold (Sampson distance, pixels)
    #[arg(long, default_value_t = 1.0)]
    ransac_threshold: f64,
    /// RANSAC samples drawn at least per frame pair (the adaptive bound may stop earlier otherwise)
    #[arg(long, default_value_t = 1000)]
    ransac_min_iterations: usize,
    /// RANSAC seed (runs are deterministic for a given seed)
    #[arg(long, default_value_t = 0x5eed)]
    seed: u64,
    /// Fewest cheirality-consistent inliers for a tracked frame (else constant velocity)
    #[arg(long, default_value_t = 20)]
    min_inliers: usize,
    /// Keep the linear eight-point pose (no Levenberg-Marquardt refinement on the inliers)
    #[arg(long)]
    no_refine: bool,
    #[command(flatten)]
    common: Common,
}

#[derive(clap::Args)]
pub(super) struct AteArgs {
    /// Ground-truth poses, KITTI format
    gt: PathBuf,
    /// Estimated poses, KITTI format (same number of lines)
    est: PathBuf,
    /// Alignment of the estimate onto the ground truth (evo: -a = se3, -as = sim3)
    #[arg(long, value_enum, default_value_t = AlignArg::Se3)]
    align: AlignArg,
    /// Print JSON instead of the table
    #[arg(long)]
    json: bool,
}

/// `--align` values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum AlignArg {
    /// No alignment
    None,
    /// Rotation + translation (Umeyama, evo -a)
    Se3,
    /// Rotation + translation + scale (Umeyama, evo -as)
    Sim3,
}

fn cli_err(e: VoError) -> CliError {
    match e {
        VoError::Lib(e) => CliError::Lib(e),
        e => CliError::Inputs(e.to_string()),
    }
}

/// `lfast vo`.
pub(super) fn run_vo(a: VoArgs) -> Result<bool, CliError> {
    let cfg = a.common.config()?;
    let (backend, gpu) = a.common.backend()?;
    let pool = a.common.pool()?;
    let range = a.frames.unwrap_or_default();
    let opts = VoOptions {
        features: FrontEnd::Lfast,
        backend,
        gpu,
        config: cfg,
        fast_threshold: a.fast_threshold,
        orb_features: a.orb_features,
        frames: range.end.map(|e| (e - range.start) as usize),
        start: range.start as usize,
        poses: a.poses.clone(),
        gt_scale: !a.no_gt_scale,
        matching: MatchOptions {
            cross_check: !a.no_cross_check,
            ratio: (a.ratio != 1.0).then_some(a.ratio),
            max_distance: a.max_distance,
        },
        ransac: RansacOptions {
            threshold_px: a.ransac_threshold,
            seed: a.seed,
            min_iterations: a.ransac_min_iterations,
            ..RansacOptions::default()
        },
        min_inliers: a.min_inliers,
        refine: !a.no_refine,
        ..VoOptions::default()
    };
    std::fs::create_dir_all(&a.out).map_err(|e| CliError::OutDir { path: a.out.clone(), reason: e.to_string() })?;
    let mut features = a.features.clone();
    let mut seen = std::collections::HashSet::new();
    features.retain(|f| seen.insert(*f));
    let several = features.len() > 1;
    let mut rows = Vec::new();
    let recording = crate::recording::format_of(&a.seq_dir).is_some();
    if !recording && (a.topic.is_some() || a.every != 1 || a.time.is_some() || a.calib.is_some()) {
        return Err(CliError::Usage("--topic, --every, --time and --calib are for recordings (MCAP, video)".into()));
    }
    let source = if recording { Some(recording::Source::new(&a)?) } else { None };
    let mut ok = true;
    for f in features {
        let o = VoOptions { features: f, ..opts.clone() };
        let run = match &source {
            None => pool.install(|| vo::run_sequence(&a.seq_dir, &o)),
            Some(src) => pool.install(|| src.run(&o)),
        }
        .map_err(cli_err)?;
        let dir = if several { a.out.join(f.to_string()) } else { a.out.clone() };
        let s = vo::write_outputs(&run, &dir).map_err(cli_err)?;
        if !a.common.quiet {
            println!("{}", line(&s, &dir));
        }
        if let Some(why) = &run.stopped {
            eprintln!("lfast: {}: {why}", a.seq_dir.display());
            ok = false;
        }
        rows.push(vo::SuiteRow { features: f, summary: s });
    }
    if several {
        let table = vo::SuiteTable { sequence: a.seq_dir.clone(), rows };
        let md = table.to_markdown();
        crate::io::write_atomic(&a.out.join("suite.md"), md.as_bytes())?;
        print!("{md}");
    }
    Ok(ok)
}

/// One line per run.
fn line(s: &vo::Summary, dir: &std::path::Path) -> String {
    let ate = match (&s.ate_se3, &s.ate_sim3) {
        (Some(a), Some(b)) => format!(
            "ATE RMSE {:.3} m (SE(3); mean {:.3}, max {:.3}), {:.3} m (Sim(3))",
            a.stats.rmse, a.stats.mean, a.stats.max, b.stats.rmse
        ),
        _ => s.ate_note.clone().map_or("no ground truth".to_string(), |n| format!("no ATE: {n}")),
    };
    format!(
        "{}: {} frames, {} lost, {:.0} keypoints, {:.0} inliers per frame; {ate}; {:.1} ms per frame \
         (detect {:.1}, match {:.1}, pose {:.1}; detector {}, matcher {:?}) -> {}",
        s.features,
        s.frames,
        s.lost_frames,
        s.mean_keypoints,
        s.mean_inliers,
        s.mean_ms.total,
        s.mean_ms.detect,
        s.mean_ms.matching,
        s.mean_ms.pose,
        s.detector_backend,
        s.matcher_backend,
        dir.display()
    )
    .replace("Cpu", "cpu")
    .replace("Gpu", "gpu")
}

/// `lfast ate`.
pub(super) fn run_ate(a: AteArgs) -> Result<bool, CliError> {
    let gt = kitti::read_poses(&a.gt).map_err(cli_err)?;
    let est = kitti::read_poses(&a.est).map_err(cli_err)?;
    let align = match a.align {
        AlignArg::None => Align::None,
        AlignArg::Se3 => Align::Se3,
        AlignArg::Sim3 => Align::Sim3,
    };
    let r = vo::ate::ate(&gt, &est, align).map_err(cli_err)?;
    if a.json {
        let j = serde_json::json!({
            "align": align, "poses": gt.len(), "scale": r.alignment.scale, "stats": r.stats,
        });
        println!("{}", serde_json::to_string_pretty(&j).unwrap_or_default());
    } else {
        let s = &r.stats;
        println!("APE w.r.t. translation part (m), {} poses, alignment {align}", gt.len());
        if align == Align::Sim3 {
            println!("{:>8} {:.6}", "scale", r.alignment.scale);
        }
        for (k, v) in [
            ("max", s.max),
            ("mean", s.mean),
            ("median", s.median),
            ("min", s.min),
            ("rmse", s.rmse),
            ("sse", s.sse),
            ("std", s.std),
        ] {
            println!("{k:>8} {v:.6}");
        }
    }
    Ok(true)
}
