//! `descriptor = "opencv"`: descriptors equal to OpenCV 5's ORB `compute()` on
//! the same keypoints (modules/features/src/orb.cpp, Apache-2.0; see NOTICE).
//!
//! OpenCV builds its pyramid with `resize(INTER_LINEAR_EXACT)` of the level
//! before ([`resize`]), blurs every level in place as a region of one padded
//! image ([`blur`]: that takes `sepFilter2D`'s float path, not GaussianBlur's
//! fixed-point one), leaves the 32-pixel reflect-101 border around each level
//! unblurred, and samples the pattern rotated by the keypoint's own angle
//! ([`describe`]).

pub mod blur;
pub mod resize;

use crate::image::Plane;
use crate::keypoint::{Descriptor, KeyPoint};
use crate::spec::pattern::Pattern;

/// `cvRound` of an `f32`: half to even.
fn cv_round(v: f32) -> i32 {
    v.round_ties_even() as i32
}

/// `borderInterpolate(p, len, BORDER_REFLECT_101)`.
pub fn reflect101(mut p: i64, len: i64) -> usize {
    if len == 1 {
        return 0;
    }
    while p < 0 || p >= len {
        p = if p < 0 { -p } else { 2 * (len - 1) - p };
    }
    p as usize
}

/// OpenCV's scale of level `l`: `(float)pow((double)scale_factor_f32, l)`
/// (`ORB_create` takes the factor as a float).
pub fn level_scale(scale_factor: f64, l: u32) -> f32 {
    ((scale_factor as f32) as f64).powi(l as i32) as f32
}

/// OpenCV's level sizes: `cvRound(W * (1.0f / scale))`, in floats.
pub fn level_size(width: u32, height: u32, scale_factor: f64, l: u32) -> (u32, u32) {
    let inv = 1.0f32 / level_scale(scale_factor, l);
    let r = |v: u32| cv_round(v as f32 * inv).max(1) as u32;
    (r(width), r(height))
}

/// The unblurred pyramid (levels `0..n`) as OpenCV's ORB builds it.
pub fn pyramid(base: &Plane<u8>, n: usize, scale_factor: f64) -> Vec<Plane<u8>> {
    let mut levels = vec![base.clone()];
    for l in 1..n {
        let (w, h) = level_size(base.width, base.height, scale_factor, l as u32);
        let next = resize::resize_linear_exact(&levels[l - 1], w, h);
        levels.push(next);
    }
    levels
}

/// One level for sampling: the blurred level inside, the unblurred level
/// reflected (101) outside, as OpenCV's padded pyramid image has it.
#[derive(Clone, Debug)]
pub struct Level {
    /// The level before blurring.
    pub raw: Plane<u8>,
    /// The level after [`blur::blur_7x7_sigma2`].
    pub smoothed: Plane<u8>,
}

impl Level {
    /// Blurs `raw`.
    pub fn new(raw: Plane<u8>) -> Self {
        let smoothed = blur::blur_7x7_sigma2(&raw);
        Self { raw, smoothed }
    }

    fn at(&self, x: i32, y: i32) -> u8 {
        let (w, h) = (self.raw.width as i32, self.raw.height as i32);
        if x >= 0 && y >= 0 && x < w && y < h {
            self.smoothed.data[(y * w + x) as usize]
        } else {
            let xr = reflect101(x as i64, w as i64);
            let yr = reflect101(y as i64, h as i64);
            self.raw.data[yr * w as usize + xr]
        }
    }
}

/// The descriptor of `kp` on its level, as `computeOrbDescriptors` does:
/// centre `cvRound(pt * (1.0f / scale))`, `a = cos`, `b = sin` of
/// `angle * (float)(CV_PI / 180)` in f32, offsets `cvRound(x*a - y*b)`,
/// `cvRound(x*b + y*a)` in f32.
pub fn describe(level: &Level, kp: &KeyPoint, scale: f32, pattern: &Pattern) -> Descriptor {
    let inv = 1.0f32 / scale;
    let cx = cv_round(kp.pt.x * inv);
    let cy = cv_round(kp.pt.y * inv);
    let ang = kp.angle * ((std::f64::consts::PI / 180.0) as f32);
    let (a, b) = (ang.cos(), ang.sin());
    let sample = |px: i8, py: i8| {
        let (px, py) = (px as f32, py as f32);
        let x = px * a - py * b;
        let y = px * b + py * a;
        level.at(cx + cv_round(x), cy + cv_round(y))
    };
    let mut d = [0u8; 32];
    for (j, byte) in d.iter_mut().enumerate() {
        for i in 0..8 {
            let p = pattern.pairs[8 * j + i];
            *byte |= ((sample(p[0], p[1]) < sample(p[2], p[3])) as u8) << i;
        }
    }
    d
}
