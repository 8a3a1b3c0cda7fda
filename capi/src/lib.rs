//! The C ABI of lfast: `include/lfast/lfast.h` is generated from this crate
//! by cbindgen (`cargo run -p lfast-capi-header` checks it is current;
//! `LFAST_BLESS=1` rewrites it). The C++ headers `lfast.hpp`,
//! `lfast_opencv.hpp` and `orbextractor.hpp` are written over it.
//!
//! Conventions, for every function:
//! - It returns an [`LfastStatus`]; on failure `lfast_last_error()` gives the
//!   message (per thread) and the output pointer is left untouched.
//! - No panic unwinds into C: one is caught and returned as
//!   `LFAST_STATUS_PANIC`.
//! - Results are allocated by the library and freed by one call
//!   (`lfast_features_free`, `lfast_plane_free`); NULL is accepted there.
//!
//! Thread safety: an `LfastDetector` may be used from several threads at
//! once (the detector is `Send + Sync`; the CPU path keeps one workspace per
//! concurrent call, the GPU path serialises its frames). It must not be freed
//! while a call on it is running. Results are independent of the detector.
//!
//! The work is the library's: input conversion as [`lfast::image::luma_bt601`]
//! says (SPEC 0), detection by [`lfast::Detector`], descriptors of given
//! keypoints by [`lfast::cpu::CpuDetector::compute`] (which the GPU equals
//! bit for bit).
#![allow(clippy::missing_safety_doc)] // each function's safety is in its doc, as C readers see it

mod image;
mod results;
mod status;

pub use image::{LfastImage, LfastPixelFormat};
pub use results::{LfastFeatures, LfastKeyPoint, LfastPlane, lfast_features_free, lfast_plane_free};
pub use status::LfastStatus;

use lfast::cpu::CpuDetector;
use lfast::{Backend, Config, DescriptorKind, Detector, KeyPoint, Mode};
use results::{features, plane};
use status::{Failure, guard, invalid, null};
use std::ffi::{CStr, c_char};

/// Which path runs: values of the `backend` argument of `lfast_detector_new`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LfastBackend {
    /// A hardware GPU when one opens (or the adapter `WGPU_ADAPTER_NAME`
    /// names), else the CPU.
    Auto = 0,
    /// The GPU or an error.
    Gpu = 1,
    /// The CPU reference path.
    Cpu = 2,
}

/// Values of `LfastConfig.mode` (SPEC 8).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LfastMode {
    /// Every edge pixel on the circle is a `t_i` (the paper's steps literally).
    Paper = 0,
    /// Runs of consecutive edge pixels on the circle are one branch each.
    Branch = 1,
}

/// Which descriptor `lfast::Config::descriptor` computes.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LfastDescriptorKind {
    /// lfast's rBRIEF (SPEC 11), CPU == GPU.
    Lfast = 0,
    /// Bit for bit OpenCV ORB `compute()`'s on the same keypoints; CPU only.
    Opencv = 1,
}

/// Every parameter of the detector, as `lfast::Config` (docs/algorithm.md);
/// `lfast_config_default()` gives the defaults.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LfastConfig {
    /// Noise factor of the flagged median (SPEC 1), in [0.0001, 100].
    pub delta: f64,
    /// Local-threshold spread alpha in hundredths (SPEC 5), 0..=99.
    pub alpha_pct: u32,
    /// An `LfastMode` value (SPEC 8).
    pub mode: i32,
    /// Neighbours of a non-edge `q_i` that must be edge for it to support p, 1..=8.
    pub support: u32,
    /// Branch mode: tolerance of the straight-line test, 0..=7.
    pub straight_tol: u32,
    /// Corners are tested only this far (pixels) from every side, 7..=1024.
    pub border: u32,
    /// Corner NMS half-window r, (2r+1)^2 square, 0..=32.
    pub nms_radius: u32,
    /// Pyramid levels, 1..=32 (1 = no pyramid).
    pub n_levels: u32,
    /// Pyramid scale between levels, in (1, 4].
    pub scale_factor: f64,
    /// Keypoint cap over all levels, 0 = no cap.
    pub n_features: u32,
    /// With a cap: spread keypoints with ORB-SLAM's quadtree instead of taking the strongest.
    pub distribution: bool,
    /// Orientation bins of the descriptor (0 = continuous angle), 0..=360.
    pub orientation_bins: u32,
    /// An `LfastDescriptorKind` value.
    pub descriptor: i32,
    /// Beyond the paper: each corner moves to the Harris maximum within this many
    /// pixels (0 = stays on its edge pixel), 0..=16; at most `nms_radius / 2` is used.
    pub snap_radius: u32,
    /// Beyond the paper: a candidate whose Harris response is not above 0 (an
    /// edge, in Harris and Stephens' sense) is no corner.
    pub reject_edges: bool,
    /// Beyond the paper, with a cap: a level whose L-FAST corners fall short of
    /// its quota is topped up with FAST-9 corners found cell by cell at this
    /// threshold (ORB-SLAM's `iniThFAST`), `class_id` 1; 0 = off, else
    /// `fill_fast_min..=255`. CPU only.
    pub fill_fast_ini: u32,
    /// The fill's FAST threshold in a cell where `fill_fast_ini` found nothing
    /// (ORB-SLAM's `minThFAST`): 0 with the fill off, else `1..=fill_fast_ini`.
    pub fill_fast_min: u32,
}

