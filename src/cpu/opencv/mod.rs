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

/// `cvRound` of an `f32`: half to even, as `_mm_cvtss_si32` under the
/// default rounding mode. For `|v| < 2^22` it adds and subtracts 1.5·2^23:
/// at that magnitude f32 has unit spacing, so the sum is `v` rounded to the
/// nearest integer, ties to even, and the difference is exact. That is
/// `round_ties_even` without its libm call (`rintf`: baseline x86-64 has no
/// rounding instruction), which was a fifth of the time of the opencv
/// descriptor (perf, KITTI). Larger values and NaN take `round_ties_even`.
#[inline]
pub fn cv_round(v: f32) -> i32 {
    const MAGIC: f32 = 12_582_912.0; // 1.5 * 2^23
    if v.abs() < 4_194_304.0 { ((v + MAGIC) - MAGIC) as i32 } else { v.round_ties_even() as i32 }
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
/// `cvRound(x*b + y*a)` in f32. The offsets are turned once per keypoint
/// ([`rotated_f32`](crate::cpu::orb::rotated_f32)); where every sample lies
/// inside the level they are read from the blurred level alone by
/// [`orb::describe`](crate::cpu::orb::describe) (its AVX2 gathers), else one
/// by one through the reflected border ([`describe_reference`] is the plain
/// per-sample loop, the tests' reference).
pub fn describe(level: &Level, kp: &KeyPoint, scale: f32, pattern: &Pattern) -> Descriptor {
    let (cx, cy, a, b) = centre_and_rotation(kp, scale);
    let table = crate::cpu::orb::rotated_f32(pattern, a, b);
    // 15·√2 < 21.5: no turned offset leaves -22..=22
    const REACH: i32 = 22;
    let (w, h) = (level.raw.width as i32, level.raw.height as i32);
    if cx >= REACH && cy >= REACH && cx + REACH < w && cy + REACH < h {
        return crate::cpu::orb::describe(&level.smoothed, cx as u32, cy as u32, &table);
    }
    let mut d = [0u8; 32];
    for (j, byte) in d.iter_mut().enumerate() {
        for i in 0..8 {
            let p = table[8 * j + i];
            let s = |x: i8, y: i8| level.at(cx + x as i32, cy + y as i32);
            *byte |= ((s(p[0], p[1]) < s(p[2], p[3])) as u8) << i;
        }
    }
    d
}

/// The keypoint's centre on its level and the cosine and sine of its angle,
/// as `computeOrbDescriptors` computes them.
fn centre_and_rotation(kp: &KeyPoint, scale: f32) -> (i32, i32, f32, f32) {
    let inv = 1.0f32 / scale;
    let ang = kp.angle * ((std::f64::consts::PI / 180.0) as f32);
    (cv_round(kp.pt.x * inv), cv_round(kp.pt.y * inv), ang.cos(), ang.sin())
}

/// [`describe`] as OpenCV's loop reads it: each sample turned, rounded and
/// read on its own, with `round_ties_even` (the reference of the tests).
pub fn describe_reference(level: &Level, kp: &KeyPoint, scale: f32, pattern: &Pattern) -> Descriptor {
    let inv = 1.0f32 / scale;
    let (cx, cy) = ((kp.pt.x * inv).round_ties_even() as i32, (kp.pt.y * inv).round_ties_even() as i32);
    let ang = kp.angle * ((std::f64::consts::PI / 180.0) as f32);
    let (a, b) = (ang.cos(), ang.sin());
    let sample = |px: i8, py: i8| {
        let (px, py) = (px as f32, py as f32);
        let x = px * a - py * b;
        let y = px * b + py * a;
        level.at(cx + x.round_ties_even() as i32, cy + y.round_ties_even() as i32)
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SplitMix64;

    #[test]
    fn cv_round_is_round_ties_even() {
        let check = |v: f32| assert_eq!(cv_round(v), v.round_ties_even() as i32, "{v:e} ({:#x})", v.to_bits());
        // every half-integer and integer of -4096..=4096 and the floats next to them
        for k in -8192i32..=8192 {
            let v = k as f32 / 2.0;
            for u in [v, f32::from_bits(v.to_bits() + 1), f32::from_bits(v.to_bits().wrapping_sub(1))] {
                check(u);
            }
        }
        // the switch to round_ties_even at 2^22, large values, zeros, NaN, infinities
        for v in [4_194_303.5f32, 4_194_304.0, 4_194_304.5, 8_388_607.0, 1e9, -1e9, 0.0, -0.0, f32::INFINITY] {
            check(v);
            check(-v);
        }
        assert_eq!(cv_round(f32::NAN), f32::NAN.round_ties_even() as i32);
        // random magnitudes
        let mut r = SplitMix64::new(7);
        for _ in 0..200_000 {
            let bits = r.next_u64() as u32;
            let v = f32::from_bits(bits);
            if v.is_finite() && v.abs() < 1e12 {
                check(v);
            }
            check((bits >> 8) as f32 / 65536.0 - 128.0);
        }
    }

    #[test]
    fn describe_equals_the_per_sample_loop_inside_and_at_the_border() {
        let pattern = Pattern::orb();
        let mut r = SplitMix64::new(11);
        // a level 5 rows and columns short of a multiple of 8, noise
        let (w, h) = (83u32, 61u32);
        let raw = Plane::from_vec(w, h, (0..w * h).map(|_| r.next_u64() as u8).collect()).unwrap();
        let level = Level::new(raw);
        let scale = level_scale(1.2, 1);
        let mut n = 0;
        for angle in [0.0f32, 45.0, 90.0, 180.0, 270.0, 359.99, 12.5, 33.3] {
            for y in (0..h).step_by(3) {
                for x in (0..w).step_by(2) {
                    let jitter = (r.next_u64() % 1000) as f32 / 1000.0;
                    let kp = KeyPoint {
                        angle,
                        octave: 1,
                        ..KeyPoint::new((x as f32 + jitter) * scale, y as f32 * scale, 31.0)
                    };
                    assert_eq!(
                        describe(&level, &kp, scale, pattern),
                        describe_reference(&level, &kp, scale, pattern),
                        "({x}, {y}) at {angle}°"
                    );
                    n += 1;
                }
            }
        }
        assert!(n > 5000);
    }
}
