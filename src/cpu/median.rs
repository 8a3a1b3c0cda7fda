//! SPEC 1: noise-flagged 3x3 median (paper Eq. 1). Mirrors shaders/median.wgsl.
//!
//! A pixel is noise when it differs from all four 4-neighbours by more than
//! `delta * G`; only noise pixels are replaced by the 3x3 median of the input.

use crate::image::Plane;
use rayon::prelude::*;

/// True iff pixel (x, y) of `src` is flagged as noise: for each 4-neighbour
/// `Gn` (replicate border), `delta_den * |G - Gn| > delta_num * G`.
///
/// ```
/// use lfast::Plane;
/// use lfast::cpu::median::is_noise;
/// let mut img = Plane::<u8>::new(3, 3);
/// img.data.fill(50);
/// img.data[4] = 255; // a salt pixel
/// assert!(is_noise(&img, 1, 1, 1, 10));
/// assert!(!is_noise(&img, 0, 0, 1, 10));
/// ```
#[inline]
pub fn is_noise(src: &Plane<u8>, x: u32, y: u32, delta_num: u32, delta_den: u32) -> bool {
    let (x, y) = (x as i32, y as i32);
    let g = src.clamped(x, y) as i32;
    let lim = delta_num as u64 * g as u64;
    [(0, -1), (0, 1), (-1, 0), (1, 0)]
        .iter()
        .all(|&(dx, dy)| delta_den as u64 * (g - src.clamped(x + dx, y + dy) as i32).unsigned_abs() as u64 > lim)
}

/// Median of the 3x3 window around (x, y), replicate border.
#[inline]
pub fn median3x3(src: &Plane<u8>, x: u32, y: u32) -> u8 {
    let (w, h) = (src.width, src.height);
    if x > 0 && y > 0 && x + 1 < w && y + 1 < h {
        // inside: three row slices, no clamping
        let w = w as usize;
        let c = y as usize * w + x as usize;
        let (u, m, d) = (&src.data[c - w - 1..c - w + 2], &src.data[c - 1..c + 2], &src.data[c + w - 1..c + w + 2]);
        return median9([u[0], u[1], u[2], m[0], m[1], m[2], d[0], d[1], d[2]]);
    }
    let (x, y) = (x as i32, y as i32);
    let mut v = [0u8; 9];
    let mut i = 0;
    for dy in -1..=1 {
        for dx in -1..=1 {
            v[i] = src.clamped(x + dx, y + dy);
            i += 1;
        }
    }
    median9(v)
}

/// Median of nine values with the classic 19-exchange network (branch-free,
/// the same network the shader uses).
#[inline]
pub fn median9(mut p: [u8; 9]) -> u8 {
    #[inline(always)]
    fn s(p: &mut [u8; 9], a: usize, b: usize) {
        let (x, y) = (p[a], p[b]);
        p[a] = x.min(y);
        p[b] = x.max(y);
    }
    s(&mut p, 1, 2);
    s(&mut p, 4, 5);
    s(&mut p, 7, 8);
    s(&mut p, 0, 1);
    s(&mut p, 3, 4);
    s(&mut p, 6, 7);
    s(&mut p, 1, 2);
    s(&mut p, 4, 5);
    s(&mut p, 7, 8);
    s(&mut p, 0, 3);
    s(&mut p, 5, 8);
    s(&mut p, 4, 7);
    s(&mut p, 3, 6);
    s(&mut p, 1, 4);
    s(&mut p, 2, 5);
    s(&mut p, 4, 7);
    s(&mut p, 4, 2);
    s(&mut p, 6, 4);
    s(&mut p, 4, 2);
    p[4]
}

