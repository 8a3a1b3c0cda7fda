//! `lfast eval`: the paper's experiments on real data, and the measurements
//! it did not make, each as CSV files, PNG plots and one section of a
//! Markdown report (docs/evaluation.md explains every metric).
//!
//! Suites (one module each):
//! 1. [`noise`]: PSNR and SNR of the flagged median vs a Gaussian on images
//!    with seeded 5% salt-and-pepper noise (paper Table 1);
//! 2. [`continuity`]: edge pixels A, 4-connected components B, 8-connected
//!    components C of traditional vs improved Canny (paper Table 2);
//! 3. [`kitti`]: keypoints and extraction time per frame of FAST-9, ORB and
//!    the L-FAST variants (paper Figs 9-10);
//! 4. [`repeatability`]: repeatability and matching score on Oxford-format
//!    scenes (Mikolajczyk et al.), also at equal keypoint budgets;
//! 5. [`illumination`]: how many edge pixels and keypoints survive synthetic
//!    brightness changes;
//! 6. [`vo`]: monocular visual odometry with each detector ([`crate::vo`]):
//!    the absolute trajectory error.
//!
//! Every suite writes `OUT/<suite>.csv` (and more CSVs where useful), PNG
//! plots, `OUT/<suite>.md` (its report section) and `OUT/<suite>.json` (the
//! numbers the report and the choice of defaults read back), then
//! [`report::assemble`] rebuilds `OUT/report.md` from every section present,
//! so suites can be run one at a time. Everything runs on the CPU path, which
//! is deterministic; the noise is seeded.

pub mod continuity;
pub mod decision;
pub mod format;
pub mod illumination;
pub mod kitti;
pub mod metrics;
pub mod noise;
pub mod output;
pub mod plot;
pub mod repeatability;
pub mod report;
pub mod vo;

use crate::baseline::fast::fast9;
use crate::baseline::orb::{OrbDetector, OrbParams};
use crate::baseline::orbslam::{OrbSlamDetector, OrbSlamParams};
use crate::config::{Config, Mode};
use crate::cpu::CpuDetector;
use crate::image::Plane;
use crate::keypoint::{Descriptor, KeyPoint};
use std::path::{Path, PathBuf};

/// What can stop an evaluation.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum EvalError {
    /// An error of the library (image decoding, config, I/O of one file).
    #[error(transparent)]
    Lib(#[from] crate::Error),
    /// A data folder is missing or not in the expected format.
    #[error("data {path}: {reason}")]
    Data {
        /// The folder or file.
        path: PathBuf,
        /// What is wrong with it.
        reason: String,
    },
    /// Two inputs of a metric do not fit together (sizes, lengths).
    #[error("{0}")]
    Mismatch(String),
    /// A plot could not be drawn or encoded.
    #[error("plot {path}: {reason}")]
    Plot {
        /// The PNG being written.
        path: PathBuf,
        /// The drawing backend's message.
        reason: String,
    },
    /// The output folder cannot be written.
    #[error("output {path}: {reason}")]
    Output {
        /// The file or folder.
        path: PathBuf,
        /// Why.
        reason: String,
    },
}

/// `Result` of the evaluation.
pub type Result<T, E = EvalError> = std::result::Result<T, E>;

/// One evaluation suite.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Suite {
    /// Paper Table 1: denoising.
    Noise,
    /// Paper Table 2: edge continuity.
    Continuity,
    /// Paper Figs 9-10: counts and times on KITTI.
    Kitti,
    /// Repeatability and matching score on homography scenes.
    Repeatability,
    /// Survival under brightness changes.
    Illumination,
    /// Visual odometry and trajectory error.
    Vo,
}

impl Suite {
    /// Every suite, in report order.
    pub const ALL: [Suite; 6] =
        [Suite::Noise, Suite::Continuity, Suite::Kitti, Suite::Repeatability, Suite::Illumination, Suite::Vo];

    /// The suite's name on the command line and in file names.
    pub fn name(self) -> &'static str {
        match self {
            Suite::Noise => "noise",
            Suite::Continuity => "continuity",
            Suite::Kitti => "kitti",
            Suite::Repeatability => "repeatability",
            Suite::Illumination => "illumination",
            Suite::Vo => "vo",
        }
    }
}

