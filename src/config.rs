//! Detector parameters (SPEC sections 1-11), their defaults, TOML I/O and validation.

use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// How the L-FAST test of SPEC 8 forms the points `t_i` on the circle.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    /// The paper's steps literally: every edge pixel on the circle is a `t_i`.
    Paper,
    /// Runs of consecutive edge pixels on the circle are one branch each.
    Branch,
}

impl std::str::FromStr for Mode {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "paper" => Ok(Mode::Paper),
            "branch" => Ok(Mode::Branch),
            _ => Err(format!("unknown mode `{s}` (expected paper or branch)")),
        }
    }
}

/// Which descriptor SPEC 11 computes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DescriptorKind {
    /// lfast's rBRIEF: the level blurred by the SPEC 11 integer kernel,
    /// the pattern rotated to `orientation_bins` (CPU == GPU).
    #[default]
    Lfast,
    /// Bit for bit OpenCV 5 ORB `compute()` on the same keypoints
    /// (its pyramid, its float blur, the keypoint's own angle); CPU only
    /// (docs/algorithm.md).
    Opencv,
}

impl std::str::FromStr for DescriptorKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "lfast" => Ok(DescriptorKind::Lfast),
            "opencv" => Ok(DescriptorKind::Opencv),
            _ => Err(format!("unknown descriptor `{s}` (expected lfast or opencv)")),
        }
    }
}

/// Every parameter of the pipeline. Build with `Config::default()` and struct
/// update syntax, or read a TOML file with [`Config::load`]; [`Config::validate`]
/// names the first bad field.
///
/// ```
/// let cfg = lfast::Config { n_features: 1000, ..Default::default() };
/// assert!(cfg.validate().is_ok());
/// let bad = lfast::Config { scale_factor: 1.0, ..Default::default() };
/// assert!(bad.validate().unwrap_err().to_string().contains("scale_factor"));
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Config {
    /// Noise factor of the flagged median (SPEC 1), > 0; used as a rational
    /// with denominator [`DELTA_DEN`].
    pub delta: f64,
    /// Local-threshold spread alpha in hundredths (SPEC 5), 0..=99.
    pub alpha_pct: u32,
    /// L-FAST variant (SPEC 8).
    pub mode: Mode,
    /// Neighbours of a non-edge `q_i` that must be edge for it to support p, 1..=8.
    pub support: u32,
    /// Branch mode: two supporting branches closer than `8 - straight_tol` steps
    /// to opposite are a straight line, 0..=7.
    pub straight_tol: u32,
    /// Corners are tested only this far (pixels) from every side, at every level, >= 7.
    pub border: u32,
    /// Corner NMS half-window r, (2r+1)^2 square, 0..=32.
    pub nms_radius: u32,
    /// Pyramid levels, 1 = no pyramid, 1..=32.
    pub n_levels: u32,
    /// Pyramid scale between levels, > 1 and <= 4.
    pub scale_factor: f64,
    /// Keypoint cap over all levels, 0 = no cap.
    pub n_features: u32,
    /// With a cap: spread keypoints with ORB-SLAM's quadtree instead of taking the strongest.
    pub distribution: bool,
    /// Orientation bins for the descriptor (0 = continuous angle as OpenCV), 0..=360.
    /// The default, 180 (2° steps), is finer than SPEC 11's 30 (the ORB paper's
    /// 12°, which [`Config::paper`] keeps): a 6° error moves the pattern's outer
    /// samples by 1.5 px and costs matches (docs/quality.md).
    pub orientation_bins: u32,
    /// The descriptor: `lfast` (default) or `opencv` (equal to cv2 ORB's).
    pub descriptor: DescriptorKind,
    /// Beyond the paper: each corner that survives corner NMS moves to the
    /// Harris maximum within this many pixels (0 = stays on its edge pixel),
    /// 0..=16; at most `nms_radius / 2` is used ([`Config::snap`]), which keeps
    /// positions distinct (docs/quality.md).
    pub snap_radius: u32,
    /// Beyond the paper: drop a candidate whose Harris response (SPEC 9) is not
    /// above 0, Harris and Stephens' sign for an edge (the smaller eigenvalue of
    /// the structure tensor under ~4% of the larger one at k = 0.04), before
    /// corner NMS. A ratio of eigenvalues, so it does not depend on contrast;
    /// such a candidate cannot beat a positive one, so the positive survivors
    /// are the same as without it (docs/quality.md).
    pub reject_edges: bool,
    /// Beyond the paper, with a cap (`n_features > 0`): a level whose L-FAST
    /// corners fall short of its quota is topped up with FAST-9 corners found
    /// as ORB-SLAM's extractor finds them, in cells of about 30 px at this
    /// threshold, retried at [`fill_fast_min`](Self::fill_fast_min) in a cell
    /// where it finds none; the L-FAST corners are all kept first, the fill
    /// corners (`class_id = 1`) take only what is left of the quota
    /// (docs/algorithm.md, "Fill"). 0 = off (the default), else
    /// `fill_fast_min..=255`. CPU only. `lfast::ORBextractor` sets it from
    /// ORB-SLAM's `iniThFAST`.
    pub fill_fast_ini: u32,
    /// The FAST threshold of the fill's retry in a cell where
    /// [`fill_fast_ini`](Self::fill_fast_ini) found nothing (ORB-SLAM's
    /// `minThFAST`): 0 with the fill off, else `1..=fill_fast_ini`.
    pub fill_fast_min: u32,
}

