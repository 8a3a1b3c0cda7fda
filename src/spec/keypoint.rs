//! Keypoint position <-> level pixel (SPEC 10, 11), one definition of each
//! direction:
//!
//! - [`keypoint_at`]: the keypoint of a corner at level pixel (x, y) of level
//!   `l` (scale `s = scale_factor^l`): `pt = ((x + centre) s, (y + centre) s)`,
//!   `size = 31 s`, computed in f64 and rounded to f32 once. `centre` is where a
//!   pixel's position lies within it: [`LFAST_CENTRE`] (0.5) for L-FAST corners,
//!   which sit on the gradient grid, [`OPENCV_CENTRE`] (0) for FAST/ORB as
//!   OpenCV reports them. The CPU path, the GPU readback and the baselines all
//!   build their keypoints here.
//!   [`keypoint_at_sub`] adds a snapped corner's sub-pixel offset
//!   (`sub / 16`, at most 7/16 either way; src/cpu/snap.rs).
//! - [`level_pixel`]: the level pixel a keypoint position names,
//!   `floor(pt / s + 1/32)`: the intended pixel under both conventions and
//!   with any sub-pixel offset (OpenCV's `x s` and lfast's `(x + 1/2 ± 7/16) s`
//!   both lie in `[x - 1/32, x + 1 - 1/32)`, with room for the f32 rounding),
//!   used to describe caller-supplied keypoints and by the tests that map
//!   keypoints back.

use crate::config::Config;
use crate::keypoint::KeyPoint;

/// Sub-pixel steps per level pixel of a snapped corner's offset
/// (`Corner::sub`, `GpuKeypoint::sub`; src/cpu/snap.rs, shaders/snap.wgsl).
pub const SUBPIXEL: i32 = 16;
/// The largest sub-pixel offset, in steps: 7/16 px keeps the position inside
/// its pixel ([`level_pixel`] maps it back to the same pixel).
pub const SUBPIXEL_MAX: i8 = 7;

/// Position of an L-FAST corner within its pixel.
pub const LFAST_CENTRE: f64 = 0.5;
/// Position of a FAST/ORB corner within its pixel (OpenCV's convention).
pub const OPENCV_CENTRE: f64 = 0.0;

/// The keypoint of level pixel (x, y) of level `level`, of scale `s`.
///
/// ```
/// let k = lfast::spec::keypoint_at(1, 10, 4, 1.2, lfast::spec::LFAST_CENTRE, 90.0, 3.0);
/// assert_eq!((k.pt.x, k.pt.y, k.size, k.octave), (12.6, 5.4, 37.2, 1));
/// ```
pub fn keypoint_at(level: u32, x: u32, y: u32, s: f64, centre: f64, angle: f32, response: f32) -> KeyPoint {
    keypoint_at_sub(level, [x, y], [0, 0], s, centre, angle, response)
}

/// [`keypoint_at`] of level pixel `p` moved by `sub / 16` of a pixel
/// ([`SUBPIXEL`] steps), still computed in f64 and rounded once.
///
/// ```
/// let k = lfast::spec::keypoint_at_sub(0, [10, 4], [4, -2], 1.0, lfast::spec::LFAST_CENTRE, 0.0, 0.0);
/// assert_eq!((k.pt.x, k.pt.y), (10.75, 4.375));
/// assert_eq!(lfast::spec::level_pixel(k.pt.x, 1.0), 10.0);
/// ```
pub fn keypoint_at_sub(
    level: u32,
    p: [u32; 2],
    sub: [i8; 2],
    s: f64,
    centre: f64,
    angle: f32,
    response: f32,
) -> KeyPoint {
    let step = SUBPIXEL as f64;
    let at = |x: u32, q: i8| ((x as f64 + centre + q as f64 / step) * s) as f32;
    KeyPoint {
        pt: glam::Vec2::new(at(p[0], sub[0]), at(p[1], sub[1])),
        size: (31.0 * s) as f32,
        angle,
        response,
        octave: level as i32,
        class_id: -1,
    }
}