/// Where the data of each suite is, and how much of it to use.
#[derive(Clone, Debug)]
pub struct Options {
    /// Output folder (created when missing).
    pub out: PathBuf,
    /// Folder of standard images (noise, continuity, illumination): every
    /// image file directly in it, sorted by name.
    pub standard: PathBuf,
    /// A KITTI-format folder (kitti, illumination, vo): `image_0/*.png`, or the
    /// images directly, or a folder of sequences (the first that has
    /// `image_0`); vo also needs its `calib.txt` (and `poses.txt` for the ATE).
    pub kitti: PathBuf,
    /// Oxford-format scenes (repeatability): a folder with `img1..imgN` and
    /// `H1to2p..H1toNp`, or a folder of such scene folders.
    pub homography: PathBuf,
    /// A reduced run (a few frames and pairs, one timing repeat) for CI.
    pub quick: bool,
    /// Seed of the salt-and-pepper noise.
    pub seed: u64,
    /// Timing repeats per frame and detector (the median is reported).
    pub repeats: usize,
}

/// Default data root, relative to the working directory (the crate root),
/// when `LFAST_TEST_DATA` is unset.
pub const DEFAULT_DATA: &str = "../shared/data";

/// The data root: `LFAST_TEST_DATA` when set (where
/// `scripts/fetch_test_data.sh DIR` put the data), else [`DEFAULT_DATA`].
pub fn default_data() -> std::path::PathBuf {
    std::env::var_os("LFAST_TEST_DATA").filter(|v| !v.is_empty()).map_or_else(|| DEFAULT_DATA.into(), Into::into)
}
/// Default noise seed.
pub const DEFAULT_SEED: u64 = 2022;

impl Options {
    /// Options with the default data folders under `root` (`standard`,
    /// `kitti/seq01_000000-000050`, `homography`).
    pub fn with_root(out: impl Into<PathBuf>, root: &Path) -> Self {
        Options {
            out: out.into(),
            standard: root.join("standard"),
            kitti: root.join("kitti/seq01_000000-000050"),
            homography: root.join("homography"),
            quick: false,
            seed: DEFAULT_SEED,
            repeats: 3,
        }
    }

    /// Timing repeats actually used (1 in a quick run).
    pub fn timing_repeats(&self) -> usize {
        if self.quick { 1 } else { self.repeats.max(1) }
    }
}

/// One L-FAST configuration under evaluation: the fields that suites 3-6
/// decide between, everything else as `Config::default()`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Variant {
    /// SPEC 8 mode.
    pub mode: Mode,
    /// SPEC 8 `support`.
    pub support: u32,
    /// `Config::snap_radius` (docs/quality.md), 0 = corners stay on their edge pixel.
    pub snap: u32,
    /// SPEC 9 `nms_radius`.
    pub nms: u32,
    /// `Config::reject_edges` (docs/quality.md): no corner where the Harris response is not above 0.
    pub reject_edges: bool,
    /// `Config::orientation_bins`: the descriptor's pattern is rotated to one of this many angles.
    pub bins: u32,
}

/// SPEC 9's initial corner-NMS radius: variant keys and labels name any other.
pub const SPEC_NMS_RADIUS: u32 = 3;

/// SPEC 11's default `orientation_bins` (the ORB paper's 12° steps): variant
/// keys and labels name any other.
pub const SPEC_BINS: u32 = 30;

const fn variant(mode: Mode, support: u32, snap: u32, nms: u32, reject_edges: bool) -> Variant {
    Variant { mode, support, snap, nms, reject_edges, bins: SPEC_BINS }
}

const fn with_bins(v: Variant, bins: u32) -> Variant {
    Variant { bins, ..v }
}

/// One way a [`Variant`] departs from SPEC (mode and support aside).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Departure {
    /// A corner-NMS radius other than SPEC 9's.
    Nms(u32),
    /// Corners snapped to the Harris peak within this radius.
    Snap(u32),
    /// Candidates with a Harris response not above 0 dropped.
    NoEdges,
    /// An orientation bin count other than SPEC 11's.
    Bins(u32),
}

