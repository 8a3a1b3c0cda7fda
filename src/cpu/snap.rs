//! Beyond the paper (docs/quality.md): each corner that survived corner NMS
//! moves to the Harris maximum of the (2s+1)^2 square around it, `s` =
//! `Config::snap()`, and takes that response. L-FAST's candidates are
//! edge pixels; a corner's Harris maximum lies inside the corner, a pixel or
//! two off the edge, and repeats where the edge pixel does not. The maximum is
//! then located to 1/16 pixel ([`subpixel`]): the peak of the parabola through
//! the responses of it and its two neighbours, along x and along y.
//! Mirrors shaders/snap.wgsl.
//!
//! Positions stay distinct: survivors of corner NMS with radius r are more
//! than r apart (Chebyshev), and `2s <= r` ([`crate::Config::snap`]). The square
//! is scanned row by row; the first of equal responses wins (the earlier
//! (y, x), as in corner NMS). Only pixels at least `border` from every side
//! (where the corner test runs) and, with a mask, where the level mask is on
//! are candidates (the corner's own pixel always is).

use super::response::{harris, harris_3x3, harris_7x7};
use super::select::Corner;
use crate::image::Plane;

/// `c` moved to the Harris maximum on `d` (the level's denoised image) within
/// `s` pixels, at least `border` pixels from every side, where `mask` (if any) is on.
///
/// ```
/// use lfast::{Plane, cpu::{select::Corner, snap::snap}};
/// // a bright square [10, 31)^2: its corner's Harris maximum lies inside, near (12, 12)
/// let img = Plane::from_vec(41, 41, (0..41 * 41).map(|i| {
///     let (x, y) = (i % 41, i / 41);
///     if (10..31).contains(&x) && (10..31).contains(&y) { 200 } else { 20 }
/// }).collect()).unwrap();
/// // a corner found on the top edge, 4 px right of the square's corner
/// let c = Corner { level: 0, x: 14, y: 10, response: 0.0, sub: [0, 0], fill: false };
/// let moved = snap(&img, None, c, 2, 7);
/// assert!(moved.x < 14 && moved.y > 10);
/// assert!(moved.response > lfast::cpu::response::harris(&img, 14, 10));
/// assert_eq!(snap(&img, None, c, 0, 7), Corner { response: lfast::cpu::response::harris(&img, 14, 10), ..c });
/// ```
pub fn snap(d: &Plane<u8>, mask: Option<&Plane<u8>>, c: Corner, s: u32, border: u32) -> Corner {
    let (x0, y0) = (c.x.saturating_sub(s).max(border), c.y.saturating_sub(s).max(border));
    let (x1, y1) =
        ((c.x + s).min(d.width.saturating_sub(border + 1)), (c.y + s).min(d.height.saturating_sub(border + 1)));
    // radius 1: the square's nine responses at once; radius 2 (the default):
    // the 5x5 square and the ring the sub-pixel fit may read, 7x7 at once;
    // each where its footprint is inside the level
    let square = match s {
        1 => harris_3x3(d, c.x, c.y).map(Square::R1),
        2 => harris_7x7(d, c.x, c.y).map(Square::R3),
        _ => None,
    };
    let resp = |x: u32, y: u32| {
        let (i, j) = (x as i64 - c.x as i64, y as i64 - c.y as i64);
        match &square {
            Some(Square::R1(q)) if i.abs() <= 1 && j.abs() <= 1 => q[(j + 1) as usize][(i + 1) as usize],
            Some(Square::R3(q)) if i.abs() <= 3 && j.abs() <= 3 => q[(j + 3) as usize][(i + 3) as usize],
            _ => harris(d, x, y),
        }
    };
    let mut best = Corner { response: resp(c.x, c.y), sub: [0, 0], ..c };
    if s == 0 {
        return best;
    }
    // The responses of the square with a ring around it, kept for the
    // sub-pixel fit (NaN: not computed); radius <= CACHED only.
    let side = 2 * s as i64 + 3;
    let mut seen = [f32::NAN; CACHE];
    let slot = |x: u32, y: u32| -> Option<usize> {
        let (dx, dy) = (x as i64 - c.x as i64 + s as i64 + 1, y as i64 - c.y as i64 + s as i64 + 1);
        (s <= CACHED && (0..side).contains(&dx) && (0..side).contains(&dy)).then(|| (dy * side + dx) as usize)
    };
    if let Some(i) = slot(c.x, c.y) {
        seen[i] = best.response;
    }
    for y in y0..=y1 {
        for x in x0..=x1 {
            if (x, y) == (c.x, c.y) || mask.is_some_and(|m| m.at(x, y) == 0) {
                continue;
            }
            let r = resp(x, y);
            if let Some(i) = slot(x, y) {
                seen[i] = r;
            }
            if r > best.response || (r == best.response && (y, x) < (best.y, best.x)) {
                best = Corner { x, y, response: r, ..best };
            }
        }
    }
    let at = |x: u32, y: u32| match slot(x, y) {
        Some(i) if !seen[i].is_nan() => seen[i],
        _ => resp(x, y),
    };
    let (x, y, r0) = (best.x, best.y, best.response);
    let qx = if x >= 1 && x + 1 < d.width { subpixel(at(x - 1, y), r0, at(x + 1, y)) } else { 0 };
    let qy = if y >= 1 && y + 1 < d.height { subpixel(at(x, y - 1), r0, at(x, y + 1)) } else { 0 };
    best.sub = [qx, qy];
    best
}