impl From<&Config> for LfastConfig {
    fn from(c: &Config) -> Self {
        LfastConfig {
            delta: c.delta,
            alpha_pct: c.alpha_pct,
            mode: match c.mode {
                Mode::Paper => LfastMode::Paper as i32,
                Mode::Branch => LfastMode::Branch as i32,
            },
            support: c.support,
            straight_tol: c.straight_tol,
            border: c.border,
            nms_radius: c.nms_radius,
            n_levels: c.n_levels,
            scale_factor: c.scale_factor,
            n_features: c.n_features,
            distribution: c.distribution,
            orientation_bins: c.orientation_bins,
            descriptor: match c.descriptor {
                DescriptorKind::Lfast => LfastDescriptorKind::Lfast as i32,
                DescriptorKind::Opencv => LfastDescriptorKind::Opencv as i32,
            },
            snap_radius: c.snap_radius,
            reject_edges: c.reject_edges,
            fill_fast_ini: c.fill_fast_ini,
            fill_fast_min: c.fill_fast_min,
        }
    }
}

impl LfastConfig {
    /// The library's config, validated. Every field is listed (no `..`), so
    /// a field added to `lfast::Config` fails to compile here until it is
    /// added to the C struct too.
    fn to_config(self) -> Result<Config, Failure> {
        let mode = match self.mode {
            0 => Mode::Paper,
            1 => Mode::Branch,
            m => {
                let reason = format!("must be LFAST_MODE_PAPER (0) or LFAST_MODE_BRANCH (1), got {m}");
                return Err(lfast::Error::InvalidConfig { field: "mode", reason }.into());
            }
        };
        let descriptor = match self.descriptor {
            0 => DescriptorKind::Lfast,
            1 => DescriptorKind::Opencv,
            d => {
                let reason =
                    format!("must be LFAST_DESCRIPTOR_KIND_LFAST (0) or LFAST_DESCRIPTOR_KIND_OPENCV (1), got {d}");
                return Err(lfast::Error::InvalidConfig { field: "descriptor", reason }.into());
            }
        };
        let cfg = Config {
            delta: self.delta,
            alpha_pct: self.alpha_pct,
            mode,
            support: self.support,
            straight_tol: self.straight_tol,
            border: self.border,
            nms_radius: self.nms_radius,
            n_levels: self.n_levels,
            scale_factor: self.scale_factor,
            n_features: self.n_features,
            distribution: self.distribution,
            orientation_bins: self.orientation_bins,
            descriptor,
            snap_radius: self.snap_radius,
            reject_edges: self.reject_edges,
            fill_fast_ini: self.fill_fast_ini,
            fill_fast_min: self.fill_fast_min,
        };
        cfg.validate()?;
        Ok(cfg)
    }
}

/// The detector behind an `LfastDetector*`.
pub struct LfastDetector {
    det: Detector,
    /// Descriptors of given keypoints: the CPU reference, equal to the GPU's.
    cpu: CpuDetector,
}

