//! Beyond the paper (docs/quality.md): each corner that survived corner NMS
//! moves to the Harris maximum of the (2s+1)^2 square around it, `s` =
//! `Config::snap()`, and takes that response. L-FAST's candidates are
//! edge pixels; a corner's Harris maximum lies inside the corner, a pixel or
//! two off the edge, and repeats where the edge pixel does not.
//! Mirrors shaders/snap.wgsl.
//!
//! Positions stay distinct: survivors of corner NMS with radius r are more
//! than r apart (Chebyshev), and `2s <= r` ([`crate::Config::snap`]). The square
//! is scanned row by row; the first of equal responses wins (the earlier
//! (y, x), as in corner NMS). Only pixels at least `border` from every side
//! (where the corner test runs) and, with a mask, where the level mask is on
//! are candidates (the corner's own pixel always is).

use super::response::harris;
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
/// let c = Corner { level: 0, x: 14, y: 10, response: 0.0 };
/// let moved = snap(&img, None, c, 2, 7);
/// assert!(moved.x < 14 && moved.y > 10);
/// assert!(moved.response > lfast::cpu::response::harris(&img, 14, 10));
/// assert_eq!(snap(&img, None, c, 0, 7), Corner { response: lfast::cpu::response::harris(&img, 14, 10), ..c });
/// ```
pub fn snap(d: &Plane<u8>, mask: Option<&Plane<u8>>, c: Corner, s: u32, border: u32) -> Corner {
    let (x0, y0) = (c.x.saturating_sub(s).max(border), c.y.saturating_sub(s).max(border));
    let (x1, y1) =
        ((c.x + s).min(d.width.saturating_sub(border + 1)), (c.y + s).min(d.height.saturating_sub(border + 1)));
    let mut best = Corner { response: harris(d, c.x, c.y), ..c };
    for y in y0..=y1 {
        for x in x0..=x1 {
            if (x, y) == (c.x, c.y) || mask.is_some_and(|m| m.at(x, y) == 0) {
                continue;
            }
            let r = harris(d, x, y);
            if r > best.response || (r == best.response && (y, x) < (best.y, best.x)) {
                best = Corner { x, y, response: r, ..c };
            }
        }
    }
    best
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
        all[0]
    }

    #[test]
    fn matches_the_naive_maximum() {
        for seed in 0..4 {
            let d = random(23, 19, seed);
            let m = random(23, 19, seed + 100);
            for border in [0, 2, 7] {
                for y in border..19 - border {
                    for x in border..23 - border {
                        let c = Corner { level: 2, x, y, response: -1.0 };
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
        let c = snap(&d, None, Corner { level: 0, x: 4, y: 4, response: 7.0 }, 1, 0);
        assert_eq!((c.x, c.y, c.response), (3, 3, 0.0));
    }
}