/// Harris responses computed at once around a corner: radius 1 and 3 squares.
enum Square {
    R1([[f32; 3]; 3]),
    R3([[f32; 7]; 7]),
}

pub use crate::spec::{SUBPIXEL, SUBPIXEL_MAX};
/// Snap radii whose responses [`snap`] keeps for the sub-pixel fit.
const CACHED: u32 = 2;
/// (2 CACHED + 3)^2.
const CACHE: usize = 49;

/// The peak of the parabola through `(-1, a)`, `(0, r0)`, `(1, b)`,
/// `d = (b - a) / (2 (2 r0 - a - b))`, rounded to the nearest 1/16
/// ([`SUBPIXEL`]) and clamped to ±7/16; 0 where the curvature `2 r0 - a - b`
/// is not positive. No division: `16 d >= k - 1/2` is decided as
/// `b - a >= ((2k - 1) / 16) (2 r0 - a - b)`, each f32 operation rounded once
/// and exact to compare, so shaders/snap.wgsl gives the same steps bit for bit
/// (WGSL rounds f32 `+ - *` correctly; its division is not).
///
/// ```
/// use lfast::cpu::snap::subpixel;
/// assert_eq!(subpixel(1.0, 2.0, 1.0), 0); // symmetric: the peak is on the pixel
/// assert_eq!(subpixel(1.0, 2.0, 1.5), 3); // d = 0.5 / 3 = 0.167 px = 2.67 / 16
/// assert_eq!(subpixel(1.5, 2.0, 1.0), -3);
/// assert_eq!(subpixel(0.0, 2.0, 1.99), 7); // d = 0.497 px, clamped to 7/16
/// assert_eq!(subpixel(1.0, 1.0, 1.0), 0); // flat
/// ```
pub fn subpixel(a: f32, r0: f32, b: f32) -> i8 {
    let den = (2.0 * r0 - a) - b;
    if den.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return 0;
    }
    let num = b - a;
    let mut q = 0;
    for k in 1..=SUBPIXEL_MAX {
        let t = ((2 * k - 1) as f32 / SUBPIXEL as f32) * den;
        if num >= t {
            q = k;
        } else if num <= -t {
            q = -k;
        }
    }
    q
}