// One detector serves concurrent calls (the thread-safety promise above).
const _: fn() = || {
    fn send_sync<T: Send + Sync>() {}
    send_sync::<LfastDetector>();
};

/// Writes `v` through the out-pointer `out` (checked non-NULL by the caller).
fn put<T>(out: *mut T, v: T) {
    // SAFETY: `out` was checked non-NULL and points to writable memory (the C contract)
    unsafe { out.write(v) }
}

/// # Safety
/// `p` is NULL or a pointer returned by `lfast_detector_new*` and not yet freed.
unsafe fn det_ref<'a>(p: *const LfastDetector) -> Result<&'a LfastDetector, Failure> {
    // SAFETY: forwarded from the caller
    unsafe { p.as_ref() }.ok_or_else(|| null("detector"))
}

fn backend(v: i32) -> Result<Backend, Failure> {
    match v {
        0 => Ok(Backend::Auto),
        1 => Ok(Backend::Gpu),
        2 => Ok(Backend::Cpu),
        _ => Err(invalid(format!("backend must be LFAST_BACKEND_AUTO (0), GPU (1) or CPU (2), got {v}"))),
    }
}

fn new_detector(cfg: Config, backend: Backend) -> Result<*mut LfastDetector, Failure> {
    let det = Detector::new(cfg.clone(), backend)?;
    let cpu = CpuDetector::new(cfg)?;
    Ok(Box::into_raw(Box::new(LfastDetector { det, cpu })))
}

/// The library's version, e.g. "0.1.0" (a static string).
#[unsafe(no_mangle)]
pub extern "C" fn lfast_version() -> *const c_char {
    concat!(env!("CARGO_PKG_VERSION"), "\0").as_ptr().cast()
}

/// The message of the last call that failed on this thread ("" before any
/// failure). Valid until the next failing call on this thread.
#[unsafe(no_mangle)]
pub extern "C" fn lfast_last_error() -> *const c_char {
    status::last_error_ptr()
}

/// The default value of every configuration field.
#[unsafe(no_mangle)]
pub extern "C" fn lfast_config_default() -> LfastConfig {
    (&Config::default()).into()
}

/// Checks every field; the error names the first one out of range.
///
/// # Safety
/// `config` is NULL or points to an `LfastConfig`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lfast_config_validate(config: *const LfastConfig) -> LfastStatus {
    guard(|| {
        // SAFETY: the caller passes NULL or a valid pointer
        let c = unsafe { config.as_ref() }.ok_or_else(|| null("config"))?;
        c.to_config().map(|_| ())
    })
}

/// Creates a detector with `config` (NULL = defaults) on `backend` (an
/// `LfastBackend` value) and stores it in `*out`; free it with
/// `lfast_detector_free`.
///
/// # Safety
/// `config` is NULL or points to an `LfastConfig`; `out` points to writable
/// memory for a pointer.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lfast_detector_new(
    config: *const LfastConfig,
    backend: i32,
    out: *mut *mut LfastDetector,
) -> LfastStatus {
    guard(|| {
        if out.is_null() {
            return Err(null("out"));
        }
        // SAFETY: the caller passes NULL or a valid pointer
        let cfg = match unsafe { config.as_ref() } {
            Some(c) => c.to_config()?,
            None => Config::default(),
        };
        put(out, new_detector(cfg, self::backend(backend)?)?);
        Ok(())
    })
}

/// As `lfast_detector_new`, with the configuration as TOML text (the format
/// of `lfast --config FILE`; missing fields take their defaults).
///
/// # Safety
/// `toml` is NULL or a NUL-terminated string; `out` as for `lfast_detector_new`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lfast_detector_new_toml(
    toml: *const c_char,
    backend: i32,
    out: *mut *mut LfastDetector,
) -> LfastStatus {
    guard(|| {
        if toml.is_null() {
            return Err(null("toml"));
        }
        if out.is_null() {
            return Err(null("out"));
        }
        // SAFETY: the caller passes a NUL-terminated string
        let text = unsafe { CStr::from_ptr(toml) }
            .to_str()
            .map_err(|e| Failure(LfastStatus::InvalidConfig, format!("config text is not UTF-8: {e}")))?;
        let cfg = Config::from_toml_str(text)?;
        put(out, new_detector(cfg, self::backend(backend)?)?);
        Ok(())
    })
}

