//! The one feature front end behind `lfast detect --detector`, `lfast vo
//! --features` and the evaluation: which detector ([`FrontEnd`]), how an
//! L-FAST [`Config`] carries over to the baselines ([`orb_params`]), and the
//! runnable front end ([`Features`]). One config gives one set of
//! descriptors whichever command runs it.

use crate::baseline::fast::fast9_and_compute;
use crate::baseline::orb::{OrbDetector, OrbParams};
use crate::baseline::orbslam::{OrbSlamDetector, OrbSlamParams};
use crate::config::Config;
use crate::cpu::CpuDetector;
use crate::detector::{Backend, Detector};
use crate::error::Result;
use crate::image::Plane;
use crate::keypoint::{Descriptor, KeyPoint};

/// The feature front end.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum FrontEnd {
    /// L-FAST on the improved Canny edge map, ORB descriptors (GPU or CPU)
    Lfast,
    /// OpenCV-exact FAST-9 (with non-maximum suppression) on the full image, our ORB descriptors
    Fast,
    /// The ORB baseline (FAST-9 + Harris over the pyramid), as cv2.ORB_create
    Orb,
    /// ORB-SLAM's extractor: FAST in ~30 px cells (threshold 20, retry 7), per-level quotas, quadtree
    Orbslam,
}

impl FrontEnd {
    /// Every front end, in the order of the paper's tables, the paper's comparator last.
    pub const ALL: [FrontEnd; 4] = [FrontEnd::Lfast, FrontEnd::Fast, FrontEnd::Orb, FrontEnd::Orbslam];

    /// The name on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            FrontEnd::Lfast => "lfast",
            FrontEnd::Fast => "fast",
            FrontEnd::Orb => "orb",
            FrontEnd::Orbslam => "orbslam",
        }
    }
}

impl std::fmt::Display for FrontEnd {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// The ORB baseline's parameters under an L-FAST config: its pyramid
/// (`n_levels`, `scale_factor`), its descriptor's `orientation_bins`, the cap
/// `n_features` (or `default_features` when the config has none) and the
/// FAST threshold.
///
/// ```
/// let cfg = lfast::Config { orientation_bins: 0, ..Default::default() };
/// let p = lfast::frontend::orb_params(&cfg, 20, 500);
/// assert_eq!((p.orientation_bins, p.n_features, p.n_levels), (0, 500, cfg.n_levels));
/// ```
pub fn orb_params(cfg: &Config, fast_threshold: i32, default_features: u32) -> OrbParams {
    OrbParams {
        n_features: if cfg.n_features > 0 { cfg.n_features } else { default_features },
        n_levels: cfg.n_levels,
        scale_factor: cfg.scale_factor,
        fast_threshold,
        orientation_bins: cfg.orientation_bins,
        ..OrbParams::default()
    }
}

/// The ORB-SLAM baseline's parameters under an L-FAST config: its pyramid,
/// and the cap `n_features` (or `default_features` when the config has none).
/// Its FAST thresholds are its own (20, retry 7); the descriptor angle is continuous.
///
/// ```
/// let p = lfast::frontend::orbslam_params(&lfast::Config::default(), 1000);
/// assert_eq!((p.n_features, p.ini_th_fast, p.min_th_fast), (1000, 20, 7));
/// ```
pub fn orbslam_params(cfg: &Config, default_features: u32) -> OrbSlamParams {
    OrbSlamParams {
        n_features: if cfg.n_features > 0 { cfg.n_features } else { default_features },
        n_levels: cfg.n_levels,
        scale_factor: cfg.scale_factor,
        ..OrbSlamParams::default()
    }
}

/// A front end ready to run.
#[derive(Debug)]
pub enum Features {
    /// L-FAST on either backend.
    Lfast(Box<Detector>),
    /// FAST-9, the `cap` strongest kept (0 = all), described by `describe`.
    Fast {
        /// Describes the FAST-9 keypoints (same pattern and bins as L-FAST).
        describe: CpuDetector,
        /// FAST threshold.
        threshold: i32,
        /// Keypoints kept, strongest first; 0 = all.
        cap: u32,
    },
    /// The ORB baseline.
    Orb(OrbDetector),
    /// The ORB-SLAM baseline.
    OrbSlam(OrbSlamDetector),
}

impl Features {
    /// The L-FAST front end on `detector`.
    pub fn lfast(detector: Detector) -> Self {
        Features::Lfast(Box::new(detector))
    }

    /// `kind` on the CPU under `cfg`: FAST-9 capped at `cfg.n_features`, ORB
    /// by [`orb_params`] (`orb_features` when `cfg` has no cap).
    pub fn cpu(kind: FrontEnd, cfg: Config, fast_threshold: i32, orb_features: u32) -> Result<Self> {
        Ok(match kind {
            FrontEnd::Lfast => Self::lfast(Detector::new(cfg, Backend::Cpu)?),
            FrontEnd::Fast => {
                Features::Fast { cap: cfg.n_features, threshold: fast_threshold, describe: CpuDetector::new(cfg)? }
            }
            FrontEnd::Orb => Features::Orb(OrbDetector::new(orb_params(&cfg, fast_threshold, orb_features))?),
            FrontEnd::Orbslam => Features::OrbSlam(OrbSlamDetector::new(orbslam_params(&cfg, orb_features))?),
        })
    }

    /// Which front end this is.
    pub fn kind(&self) -> FrontEnd {
        match self {
            Features::Lfast(_) => FrontEnd::Lfast,
            Features::Fast { .. } => FrontEnd::Fast,
            Features::Orb(_) => FrontEnd::Orb,
            Features::OrbSlam(_) => FrontEnd::Orbslam,
        }
    }

    /// Where detection runs: `gpu` or `cpu`.
    pub fn backend_name(&self) -> &'static str {
        match self {
            Features::Lfast(d) => d.backend_name(),
            _ => "cpu",
        }
    }

    /// Whether frames run on a software adapter ([`Detector::on_software_gpu`]).
    pub(crate) fn on_software_gpu(&self) -> bool {
        matches!(self, Features::Lfast(d) if d.on_software_gpu())
    }

    /// [`detect_and_compute`](Self::detect_and_compute) with `img` handed to
    /// L-FAST's CPU path as the pyramid's level 0 instead of copied
    /// ([`Detector::detect_and_compute_in`]); handed back unchanged.
    pub fn detect_and_compute_in(&self, img: &mut Plane<u8>) -> Result<(Vec<KeyPoint>, Vec<Descriptor>)> {
        match self {
            Features::Lfast(d) => d.detect_and_compute_in(img, None),
            _ => self.detect_and_compute(img),
        }
    }

    /// Keypoints and their descriptors; `desc[i]` belongs to `kps[i]`.
    pub fn detect_and_compute(&self, img: &Plane<u8>) -> Result<(Vec<KeyPoint>, Vec<Descriptor>)> {
        match self {
            Features::Lfast(d) => d.detect_and_compute(img.view(), None),
            Features::Orb(d) => d.detect_and_compute(img.view()),
            Features::OrbSlam(d) => d.detect_and_compute(img.view()),
            Features::Fast { describe, threshold, cap } => fast9_and_compute(img, *threshold, *cap, describe),
        }
    }
}
