//! The frame loop: detect, match with the previous frame, estimate the
//! relative motion, chain it.

use super::geometry::{self, Point, RansacOptions};
use super::kitti::{self, Calib};
use super::{Pose, VoError};
use crate::config::Config;
use crate::cpu::matcher::{self, Match, MatchOptions};
use crate::frontend::Features;
use crate::gpu::matcher::GpuMatcher;
use crate::gpu::{GpuContext, GpuOptions};
use crate::{Backend, Descriptor, Detector, KeyPoint};
use nalgebra::{Matrix3, Vector3};
use std::path::{Path, PathBuf};
use std::time::Instant;

pub use crate::frontend::FrontEnd;

/// Where matching runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum MatcherBackend {
    /// src/cpu/matcher.rs
    Cpu,
    /// shaders/matcher.wgsl
    Gpu,
}

/// Everything a run depends on.
#[derive(Clone, Debug)]
pub struct VoOptions {
    /// The front end.
    pub features: FrontEnd,
    /// Where L-FAST detection and matching run (FAST-9 and ORB detection always on the CPU).
    pub backend: Backend,
    /// Which GPU adapter.
    pub gpu: GpuOptions,
    /// The L-FAST configuration; its pyramid serves ORB, its descriptor
    /// settings FAST-9's descriptors, and `n_features` (when not 0) caps
    /// every front end.
    pub config: Config,
    /// FAST threshold of the FAST-9 and ORB front ends.
    pub fast_threshold: i32,
    /// Keypoints per frame of the ORB front end when `config.n_features` is 0.
    pub orb_features: u32,
    /// Use only the first N frames (of those from [`VoOptions::start`] on).
    pub frames: Option<usize>,
    /// Skip the frames before this one (the ground truth is taken from it on too).
    pub start: usize,
    /// Ground-truth poses (default: `SEQ/poses.txt` when it exists).
    pub poses: Option<PathBuf>,
    /// Scale each step by the ground-truth translation norm (when poses exist).
    pub gt_scale: bool,
    /// Matcher filters.
    pub matching: MatchOptions,
    /// Essential-matrix RANSAC.
    pub ransac: RansacOptions,
    /// A frame pair with fewer cheirality-consistent inliers is "lost": the
    /// previous relative motion is repeated (constant velocity).
    pub min_inliers: usize,
    /// Cheirality: points farther than this many baselines do not count.
    pub max_depth: f64,
    /// Refine each relative pose on its inliers (Levenberg-Marquardt on the
    /// Sampson error) after the linear estimate.
    pub refine: bool,
}

impl Default for VoOptions {
    fn default() -> Self {
        Self {
            features: FrontEnd::Lfast,
            backend: Backend::Auto,
            gpu: GpuOptions::default(),
            config: Config::default(),
            fast_threshold: 20,
            orb_features: 2000,
            frames: None,
            start: 0,
            poses: None,
            gt_scale: true,
            matching: MatchOptions::default(),
            ransac: RansacOptions::default(),
            min_inliers: 20,
            max_depth: 50.0,
            refine: true,
        }
    }
}

/// One frame's counts and times (milliseconds).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct FrameRecord {
    /// Index in the sequence.
    pub frame: usize,
    /// Image file name.
    pub name: String,
    /// Decoding the image (not part of the per-frame time).
    pub load_ms: f64,
    /// Detection and description.
    pub detect_ms: f64,
    /// Matching with the previous frame.
    pub match_ms: f64,
    /// RANSAC, pose recovery, chaining.
    pub pose_ms: f64,
    /// detect + match + pose: the per-frame time of Table 5.
    pub total_ms: f64,
    /// Keypoints detected.
    pub keypoints: usize,
    /// Matches kept by the matcher.
    pub matches: usize,
    /// RANSAC inliers.
    pub inliers: usize,
    /// Inliers triangulated in front of both cameras.
    pub good: usize,
    /// False when the motion could not be estimated (frame 0 is tracked).
    pub tracked: bool,
}

/// A finished run.
#[derive(Clone, Debug)]
pub struct VoRun {
    /// The sequence folder.
    pub sequence: PathBuf,
    /// The options it ran with.
    pub options: VoOptions,
    /// `"gpu"` or `"cpu"`: where detection ran.
    pub detector_backend: &'static str,
    /// Where matching ran.
    pub matcher_backend: MatcherBackend,
    /// The calibration.
    pub calib: Calib,
    /// Estimated camera-to-world poses, one per frame.
    pub poses: Vec<Pose>,
    /// Ground truth for the same frames, when the sequence has it.
    pub gt: Option<Vec<Pose>>,
    /// Per-frame records.
    pub records: Vec<FrameRecord>,
    /// Why the frames ended early (a damaged recording): the run holds the
    /// frames before it; `None` when every frame was read.
    pub stopped: Option<String>,
}