/// Frees a detector (NULL is ignored). No call on it may be running.
///
/// # Safety
/// `detector` is NULL or a pointer from `lfast_detector_new*`, freed once.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lfast_detector_free(detector: *mut LfastDetector) {
    if !detector.is_null() {
        // dropping a detector releases GPU resources; a panic there stays here
        let _ = guard(|| {
            // SAFETY: the pointer came from Box::into_raw in new_detector
            drop(unsafe { Box::from_raw(detector) });
            Ok(())
        });
    }
}

/// Writes the detector's configuration to `*out`.
///
/// # Safety
/// `detector` as for `lfast_detector_free`; `out` points to an `LfastConfig`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lfast_detector_config(detector: *const LfastDetector, out: *mut LfastConfig) -> LfastStatus {
    guard(|| {
        // SAFETY: forwarded from the caller
        let d = unsafe { det_ref(detector) }?;
        if out.is_null() {
            return Err(null("out"));
        }
        put(out, d.det.config().into());
        Ok(())
    })
}

/// "gpu" or "cpu": where the next frame runs (a static string), or NULL for
/// a NULL detector.
///
/// # Safety
/// As `lfast_detector_config`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lfast_detector_backend(detector: *const LfastDetector) -> *const c_char {
    // SAFETY: forwarded from the caller
    match unsafe { detector.as_ref() } {
        Some(d) if d.det.backend_name() == "gpu" => c"gpu".as_ptr(),
        Some(_) => c"cpu".as_ptr(),
        None => std::ptr::null(),
    }
}

/// Shared body of detect and detect_and_compute.
unsafe fn run_detect(
    detector: *const LfastDetector,
    image: *const LfastImage,
    mask: *const LfastImage,
    out: *mut *mut LfastFeatures,
    with_descriptors: bool,
) -> LfastStatus {
    guard(|| {
        // SAFETY: the pointers are forwarded from the caller, who answers for them
        let d = unsafe { det_ref(detector) }?;
        if out.is_null() {
            return Err(null("out"));
        }
        let img = unsafe { image::gray(image, "image") }?;
        let mask = unsafe { image::mask(mask) }?;
        let (kps, desc) = d.det.detect_and_compute(img.view(), mask.as_ref().map(|m| m.view()))?;
        put(out, features(&kps, with_descriptors.then_some(&desc[..])));
        Ok(())
    })
}

/// Detects keypoints in `image`, only where `mask` (NULL = everywhere; 8-bit
/// gray of the image's size) is nonzero, and stores them in `*out`
/// (descriptors NULL). Order: response descending, then octave, y, x.
///
/// # Safety
/// `detector` as for `lfast_detector_free`; `image` and `mask` NULL or
/// pointing to an `LfastImage` whose buffer holds what it describes; `out`
/// points to writable memory for a pointer.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lfast_detect(
    detector: *const LfastDetector,
    image: *const LfastImage,
    mask: *const LfastImage,
    out: *mut *mut LfastFeatures,
) -> LfastStatus {
    // SAFETY: forwarded
    unsafe { run_detect(detector, image, mask, out, false) }
}

/// As `lfast_detect`, with the descriptors.
///
/// # Safety
/// As `lfast_detect`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lfast_detect_and_compute(
    detector: *const LfastDetector,
    image: *const LfastImage,
    mask: *const LfastImage,
    out: *mut *mut LfastFeatures,
) -> LfastStatus {
    // SAFETY: forwarded
    unsafe { run_detect(detector, image, mask, out, true) }
}