impl Variant {
    /// The candidates: {Paper, Branch} x support {3, 4} as the paper's corners;
    /// the two support-3 ones with their corners snapped within 1 px; paper
    /// support 3 snapped within 1 px without the candidates whose Harris
    /// response says edge; the same with NMS radius 4 and snap radius 2; and
    /// that one with the descriptor's pattern rotated in 2° steps instead of 12°.
    pub const ALL: [Variant; 9] = [
        variant(Mode::Paper, 3, 0, SPEC_NMS_RADIUS, false),
        variant(Mode::Paper, 4, 0, SPEC_NMS_RADIUS, false),
        variant(Mode::Branch, 3, 0, SPEC_NMS_RADIUS, false),
        variant(Mode::Branch, 4, 0, SPEC_NMS_RADIUS, false),
        variant(Mode::Paper, 3, 1, SPEC_NMS_RADIUS, false),
        variant(Mode::Branch, 3, 1, SPEC_NMS_RADIUS, false),
        variant(Mode::Paper, 3, 1, SPEC_NMS_RADIUS, true),
        variant(Mode::Paper, 3, 2, 4, true),
        with_bins(variant(Mode::Paper, 3, 2, 4, true), 180),
    ];

    /// The variant `Config::default()` is.
    pub fn current() -> Variant {
        let d = Config::default();
        with_bins(variant(d.mode, d.support, d.snap_radius, d.nms_radius, d.reject_edges), d.orientation_bins)
    }

    /// A stable key for files and JSON, e.g. `lfast-branch-s4`, `lfast-branch-s3-snap1`,
    /// `lfast-paper-s3-nms4-snap2-noedges`, `lfast-paper-s3-nms4-snap2-noedges-bins180`.
    pub fn key(self) -> String {
        let rest: String = self
            .departures()
            .into_iter()
            .map(|d| match d {
                Departure::Nms(r) => format!("-nms{r}"),
                Departure::Snap(s) => format!("-snap{s}"),
                Departure::NoEdges => "-noedges".into(),
                Departure::Bins(b) => format!("-bins{b}"),
            })
            .collect();
        format!("lfast-{}-s{}{rest}", mode_name(self.mode), self.support)
    }

    /// Display name: `L-FAST paper s3`, `L-FAST paper s3 nms4 snap2 no edges`.
    pub fn label(self) -> String {
        let rest: String = self
            .departures()
            .into_iter()
            .map(|d| match d {
                Departure::Nms(r) => format!(" nms{r}"),
                Departure::Snap(s) => format!(" snap{s}"),
                Departure::NoEdges => " no edges".into(),
                Departure::Bins(b) => format!(" bins{b}"),
            })
            .collect();
        format!("L-FAST {} s{}{rest}", mode_name(self.mode), self.support)
    }

    /// Where this variant departs from SPEC beyond mode and support, in a
    /// fixed order; keys, labels and the decision table each spell these.
    pub(crate) fn departures(self) -> Vec<Departure> {
        let mut d = Vec::new();
        if self.nms != SPEC_NMS_RADIUS {
            d.push(Departure::Nms(self.nms));
        }
        if self.snap > 0 {
            d.push(Departure::Snap(self.snap));
        }
        if self.reject_edges {
            d.push(Departure::NoEdges);
        }
        if self.bins != SPEC_BINS {
            d.push(Departure::Bins(self.bins));
        }
        d
    }

    /// The configuration fields as TOML-like text, for reports.
    pub fn fields(self) -> String {
        format!(
            "`mode = \"{}\"`, `support = {}`, `nms_radius = {}`, `snap_radius = {}`, `reject_edges = {}`, \
             `orientation_bins = {}`",
            mode_name(self.mode),
            self.support,
            self.nms,
            self.snap,
            self.reject_edges,
            self.bins
        )
    }

    /// The configuration: the defaults with this variant's fields.
    pub fn config(self) -> Config {
        Config {
            mode: self.mode,
            support: self.support,
            snap_radius: self.snap,
            nms_radius: self.nms,
            reject_edges: self.reject_edges,
            orientation_bins: self.bins,
            ..Config::default()
        }
    }

    /// True for the variant `Config::default()` uses now.
    pub fn is_current_default(self) -> bool {
        self == Variant::current()
    }

    /// The variant with this key.
    pub fn from_key(key: &str) -> Option<Variant> {
        Variant::ALL.into_iter().find(|v| v.key() == key)
    }
}

/// `paper` or `branch`.
pub fn mode_name(m: Mode) -> &'static str {
    match m {
        Mode::Paper => "paper",
        Mode::Branch => "branch",
    }
}

/// The FAST threshold of every FAST-9 and ORB run (SPEC 12, as OpenCV).
pub const FAST_THRESHOLD: i32 = 20;