/// [`snap`] on every corner of one level, in order.
pub fn snap_all(d: &Plane<u8>, mask: Option<&Plane<u8>>, corners: &mut [Corner], s: u32, border: u32) {
    use rayon::prelude::*;
    corners.par_iter_mut().for_each(|c| *c = snap(d, mask, *c, s, border));
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SplitMix64;

    fn random(w: u32, h: u32, seed: u64) -> Plane<u8> {
        let mut r = SplitMix64::new(seed);
        Plane::from_vec(w, h, (0..w * h).map(|_| (r.next_u64() >> 56) as u8 & 0xf0).collect()).unwrap()
    }

    /// The naive reference: the maximum over the square by (response, then
    /// earliest (y, x)), every pixel `border` inside the level and on in the mask.
    fn naive(d: &Plane<u8>, mask: Option<&Plane<u8>>, c: Corner, s: u32, border: u32) -> Corner {
        let b = border as i64;
        let mut all = Vec::new();
        for y in c.y as i64 - s as i64..=c.y as i64 + s as i64 {
            for x in c.x as i64 - s as i64..=c.x as i64 + s as i64 {
                if x < b || y < b || x >= d.width as i64 - b || y >= d.height as i64 - b {
                    continue;
                }
                let (x, y) = (x as u32, y as u32);
                if (x, y) != (c.x, c.y) && mask.is_some_and(|m| m.at(x, y) == 0) {
                    continue;
                }
                all.push(Corner { x, y, response: harris(d, x, y), ..c });
            }
        }
        all.sort_by(|a, b| b.response.total_cmp(&a.response).then((a.y, a.x).cmp(&(b.y, b.x))));
        let mut best = all[0];
        if s > 0 {
            let (x, y, r) = (best.x, best.y, best.response);
            if x >= 1 && x + 1 < d.width {
                best.sub[0] = subpixel(harris(d, x - 1, y), r, harris(d, x + 1, y));
            }
            if y >= 1 && y + 1 < d.height {
                best.sub[1] = subpixel(harris(d, x, y - 1), r, harris(d, x, y + 1));
            }
        }
        best
    }

    /// `subpixel` against the parabola's peak in f64, rounded: equal wherever
    /// the f64 value is not within 1e-3 step of a rounding boundary.
    #[test]
    fn subpixel_is_the_rounded_parabola_peak() {
        let mut r = SplitMix64::new(7);
        let mut f = || (r.next_u64() >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0;
        let mut checked = 0;
        for _ in 0..200_000 {
            let (a, r0, b) = (f(), f(), f());
            let den = 2.0 * r0 as f64 - a as f64 - b as f64;
            let want = if den <= 0.0 {
                0.0
            } else {
                let q = 8.0 * (b as f64 - a as f64) / den;
                if (q.abs() - q.abs().floor() - 0.5).abs() < 1e-3 {
                    continue;
                }
                q.round().clamp(-7.0, 7.0)
            };
            assert_eq!(subpixel(a, r0, b) as f64, want, "{a} {r0} {b}");
            checked += 1;
        }
        assert!(checked > 190_000);
    }

    #[test]
    fn a_symmetric_peak_stays_and_a_shifted_one_is_located_between_pixels() {
        // a Gaussian blob (sigma 2.5) centred at (cx, 10): Harris peaks at its centre
        let blob = |cx: f64| {
            let v = (0..21 * 21u32).map(|i| {
                let (x, y) = ((i % 21) as f64 - cx, (i / 21) as f64 - 10.0);
                (20.0 + 180.0 * (-(x * x + y * y) / 12.5).exp()).round() as u8
            });
            Plane::from_vec(21, 21, v.collect()).unwrap()
        };
        let start = Corner { level: 0, x: 10, y: 10, response: 0.0, sub: [0, 0], fill: false };
        let c = snap(&blob(10.0), None, start, 1, 7);
        assert_eq!((c.x, c.y, c.sub), (10, 10, [0, 0]));
        for (cx, dx) in [(10.5, 0.5), (10.25, 0.25), (9.75, -0.25)] {
            let c = snap(&blob(cx), None, start, 1, 7);
            let x = c.x as f64 + c.sub[0] as f64 / 16.0;
            // the parabola through three samples of a Gaussian-like peak: within 1/8
            assert!((x - (10.0 + dx)).abs() <= 0.125, "{cx}: {c:?}");
            assert_eq!(c.sub[1], 0, "{cx}");
        }
    }

    #[test]
    fn matches_the_naive_maximum() {
        for seed in 0..4 {
            let d = random(23, 19, seed);
            let m = random(23, 19, seed + 100);
            for border in [0, 2, 7] {
                for y in border..19 - border {
                    for x in border..23 - border {
                        let c = Corner { level: 2, x, y, response: -1.0, sub: [0, 0], fill: false };
                        for s in 0..3 {
                            let what = format!("{seed} {x} {y} {s} {border}");
                            assert_eq!(snap(&d, None, c, s, border), naive(&d, None, c, s, border), "{what}");
                            assert_eq!(snap(&d, Some(&m), c, s, border), naive(&d, Some(&m), c, s, border), "{what}");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn ties_go_to_the_earliest_position() {
        // a flat image: every response is 0, the first pixel of the square wins
        let d = Plane::from_vec(9, 9, vec![50; 81]).unwrap();
        let c = snap(&d, None, Corner { level: 0, x: 4, y: 4, response: 7.0, sub: [0, 0], fill: false }, 1, 0);
        assert_eq!((c.x, c.y, c.response), (3, 3, 0.0));
    }
}