/// One input frame of [`run_frames`]: its index in the sequence (the row of
/// the ground truth), its name, and the image.
pub type InputFrame = (usize, String, crate::image::Plane<u8>);

const IMAGE_EXT: [&str; 7] = ["png", "jpg", "jpeg", "tif", "tiff", "pgm", "bmp"];

/// The frames of `SEQ/image_0`, sorted by name.
pub fn list_frames(seq: &Path) -> Result<Vec<PathBuf>, VoError> {
    let dir = seq.join("image_0");
    let rd = std::fs::read_dir(&dir).map_err(|e| VoError::Sequence {
        path: seq.to_path_buf(),
        reason: format!(
            "cannot read {}: {e} (expected KITTI layout: image_0/*.png, calib.txt, poses.txt)",
            dir.display()
        ),
    })?;
    let mut v: Vec<PathBuf> = rd
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.is_file()
                && !p.file_name().and_then(|n| n.to_str()).is_some_and(|n| n.starts_with('.'))
                && p.extension()
                    .and_then(|e| e.to_str())
                    .is_some_and(|e| IMAGE_EXT.contains(&e.to_ascii_lowercase().as_str()))
        })
        .collect();
    v.sort();
    if v.is_empty() {
        return Err(VoError::Sequence { path: seq.to_path_buf(), reason: format!("no images in {}", dir.display()) });
    }
    Ok(v)
}

enum Matcher {
    Cpu,
    Gpu { m: Box<GpuMatcher>, fallback: bool },
}

impl Matcher {
    fn run(&mut self, q: &[Descriptor], t: &[Descriptor], o: &MatchOptions) -> crate::Result<Vec<Match>> {
        match self {
            Matcher::Cpu => matcher::match_descriptors(q, t, o),
            Matcher::Gpu { m, fallback } => match m.match_descriptors(q, t, o) {
                Ok(v) => Ok(v),
                Err(e @ crate::Error::InvalidConfig { .. }) => Err(e),
                Err(e) if *fallback => {
                    log::warn!("GPU matcher failed ({e}); matching on the CPU from now on");
                    *self = Matcher::Cpu;
                    matcher::match_descriptors(q, t, o)
                }
                Err(e) => Err(e),
            },
        }
    }

    fn backend(&self) -> MatcherBackend {
        match self {
            Matcher::Cpu => MatcherBackend::Cpu,
            Matcher::Gpu { .. } => MatcherBackend::Gpu,
        }
    }
}

fn validate(o: &VoOptions) -> Result<(), VoError> {
    let bad = |field, reason: String| Err(VoError::Options { field, reason });
    o.config.validate()?;
    o.matching.ratio_q16()?;
    let r = &o.ransac;
    if !(r.threshold_px > 0.0 && r.threshold_px.is_finite()) {
        return bad("ransac.threshold_px", format!("must be positive, got {}", r.threshold_px));
    }
    if !(r.confidence > 0.0 && r.confidence < 1.0) {
        return bad("ransac.confidence", format!("must be in (0, 1), got {}", r.confidence));
    }
    if r.max_iterations == 0 {
        return bad("ransac.max_iterations", "must be at least 1".into());
    }
    if o.min_inliers < 8 {
        return bad("min_inliers", format!("must be at least 8 (the eight-point sample), got {}", o.min_inliers));
    }
    if o.max_depth.is_nan() || o.max_depth <= 0.0 {
        return bad("max_depth", format!("must be positive, got {}", o.max_depth));
    }
    if o.frames == Some(0) {
        return bad("frames", "must be at least 1".into());
    }
    if matches!(o.features, FrontEnd::Orb | FrontEnd::Orbslam) && o.config.n_features == 0 && o.orb_features == 0 {
        return bad("orb_features", "must be at least 1".into());
    }
    Ok(())
}

/// The GPU context for `backend` (`None` on the CPU, or in auto mode without an adapter).
fn gpu_context(o: &VoOptions) -> Result<Option<GpuContext>, VoError> {
    match o.backend {
        Backend::Cpu => Ok(None),
        Backend::Gpu => Ok(Some(GpuContext::new(&o.gpu)?)),
        Backend::Auto => match GpuContext::new_auto(&o.gpu) {
            Ok(c) => Ok(Some(c)),
            Err(e) => {
                log::warn!("GPU unavailable ({e}); detection and matching run on the CPU");
                Ok(None)
            }
        },
    }
}