/// Denominator of the rational `delta` (SPEC 1): `delta_num = round(delta * DELTA_DEN)`.
pub const DELTA_DEN: u32 = 10_000;

impl Default for Config {
    fn default() -> Self {
        Self {
            delta: 0.1,
            alpha_pct: 35,
            mode: Mode::Paper,
            support: 3,
            straight_tol: 1,
            border: 16,
            nms_radius: 4,
            n_levels: 8,
            scale_factor: 1.2,
            n_features: 0,
            distribution: false,
            orientation_bins: 180,
            descriptor: DescriptorKind::Lfast,
            snap_radius: 2,
            reject_edges: true,
            fill_fast_ini: 0,
            fill_fast_min: 0,
        }
    }
}

/// The GPU pipeline computes lfast's descriptor only: `descriptor = "opencv"`
/// is refused (OpenCV's f32 blur with fused multiply-adds and its f32
/// `cos`/`sin` have no bit-exact WGSL equivalent; docs/algorithm.md).
/// [`crate::Detector`] keeps detecting on the GPU and describes on the CPU.
pub fn gpu_supports(cfg: &Config) -> Result<()> {
    if cfg.descriptor == DescriptorKind::Opencv {
        return Err(bad(
            "descriptor",
            "`opencv` is CPU-only: OpenCV's f32 blur (fused multiply-adds) and f32 cos/sin \
             have no bit-exact WGSL equivalent; use Backend::Cpu or Backend::Auto",
        ));
    }
    if cfg.fills() {
        return Err(bad(
            "fill_fast_ini",
            "the FAST fill is CPU-only (the GPU pipeline has no FAST stage); use Backend::Cpu or Backend::Auto",
        ));
    }
    Ok(())
}

fn bad(field: &'static str, reason: impl Into<String>) -> Error {
    Error::InvalidConfig { field, reason: reason.into() }
}

impl Config {
    /// Checks every field; the error names the first one out of range.
    pub fn validate(&self) -> Result<()> {
        if !self.delta.is_finite() || self.delta <= 0.0 {
            return Err(bad("delta", format!("must be a finite number > 0, got {}", self.delta)));
        }
        if self.delta > 100.0 || self.delta_num() == 0 {
            return Err(bad("delta", format!("must be in [0.0001, 100], got {}", self.delta)));
        }
        if self.alpha_pct >= 100 {
            return Err(bad("alpha_pct", format!("must be < 100, got {}", self.alpha_pct)));
        }
        if !(1..=8).contains(&self.support) {
            return Err(bad("support", format!("must be 1..=8 neighbours, got {}", self.support)));
        }
        if self.straight_tol > 7 {
            return Err(bad("straight_tol", format!("must be 0..=7, got {}", self.straight_tol)));
        }
        if self.border < 7 {
            return Err(bad(
                "border",
                format!("must be >= 7 (the L-FAST test reads 7 pixels out), got {}", self.border),
            ));
        }
        if self.border > 1024 {
            return Err(bad("border", format!("must be <= 1024, got {}", self.border)));
        }
        if self.nms_radius > 32 {
            return Err(bad("nms_radius", format!("must be 0..=32, got {}", self.nms_radius)));
        }
        if !(1..=32).contains(&self.n_levels) {
            return Err(bad("n_levels", format!("must be 1..=32, got {}", self.n_levels)));
        }
        if !self.scale_factor.is_finite() || self.scale_factor <= 1.0 || self.scale_factor > 4.0 {
            return Err(bad("scale_factor", format!("must be a finite number in (1, 4], got {}", self.scale_factor)));
        }
        if self.snap_radius > 16 {
            return Err(bad("snap_radius", format!("must be 0..=16, got {}", self.snap_radius)));
        }
        if self.orientation_bins > 360 {
            return Err(bad(
                "orientation_bins",
                format!("must be 0 (continuous) or 1..=360, got {}", self.orientation_bins),
            ));
        }
        match (self.fill_fast_ini, self.fill_fast_min) {
            (0, 0) => {}
            (0, m) => {
                return Err(bad("fill_fast_min", format!("must be 0 while fill_fast_ini is 0 (fill off), got {m}")));
            }
            (i, _) if i > 255 => return Err(bad("fill_fast_ini", format!("must be 0 (off) or 1..=255, got {i}"))),
            (i, m) if m == 0 || m > i => {
                return Err(bad("fill_fast_min", format!("must be 1..=fill_fast_ini ({i}) with the fill on, got {m}")));
            }
            _ if self.n_features == 0 => {
                return Err(bad(
                    "fill_fast_ini",
                    "the fill tops levels up to their quotas, so it needs a cap (n_features > 0)",
                ));
            }
            _ => {}
        }
        Ok(())
    }

