//! Separable Gaussian blur with integer Q8 weights and BORDER_REFLECT_101, as
//! OpenCV's fixed-point GaussianBlur for 8-bit images. SPEC 11 uses the 7x7,
//! sigma 2 kernel before sampling descriptors. Mirrors shaders/blur.wgsl.

use crate::image::Plane;
use rayon::prelude::*;

/// Q8 weights of a `ksize`-tap Gaussian with `sigma`, summing exactly to 256:
/// each weight rounded, the rounding error put on the centre tap.
///
/// ```
/// assert_eq!(lfast::cpu::blur::gaussian_kernel_q8(7, 2.0), vec![18, 34, 49, 54, 49, 34, 18]);
/// ```
pub fn gaussian_kernel_q8(ksize: usize, sigma: f64) -> Vec<u32> {
    let r = (ksize / 2) as i64;
    let g: Vec<f64> = (-r..=r).map(|i| (-(i * i) as f64 / (2.0 * sigma * sigma)).exp()).collect();
    let sum: f64 = g.iter().sum();
    let mut w: Vec<u32> = g.iter().map(|v| (v / sum * 256.0).round() as u32).collect();
    let total: u32 = w.iter().sum();
    w[r as usize] = (w[r as usize] as i64 + 256 - total as i64) as u32;
    w
}

/// The ORB smoothing kernel of SPEC 11: 7 taps, sigma 2.
pub const ORB_KERNEL: [u32; 7] = [18, 34, 49, 54, 49, 34, 18];

/// BORDER_REFLECT_101 index (`gfedcb|abcdefgh|gfedcba`); a 1-pixel axis clamps.
#[inline(always)]
pub fn reflect101(i: i32, len: i32) -> usize {
    if len == 1 {
        return 0;
    }
    let period = 2 * (len - 1);
    let mut i = i.rem_euclid(period);
    if i >= len {
        i = period - i;
    }
    i as usize
}

/// Separable blur: horizontal pass to Q8 u32, vertical pass to Q16, rounded.
pub fn gaussian_blur(src: &Plane<u8>, kernel: &[u32]) -> Plane<u8> {
    let (w, h) = (src.width as usize, src.height as usize);
    let r = (kernel.len() / 2) as i32;
    let mut tmp = vec![0u32; w * h];
    tmp.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        let s = src.row(y as u32);
        for (x, o) in row.iter_mut().enumerate() {
            let mut acc = 0u32;
            for (k, &wk) in kernel.iter().enumerate() {
                acc += wk * s[reflect101(x as i32 + k as i32 - r, w as i32)] as u32;
            }
            *o = acc;
        }
    });
    let mut out = Plane::<u8>::new(src.width, src.height);
    out.data.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, o) in row.iter_mut().enumerate() {
            let mut acc = 0u32;
            for (k, &wk) in kernel.iter().enumerate() {
                acc += wk * tmp[reflect101(y as i32 + k as i32 - r, h as i32) * w + x];
            }
            *o = ((acc + (1 << 15)) >> 16) as u8;
        }
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn orb_kernel_matches_formula() {
        assert_eq!(gaussian_kernel_q8(7, 2.0), ORB_KERNEL.to_vec());
        assert_eq!(ORB_KERNEL.iter().sum::<u32>(), 256);
        let k5 = gaussian_kernel_q8(5, 0.8);
        assert_eq!(k5.iter().sum::<u32>(), 256);
        assert_eq!(k5, k5.iter().rev().copied().collect::<Vec<_>>());
    }

    #[test]
    fn reflect101_indices() {
        let v: Vec<usize> = (-3..8).map(|i| reflect101(i, 5)).collect();
        assert_eq!(v, vec![3, 2, 1, 0, 1, 2, 3, 4, 3, 2, 1]);
        assert_eq!(reflect101(-5, 1), 0);
        assert_eq!(reflect101(-9, 2), 1);
    }

    #[test]
    fn impulse_response_is_the_kernel() {
        // a column of 255s: vertical pass is identity, the row shows the kernel
        let mut img = Plane::<u8>::new(15, 3);
        for y in 0..3 {
            img.data[y * 15 + 7] = 255;
        }
        let b = gaussian_blur(&img, &ORB_KERNEL);
        let row: Vec<u8> = b.row(1)[4..11].to_vec();
        let want: Vec<u8> = ORB_KERNEL.iter().map(|&k| ((255 * k * 256 + (1 << 15)) >> 16) as u8).collect();
        assert_eq!(row, want);
        let flat = Plane::from_vec(4, 4, vec![77u8; 16]).unwrap();
        assert_eq!(gaussian_blur(&flat, &ORB_KERNEL), flat);
    }
}