fn features(o: &VoOptions, ctx: Option<&GpuContext>) -> Result<Features, VoError> {
    let cfg = o.config.clone();
    Ok(match o.features {
        FrontEnd::Lfast => Features::lfast(match (ctx, o.backend) {
            (None, _) => Detector::new(cfg, Backend::Cpu)?,
            (Some(c), Backend::Gpu) => Detector::from_context(c.clone(), cfg)?,
            (Some(c), _) => match Detector::from_context_with_fallback(c.clone(), cfg.clone()) {
                Ok(d) => d,
                Err(e) => {
                    log::warn!("GPU detector unavailable ({e}); detecting on the CPU");
                    Detector::new(cfg, Backend::Cpu)?
                }
            },
        }),
        kind => Features::cpu(kind, cfg, o.fast_threshold, o.orb_features)?,
    })
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// The relative motion of one frame pair: `X_cur = R X_prev + t`, `|t| = 1`.
struct Step {
    rotation: Matrix3<f64>,
    translation: Vector3<f64>,
    inliers: usize,
    good: usize,
}

fn estimate(kp1: &[KeyPoint], kp2: &[KeyPoint], m: &[Match], calib: &Calib, o: &VoOptions, seed: u64) -> Option<Step> {
    let k = calib.intrinsics();
    let pt = |kp: &KeyPoint| k.normalise(kp.pt.x as f64, kp.pt.y as f64);
    let x1: Vec<Point> = m.iter().map(|m| pt(&kp1[m.query as usize])).collect();
    let x2: Vec<Point> = m.iter().map(|m| pt(&kp2[m.train as usize])).collect();
    // a keypoint found on level l is located to about s^l pixels
    let level = |kp: &KeyPoint| o.config.level_scale(kp.octave.max(0) as u32);
    let sigma: Vec<f64> = m.iter().map(|m| level(&kp1[m.query as usize]).max(level(&kp2[m.train as usize]))).collect();
    let ransac = RansacOptions { seed, ..o.ransac };
    let e = geometry::ransac_essential(&x1, &x2, Some(&sigma), k.focal(), &ransac)?;
    let p = geometry::recover_pose(&e.e, &x1, &x2, &e.inliers, o.max_depth)?;
    if !o.refine {
        return Some(Step { rotation: p.rotation, translation: p.translation, inliers: e.n_inliers, good: p.n_good });
    }
    let (r, t) = geometry::refine_pose(&p.rotation, &p.translation, &x1, &x2, &e.inliers, Some(&sigma), 20);
    let thr = o.ransac.threshold_px / k.focal();
    let (inl, n_inliers) = geometry::score(&(t.cross_matrix() * r), &x1, &x2, Some(&sigma), thr * thr);
    let (_, good) = geometry::cheirality(&r, &t, &x1, &x2, &inl, o.max_depth);
    Some(Step { rotation: r, translation: t, inliers: n_inliers, good })
}

/// Runs monocular VO over a KITTI-format folder: `SEQ/image_0/*` (sorted by
/// name), `SEQ/calib.txt` (P0) and, optionally, `SEQ/poses.txt`.
pub fn run_sequence(seq: &Path, o: &VoOptions) -> Result<VoRun, VoError> {
    validate(o)?;
    let mut frames = list_frames(seq)?;
    let start = o.start.min(frames.len());
    frames.drain(..start);
    if let Some(n) = o.frames {
        frames.truncate(n);
    }
    if frames.is_empty() {
        return Err(VoError::Sequence {
            path: seq.to_path_buf(),
            reason: format!("no frame from frame {} on", o.start),
        });
    }
    let calib = kitti::read_calib(&seq.join("calib.txt"))?;
    let poses_path = o.poses.clone().or_else(|| Some(seq.join("poses.txt")).filter(|p| p.exists()));
    let gt = match &poses_path {
        Some(p) => {
            let g = kitti::read_poses(p)?;
            if g.len() < start + frames.len() {
                return Err(VoError::Sequence {
                    path: seq.to_path_buf(),
                    reason: format!("{} has {} poses for {} frames", p.display(), g.len(), start + frames.len()),
                });
            }
            Some(g)
        }
        None => None,
    };
    let mut loader = crate::image::GrayLoader::default();
    let images = frames.into_iter().enumerate().map(move |(i, path)| {
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        Ok((start + i, name, loader.load(&path)?))
    });
    run_frames(seq, images, calib, gt.as_deref(), o)
}

/// Runs monocular VO over `frames` with the intrinsics of `calib`; `gt`
/// (indexed by the frames' indices) scales each step and is the ground truth
/// of the run. A frame that is an `Err` ends the run: a [`VoError::Sequence`]
/// (a damaged recording) is kept in [`VoRun::stopped`] with the frames
/// before it, any other error is returned. `o.start` and `o.frames` are the
/// caller's to apply.
pub fn run_frames(
    sequence: &Path,
    frames: impl IntoIterator<Item = Result<InputFrame, VoError>>,
    calib: Calib,
    gt: Option<&[Pose]>,
    o: &VoOptions,
) -> Result<VoRun, VoError> {
    validate(o)?;
    let ctx = gpu_context(o)?;
    let det = features(o, ctx.as_ref())?;
    let mut mat = match ctx {
        None => Matcher::Cpu,
        Some(c) => match GpuMatcher::new(c) {
            Ok(m) => Matcher::Gpu { m: Box::new(m), fallback: o.backend == Backend::Auto },
            Err(e) if o.backend == Backend::Auto => {
                log::warn!("GPU matcher unavailable ({e}); matching on the CPU");
                Matcher::Cpu
            }
            Err(e) => return Err(e.into()),
        },
    };
    let gt_of = |index: usize| -> Result<Option<Pose>, VoError> {
        match gt {
            None => Ok(None),
            Some(g) => g.get(index).copied().map(Some).ok_or_else(|| VoError::Sequence {
                path: sequence.to_path_buf(),
                reason: format!("the ground truth has {} poses; frame {index} has none", g.len()),
            }),
        }
    };

    let mut poses: Vec<Pose> = Vec::new();
    let mut gt_used: Vec<Pose> = Vec::new();
    let mut records = Vec::new();
    let mut prev: Option<(Vec<KeyPoint>, Vec<Descriptor>)> = None;
    let mut last_step: Option<(Matrix3<f64>, Vector3<f64>)> = None;
    let mut stopped = None;
    for (i, frame) in frames.into_iter().enumerate() {
        let t = Instant::now();
        let (index, name, img) = match frame {
            Ok(f) => f,
            Err(VoError::Sequence { reason, .. }) => {
                stopped = Some(reason);
                break;
            }
            Err(e) => return Err(e),
        };
        let load_ms = ms(t);
        let g = gt_of(index)?;
        let t = Instant::now();
        let (kps, desc) = det.detect_and_compute(&img)?;
        let detect_ms = ms(t);
        let mut rec = FrameRecord {
            frame: i,
            name,
            load_ms,
            detect_ms,
            keypoints: kps.len(),
            tracked: true,
            ..Default::default()
        };
        if let Some((pk, pd)) = &prev {
            let t = Instant::now();
            let m = mat.run(pd, &desc, &o.matching)?;
            rec.match_ms = ms(t);
            rec.matches = m.len();
            let t = Instant::now();
            let step = if m.len() >= o.min_inliers {
                estimate(pk, &kps, &m, &calib, o, o.ransac.seed.wrapping_add(i as u64))
            } else {
                None
            };
            let (rot, dir) = match step {
                Some(s) if s.good >= o.min_inliers => {
                    rec.inliers = s.inliers;
                    rec.good = s.good;
                    (s.rotation, s.translation)
                }
                s => {
                    // lost: constant velocity (or standing still before any motion is known)
                    rec.tracked = false;
                    if let Some(s) = s {
                        rec.inliers = s.inliers;
                        rec.good = s.good;
                    }
                    last_step.unwrap_or((Matrix3::identity(), Vector3::zeros()))
                }
            };
            last_step = Some((rot, dir));
            let scale = match (g, gt_used.last()) {
                (Some(cur), Some(before)) if o.gt_scale => (cur.translation - before.translation).norm(),
                _ => 1.0,
            };
            // T_w,cur = T_w,prev * T_cur<-prev^-1
            let rel = Pose { rotation: rot, translation: dir * scale };
            poses.push(poses[i - 1].compose(&rel.inverse()));
            rec.pose_ms = ms(t);
        } else {
            poses.push(g.unwrap_or_else(Pose::identity));
        }
        if let Some(g) = g {
            gt_used.push(g);
        }
        rec.total_ms = rec.detect_ms + rec.match_ms + rec.pose_ms;
        records.push(rec);
        prev = Some((kps, desc));
    }
    if records.is_empty() {
        return Err(VoError::Sequence {
            path: sequence.to_path_buf(),
            reason: stopped.unwrap_or_else(|| "no frame to run on".into()),
        });
    }
    Ok(VoRun {
        sequence: sequence.to_path_buf(),
        options: o.clone(),
        detector_backend: det.backend_name(),
        matcher_backend: mat.backend(),
        calib,
        poses,
        gt: gt.map(|_| gt_used),
        records,
        stopped,
    })
}