/// The detectors compared by the keypoint suites, built once. ORB comes from
/// [`crate::frontend`] like the CLI's and VO's; FAST-9 keeps every keypoint
/// in a total order ([`sort_by_response`]) so the suites' top-N cuts are
/// deterministic, where [`crate::frontend::Features::Fast`] keeps detection order.
#[derive(Debug)]
pub struct Detectors {
    /// The L-FAST variants, in [`Variant::ALL`] order.
    pub lfast: Vec<(Variant, CpuDetector)>,
    /// Describes FAST-9 keypoints (default config: same pattern and bins).
    pub describer: CpuDetector,
    /// ORB as `cv2.ORB_create()` (500 features).
    pub orb: OrbDetector,
    /// ORB-SLAM's extractor with its settings files' 1000 features.
    pub orbslam: OrbSlamDetector,
}

impl Detectors {
    /// Builds every detector.
    pub fn new() -> Result<Self> {
        let lfast = Variant::ALL.iter().map(|&v| Ok((v, CpuDetector::new(v.config())?))).collect::<Result<Vec<_>>>()?;
        Ok(Detectors {
            lfast,
            describer: CpuDetector::new(Config::default())?,
            orb: Self::orb_with(OrbParams::default().n_features)?,
            orbslam: Self::orbslam_with(OrbSlamParams::default().n_features)?,
        })
    }

    /// FAST-9 keypoints (threshold 20, NMS), strongest first (ties by y, x).
    pub fn fast9_sorted(img: &Plane<u8>) -> Vec<KeyPoint> {
        let mut kps = fast9(img, FAST_THRESHOLD, true);
        sort_by_response(&mut kps);
        kps
    }

    /// FAST-9 keypoints (sorted) with descriptors.
    pub fn fast9_described(&self, img: &Plane<u8>) -> Result<(Vec<KeyPoint>, Vec<Descriptor>)> {
        let kps = Self::fast9_sorted(img);
        let desc = self.describer.compute(img.view(), &kps)?;
        Ok((kps, desc))
    }

    /// ORB with a budget of `n` features (`cv2.ORB_create(nfeatures=n)`),
    /// built as every front end builds it ([`crate::frontend::orb_params`]) from
    /// the default config.
    pub fn orb_with(n: u32) -> Result<OrbDetector> {
        let cfg = Config { n_features: n, ..Config::default() };
        Ok(OrbDetector::new(crate::frontend::orb_params(&cfg, FAST_THRESHOLD, n))?)
    }
}

impl Detectors {
    /// ORB-SLAM's extractor with a budget of `n` features, built as every
    /// front end builds it ([`crate::frontend::orbslam_params`]).
    pub fn orbslam_with(n: u32) -> Result<OrbSlamDetector> {
        let cfg = Config { n_features: n, ..Config::default() };
        Ok(OrbSlamDetector::new(crate::frontend::orbslam_params(&cfg, n))?)
    }
}

/// Sorts keypoints by response, strongest first, ties by (y, x), so a top-N
/// cut is deterministic.
pub fn sort_by_response(kps: &mut [KeyPoint]) {
    kps.sort_by(|a, b| {
        b.response.total_cmp(&a.response).then(a.pt.y.total_cmp(&b.pt.y)).then(a.pt.x.total_cmp(&b.pt.x))
    });
}

/// Runs one suite: writes its CSV files, plots, section and summary into
/// `opts.out` (created when missing), without rebuilding the report.
pub fn run_suite(suite: Suite, opts: &Options) -> Result<()> {
    create_dir(&opts.out)?;
    match suite {
        Suite::Noise => noise::run(opts),
        Suite::Continuity => continuity::run(opts),
        Suite::Kitti => kitti::run(opts),
        Suite::Repeatability => repeatability::run(opts),
        Suite::Illumination => illumination::run(opts),
        Suite::Vo => vo::run(opts),
    }
}

/// Runs one suite and rebuilds `OUT/report.md` from every section in `OUT`.
pub fn run(suite: Suite, opts: &Options) -> Result<()> {
    run_suite(suite, opts)?;
    report::assemble(&opts.out)
}

/// Runs every suite in order, then rebuilds the report once.
pub fn run_all(opts: &Options) -> Result<()> {
    for s in Suite::ALL {
        run_suite(s, opts)?;
    }
    report::assemble(&opts.out)
}

/// Creates a folder (and its parents).
pub fn create_dir(p: &Path) -> Result<()> {
    std::fs::create_dir_all(p).map_err(|e| EvalError::Output { path: p.to_path_buf(), reason: e.to_string() })
}

/// Writes a text file atomically.
pub(crate) fn write_text(path: &Path, text: &str) -> Result<()> {
    Ok(crate::io::write_atomic(path, text.as_bytes())?)
}