/// The level pixel coordinate that position `p` names at scale `s`:
/// `floor(p / s + 1/32)` (may be negative or past the level; the caller checks).
///
/// ```
/// use lfast::spec::{LFAST_CENTRE, OPENCV_CENTRE, keypoint_at, level_pixel};
/// let s = 1.2f64.powi(3);
/// for centre in [LFAST_CENTRE, OPENCV_CENTRE] {
///     let k = keypoint_at(3, 17, 9, s, centre, 0.0, 0.0);
///     assert_eq!((level_pixel(k.pt.x, s), level_pixel(k.pt.y, s)), (17.0, 9.0));
/// }
/// ```
pub fn level_pixel(p: f32, s: f64) -> f64 {
    (p as f64 / s + 1.0 / 32.0).floor()
}

/// The 1/[`SUBPIXEL`]-px offset of position `p` (input pixels, level scale `s`)
/// from its level pixel `pixel` ([`level_pixel`]) under the L-FAST centre:
/// the inverse of [`keypoint_at_sub`], `q = round(16 (p / s - pixel - 1/2))`
/// when `|q| <=` [`SUBPIXEL_MAX`] (lfast's own positions), else 0 (OpenCV's
/// `p = pixel * s`, on the pixel's corner, whose `q` would be -8).
///
/// ```
/// use lfast::spec::{keypoint_at_sub, level_pixel, level_subpixel, LFAST_CENTRE};
/// let s = 1.2f64.powi(3);
/// let kp = keypoint_at_sub(3, [40, 17], [-5, 7], s, LFAST_CENTRE, 0.0, 1.0);
/// let (x, y) = (level_pixel(kp.pt.x, s), level_pixel(kp.pt.y, s));
/// assert_eq!((x, y), (40.0, 17.0));
/// assert_eq!([level_subpixel(kp.pt.x, s, x), level_subpixel(kp.pt.y, s, y)], [-5, 7]);
/// // an OpenCV keypoint (pt = pixel * s) has no offset
/// let cv = (40.0 * s) as f32;
/// assert_eq!(level_subpixel(cv, s, level_pixel(cv, s)), 0);
/// ```
pub fn level_subpixel(p: f32, s: f64, pixel: f64) -> i8 {
    let q = (SUBPIXEL as f64 * (p as f64 / s - pixel - LFAST_CENTRE)).round();
    if q.abs() <= SUBPIXEL_MAX as f64 { q as i8 } else { 0 }
}

/// The level pixel (x, y) of a keypoint under `cfg`'s scale (by [`level_pixel`]),
/// for keypoints inside their level.
pub fn keypoint_level_pixel(cfg: &Config, k: &KeyPoint) -> (u32, u32) {
    let s = cfg.level_scale(k.octave.max(0) as u32);
    (level_pixel(k.pt.x, s).max(0.0) as u32, level_pixel(k.pt.y, s).max(0.0) as u32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_on_every_pixel_of_a_pyramid() {
        let cfg = Config::default();
        for (l, &(w, h)) in cfg.level_sizes(1241, 376).iter().enumerate() {
            let s = cfg.level_scale(l as u32);
            for centre in [LFAST_CENTRE, OPENCV_CENTRE] {
                for x in 0..w {
                    let k = keypoint_at(l as u32, x, h - 1, s, centre, 0.0, 0.0);
                    assert_eq!(keypoint_level_pixel(&cfg, &k), (x, h - 1), "level {l} x {x} centre {centre}");
                }
            }
            let m = SUBPIXEL_MAX;
            for x in 0..w {
                for q in -m..=m {
                    let k = keypoint_at_sub(l as u32, [x, h - 1], [q, -q], s, LFAST_CENTRE, 0.0, 0.0);
                    assert_eq!(keypoint_level_pixel(&cfg, &k), (x, h - 1), "level {l} x {x} sub {q}");
                }
            }
        }
    }
}