    /// Whether the FAST fill is on ([`fill_fast_ini`](Self::fill_fast_ini) > 0).
    pub fn fills(&self) -> bool {
        self.fill_fast_ini > 0
    }

    /// This configuration with the FAST fill off.
    ///
    /// ```
    /// let c = lfast::Config { n_features: 500, fill_fast_ini: 20, fill_fast_min: 7, ..Default::default() };
    /// assert!(c.fills() && !c.without_fill().fills());
    /// ```
    pub fn without_fill(self) -> Self {
        Self { fill_fast_ini: 0, fill_fast_min: 0, ..self }
    }

    /// The paper's pipeline literally (SPEC 1-10 as written): `mode = "paper"`,
    /// `support = 4` ("more than three" neighbours), SPEC 9's corner-NMS radius
    /// 3, no snap, every corner whatever the sign of its response, SPEC 11's 30
    /// orientation bins, the other fields at their defaults.
    /// Its output does not move when the defaults do.
    ///
    /// ```
    /// let p = lfast::Config::paper();
    /// assert_eq!((p.mode, p.support, p.nms_radius, p.snap_radius, p.reject_edges), (lfast::Mode::Paper, 4, 3, 0, false));
    /// assert_eq!(p.orientation_bins, 30);
    /// ```
    pub fn paper() -> Self {
        Self {
            mode: Mode::Paper,
            support: 4,
            nms_radius: 3,
            snap_radius: 0,
            reject_edges: false,
            orientation_bins: 30,
            ..Self::default()
        }
    }

    /// The snap radius the pipeline uses: `min(snap_radius, nms_radius / 2)`.
    /// Survivors of corner NMS are more than `nms_radius` apart (Chebyshev),
    /// so corners moved by at most half of it cannot meet.
    ///
    /// ```
    /// let c = lfast::Config { snap_radius: 2, nms_radius: 3, ..Default::default() };
    /// assert_eq!(c.snap(), 1);
    /// ```
    pub fn snap(&self) -> u32 {
        self.snap_radius.min(self.nms_radius / 2)
    }

    /// Numerator of the rational delta over [`DELTA_DEN`].
    pub fn delta_num(&self) -> u32 {
        (self.delta * DELTA_DEN as f64).round().clamp(0.0, u32::MAX as f64) as u32
    }

    /// Parses TOML (missing fields take their defaults) and validates.
    pub fn from_toml_str(s: &str) -> Result<Self> {
        let cfg: Config =
            toml::from_str(s).map_err(|e| Error::ConfigParse { path: "<string>".into(), message: e.to_string() })?;
        cfg.validate()?;
        Ok(cfg)
    }

    /// Reads and validates a TOML file.
    pub fn load(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|source| Error::Io { path: path.into(), source })?;
        let cfg: Config =
            toml::from_str(&text).map_err(|e| Error::ConfigParse { path: path.into(), message: e.to_string() })?;
        cfg.validate()?;
        Ok(cfg)
    }

    /// The config as TOML text.
    pub fn to_toml_string(&self) -> String {
        toml::to_string_pretty(self).expect("Config always serialises")
    }

    /// Scale of level `l` relative to the input, `scale_factor^l`.
    pub fn level_scale(&self, l: u32) -> f64 {
        self.scale_factor.powi(l as i32)
    }

    /// Sizes of the pyramid levels for a `width x height` input (SPEC 10):
    /// `round(W / s^l) x round(H / s^l)`, never below 1.
    pub fn level_sizes(&self, width: u32, height: u32) -> Vec<(u32, u32)> {
        (0..self.n_levels)
            .map(|l| {
                let s = self.level_scale(l);
                let w = (width as f64 / s).round().max(1.0) as u32;
                let h = (height as f64 / s).round().max(1.0) as u32;
                (w, h)
            })
            .collect()
    }
}