/// Descriptors of `count` given keypoints (from any detector) in `image`. A
/// keypoint is described at its `octave`, with the orientation recomputed
/// from the image, so lfast's own keypoints get the descriptors
/// `lfast_detect_and_compute` gave them. `*out` holds the keypoints as given
/// and their descriptors. A keypoint outside the image, or with an octave
/// outside `0..n_levels`, is an `LFAST_STATUS_INVALID_ARGUMENT` naming it.
///
/// # Safety
/// As `lfast_detect`; `keypoints` points to `count` keypoints (or is NULL
/// when `count` is 0).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lfast_compute(
    detector: *const LfastDetector,
    image: *const LfastImage,
    keypoints: *const LfastKeyPoint,
    count: usize,
    out: *mut *mut LfastFeatures,
) -> LfastStatus {
    guard(|| {
        // SAFETY: the pointers are forwarded from the caller, who answers for them
        let d = unsafe { det_ref(detector) }?;
        if out.is_null() {
            return Err(null("out"));
        }
        let img = unsafe { image::gray(image, "image") }?;
        let given: &[LfastKeyPoint] = match (keypoints.is_null(), count) {
            (_, 0) => &[],
            (true, _) => return Err(null("keypoints")),
            (false, n) => {
                if n > isize::MAX as usize / size_of::<LfastKeyPoint>() {
                    return Err(invalid(format!("keypoint count {n} is too large")));
                }
                // SAFETY: the caller passes `count` keypoints
                unsafe { std::slice::from_raw_parts(keypoints, n) }
            }
        };
        let kps: Vec<KeyPoint> = given.iter().map(Into::into).collect();
        let desc = d.cpu.compute(img.view(), &kps)?;
        put(out, features(&kps, Some(&desc)));
        Ok(())
    })
}

/// The improved Canny edge map of `image` (255 = edge, 0 elsewhere), in `*out`.
///
/// # Safety
/// As `lfast_detect`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lfast_edges(
    detector: *const LfastDetector,
    image: *const LfastImage,
    out: *mut *mut LfastPlane,
) -> LfastStatus {
    guard(|| {
        // SAFETY: the pointers are forwarded from the caller, who answers for them
        let d = unsafe { det_ref(detector) }?;
        if out.is_null() {
            return Err(null("out"));
        }
        let img = unsafe { image::gray(image, "image") }?;
        put(out, plane(d.det.edge_image(img.view())?));
        Ok(())
    })
}

/// Reads an image file as 8-bit gray exactly as `lfast detect` does (SPEC 0),
/// into `*out`.
///
/// # Safety
/// `path` is NULL or a NUL-terminated string; `out` points to writable memory
/// for a pointer.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lfast_imread(path: *const c_char, out: *mut *mut LfastPlane) -> LfastStatus {
    guard(|| {
        if path.is_null() {
            return Err(null("path"));
        }
        if out.is_null() {
            return Err(null("out"));
        }
        // SAFETY: the caller passes a NUL-terminated string
        let bytes = unsafe { CStr::from_ptr(path) }.to_bytes();
        #[cfg(unix)]
        let p = std::path::PathBuf::from(<std::ffi::OsStr as std::os::unix::ffi::OsStrExt>::from_bytes(bytes));
        #[cfg(not(unix))]
        let p = std::path::PathBuf::from(String::from_utf8_lossy(bytes).into_owned());
        put(out, plane(lfast::image::load_gray(&p)?));
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_config_round_trips() {
        let c = lfast_config_default();
        assert_eq!(c.to_config().ok().unwrap(), Config::default());
        let all = Config {
            mode: Mode::Paper,
            distribution: true,
            n_features: 7,
            orientation_bins: 0,
            descriptor: DescriptorKind::Opencv,
            ..c.to_config().ok().unwrap()
        };
        assert_eq!(LfastConfig::from(&all).to_config().ok().unwrap(), all);
    }

    #[test]
    fn bad_config_fields_are_named() {
        let c = LfastConfig { mode: 5, ..lfast_config_default() };
        let Err(Failure(s, m)) = c.to_config() else { panic!("accepted") };
        assert_eq!(s, LfastStatus::InvalidConfig);
        assert!(m.contains("`mode`"), "{m}");
        let c = LfastConfig { scale_factor: f64::NAN, ..lfast_config_default() };
        assert!(c.to_config().err().unwrap().1.contains("scale_factor"));
    }

    #[test]
    fn keypoints_convert_both_ways() {
        let k = KeyPoint { pt: [1.5, 2.5].into(), size: 37.2, angle: 12.0, response: 3.0, octave: 1, class_id: -1 };
        assert_eq!(KeyPoint::from(&LfastKeyPoint::from(&k)), k);
        // the layout of cv::KeyPoint: five floats then two ints
        assert_eq!(size_of::<LfastKeyPoint>(), 28);
    }
}