/// The flagged median D of SPEC 1.
pub fn median(src: &Plane<u8>, delta_num: u32, delta_den: u32) -> Plane<u8> {
    let (w, h) = (src.width as usize, src.height as usize);
    let mut out = Plane::<u8>::new(src.width, src.height);
    out.data.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        let up = src.row(y.saturating_sub(1) as u32);
        let mid = src.row(y as u32);
        let down = src.row((y + 1).min(h - 1) as u32);
        for x in 0..w {
            let g = mid[x] as i32;
            let lim = delta_num * g as u32;
            let l = mid[x.saturating_sub(1)] as i32;
            let r = mid[(x + 1).min(w - 1)] as i32;
            let differs = |n: i32| delta_den * (g - n).unsigned_abs() > lim;
            // `&` not `&&`: no branches in the common case (a smooth pixel).
            row[x] = if differs(up[x] as i32) & differs(down[x] as i32) & differs(l) & differs(r) {
                median3x3(src, x as u32, y as u32)
            } else {
                mid[x]
            };
        }
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plane(w: u32, h: u32, v: &[u8]) -> Plane<u8> {
        Plane::from_vec(w, h, v.to_vec()).unwrap()
    }

    #[test]
    fn salt_pixel_is_flagged_and_replaced() {
        #[rustfmt::skip]
        let img = plane(3, 3, &[
            10, 20, 30,
            40, 250, 60,
            70, 80, 90,
        ]);
        assert!(is_noise(&img, 1, 1, 1, 10));
        let d = median(&img, 1, 10);
        // sorted window: 10 20 30 40 60 70 80 90 250 -> 60
        assert_eq!(d.at(1, 1), 60);
        // the other pixels are copied: each has a neighbour equal to itself at the border
        for (i, (&a, &b)) in img.data.iter().zip(&d.data).enumerate() {
            if i != 4 {
                assert_eq!(a, b, "pixel {i}");
            }
        }
    }

    #[test]
    fn pepper_pixel_is_flagged() {
        let mut img = plane(3, 3, &[100; 9]);
        img.data[4] = 0;
        assert!(is_noise(&img, 1, 1, 1, 10));
        assert_eq!(median(&img, 1, 10).at(1, 1), 100);
    }

    #[test]
    fn edge_pixel_is_not_flagged() {
        // A vertical step: the centre equals its upper and lower neighbours.
        #[rustfmt::skip]
        let img = plane(3, 3, &[
            0, 200, 200,
            0, 200, 200,
            0, 200, 200,
        ]);
        assert!(!is_noise(&img, 1, 1, 1, 10));
        assert_eq!(median(&img, 1, 10), img);
    }

    #[test]
    fn threshold_is_strict_and_relative() {
        // G = 100, delta 0.1: a difference of exactly 10 is not noise, 11 is.
        let mut img = plane(3, 3, &[90; 9]);
        img.data[4] = 100;
        assert!(!is_noise(&img, 1, 1, 1, 10));
        img.data.iter_mut().enumerate().filter(|(i, _)| *i != 4).for_each(|(_, v)| *v = 89);
        assert!(is_noise(&img, 1, 1, 1, 10));
    }

    #[test]
    fn median9_matches_sort() {
        let mut seed = 12345u32;
        for _ in 0..2000 {
            let mut v = [0u8; 9];
            for x in &mut v {
                seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
                *x = (seed >> 24) as u8;
            }
            let mut s = v;
            s.sort();
            assert_eq!(median9(v), s[4]);
        }
    }

    proptest::proptest! {
        #[test]
        fn matches_naive(w in 1u32..12, h in 1u32..12, seed in proptest::prelude::any::<u64>(), num in 1u32..30) {
            let mut s = seed;
            let data: Vec<u8> = (0..w * h).map(|_| { s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407); (s >> 56) as u8 }).collect();
            let img = plane(w, h, &data);
            let d = median(&img, num, 10);
            for y in 0..h { for x in 0..w {
                // naive: sort the clamped window
                let mut win = vec![];
                for dy in -1..=1 { for dx in -1..=1 { win.push(img.clamped(x as i32 + dx, y as i32 + dy)); } }
                win.sort();
                let want = if is_noise(&img, x, y, num, 10) { win[4] } else { img.at(x, y) };
                proptest::prop_assert_eq!(d.at(x, y), want);
            }}
        }
    }
}