/// Image files directly in `dir` (not in sub-folders), sorted by name.
pub fn image_files(dir: &Path) -> Result<Vec<PathBuf>> {
    let rd = std::fs::read_dir(dir).map_err(|e| EvalError::Data { path: dir.to_path_buf(), reason: e.to_string() })?;
    let mut files: Vec<PathBuf> = rd
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file() && is_image(p) && !p.file_name().is_some_and(|n| n.to_string_lossy().starts_with('.')))
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(EvalError::Data {
            path: dir.to_path_buf(),
            reason: "no image files (.png .jpg .pgm .ppm .tif .bmp) in it".into(),
        });
    }
    Ok(files)
}

fn is_image(p: &Path) -> bool {
    const EXT: [&str; 9] = ["png", "jpg", "jpeg", "pgm", "ppm", "pnm", "tif", "tiff", "bmp"];
    p.extension().and_then(|e| e.to_str()).is_some_and(|e| EXT.contains(&e.to_ascii_lowercase().as_str()))
}

/// A named gray image.
#[derive(Clone, Debug)]
pub struct NamedImage {
    /// File stem (`cameraman`).
    pub name: String,
    /// The image, converted to gray (SPEC 0).
    pub image: Plane<u8>,
}

/// Loads every image of a folder of standard images.
pub fn load_standard(dir: &Path) -> Result<Vec<NamedImage>> {
    image_files(dir)?
        .into_iter()
        .map(|p| Ok(NamedImage { name: stem(&p), image: crate::image::load_gray(&p)? }))
        .collect()
}

/// The frames of a KITTI-format folder, sorted: `DIR/image_0/*`, else the
/// images directly in DIR, else those of the first sub-folder (sorted) that
/// has an `image_0` folder.
pub fn kitti_frames(dir: &Path) -> Result<Vec<PathBuf>> {
    let bad = |reason: &str| EvalError::Data { path: dir.to_path_buf(), reason: reason.into() };
    if !dir.is_dir() {
        return Err(bad("not a folder"));
    }
    if dir.join("image_0").is_dir() {
        return image_files(&dir.join("image_0"));
    }
    if let Ok(files) = image_files(dir) {
        return Ok(files);
    }
    let mut subs: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| bad(&e.to_string()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.join("image_0").is_dir())
        .collect();
    subs.sort();
    match subs.first() {
        Some(s) => image_files(&s.join("image_0")),
        None => Err(bad("no image_0/ folder, no images, and no sequence folder with image_0/")),
    }
}

/// A file's stem as text.
pub(crate) fn stem(p: &Path) -> String {
    p.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default()
}

/// Median of a non-empty list (the mean of the two middles for even lengths).
pub(crate) fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 { v[n / 2] } else { (v[n / 2 - 1] + v[n / 2]) / 2.0 }
}

/// Mean of a list, NaN when empty.
pub(crate) fn mean(v: impl IntoIterator<Item = f64>) -> f64 {
    let (s, n) = v.into_iter().fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    if n == 0 { f64::NAN } else { s / n as f64 }
}

/// Key of the default L-FAST on level 0 only (kitti suite).
pub const LFAST_L0: &str = "lfast-default-l0";

/// Display name of a detector or method key.
pub fn label(key: &str) -> String {
    match key {
        "fast9" => "FAST-9".into(),
        "orb" => "ORB".into(),
        "orbslam" => "ORB-SLAM".into(),
        "canny" => "Canny".into(),
        "improved-canny" => "improved Canny".into(),
        LFAST_L0 => "L-FAST default, level 0".into(),
        k => Variant::from_key(k).map_or_else(|| k.into(), Variant::label),
    }
}

/// Palette index of a detector or method key, the same in every plot.
pub fn colour_of(key: &str) -> usize {
    match key {
        "fast9" | "canny" => 3,
        "orb" => 1,
        "orbslam" => 5,
        "improved-canny" => 0,
        LFAST_L0 => 9,
        "lfast-paper-s3" => 4,
        "lfast-paper-s4" => 6,
        "lfast-branch-s3" => 2,
        "lfast-branch-s4" => 0,
        "lfast-paper-s3-snap1" => 8,
        "lfast-branch-s3-snap1" => 10,
        "lfast-paper-s3-snap1-noedges" => 11,
        "lfast-paper-s3-nms4-snap2-noedges" => 12,
        _ => 7,
    }
}
