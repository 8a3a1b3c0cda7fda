//! OpenCV's 7x7, sigma 2 Gaussian blur of an ORB pyramid level.
//!
//! ORB blurs each level as a region of its padded pyramid image without
//! `BORDER_ISOLATED`, so GaussianBlur skips its fixed-point path
//! (smooth.dispatch.cpp) and runs `sepFilter2D` with the f32 kernel
//! `getGaussianKernel(7, 2, CV_32F)`: the kernel does not sum to 1 exactly in
//! f32 terms, so the filter engine works in floats (filter.simd.hpp):
//! - rows: `s = 0; s = fma(p[x+i], k[i], s)` for i = 0..7;
//! - columns (symmetric): `s = r[y] * k[3]`, then
//!   `s = fma(r[y-j] + r[y+j], k[3+j], s)` for j = 1..3;
//! - `saturate_cast<uchar>`: round half to even, clamp to 0..=255.
//!
//! The border is reflect-101 (the region's neighbours are its reflect-101 padding).

use super::reflect101;
use crate::image::Plane;

/// `getGaussianKernel(7, 2, CV_32F)` as f32 bit patterns.
pub const KERNEL_BITS: [u32; 7] = [0x3d8fafb1, 0x3e06387e, 0x3e434a39, 0x3e5d4ae0, 0x3e434a39, 0x3e06387e, 0x3d8fafb1];

/// The kernel as f32.
pub fn kernel() -> [f32; 7] {
    KERNEL_BITS.map(f32::from_bits)
}

/// The kernel as `getGaussianKernelBitExact` computes it in doubles
/// (`exp(-x^2 / 8)` normalised), cast to f32.
pub fn kernel_from_formula() -> [f32; 7] {
    let t: Vec<f64> = [-6i32, -4, -2].iter().map(|&x| ((x * x) as f64 * (-0.125 / 4.0)).exp()).collect();
    let sum = 2.0 * (t[0] + t[1] + t[2]) + 1.0;
    let m = 1.0 / sum;
    let (a, b, c, d) = ((t[0] * m) as f32, (t[1] * m) as f32, (t[2] * m) as f32, m as f32);
    [a, b, c, d, c, b, a]
}

/// `saturate_cast<uchar>(float)`.
fn to_u8(v: f32) -> u8 {
    v.round_ties_even().clamp(0.0, 255.0) as u8
}

/// One row of the horizontal pass: `line` is the row with 3 reflected
/// pixels each side, `out[x] = fma chain of line[x..x + 7]`.
#[inline(always)]
fn row_pass(line: &[f32], k: &[f32; 7], out: &mut [f32]) {
    for (x, o) in out.iter_mut().enumerate() {
        let mut s = 0f32;
        for (i, &ki) in k.iter().enumerate() {
            s = line[x + i].mul_add(ki, s);
        }
        *o = s;
    }
}

/// One row of the vertical pass over the 7 filtered rows `r[0..7]`.
#[inline(always)]
fn col_pass(r: [&[f32]; 7], k: &[f32; 7], out: &mut [u8]) {
    for (x, o) in out.iter_mut().enumerate() {
        let mut s = r[3][x] * k[3];
        for j in 1..4 {
            s = (r[3 - j][x] + r[3 + j][x]).mul_add(k[3 + j], s);
        }
        *o = to_u8(s);
    }
}

/// [`row_pass`] compiled with hardware FMA (the same results: `mul_add` is
/// one rounding either way, only faster).
///
/// # Safety
/// The CPU has FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "fma")]
unsafe fn row_pass_fma(line: &[f32], k: &[f32; 7], out: &mut [f32]) {
    row_pass(line, k, out)
}

/// [`col_pass`] with hardware FMA.
///
/// # Safety
/// The CPU has FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "fma")]
unsafe fn col_pass_fma(r: [&[f32]; 7], k: &[f32; 7], out: &mut [u8]) {
    col_pass(r, k, out)
}

fn has_fma() -> bool {
    #[cfg(target_arch = "x86_64")]
    return std::is_x86_feature_detected!("fma");
    #[cfg(not(target_arch = "x86_64"))]
    false
}

/// Blurs `img` as OpenCV's ORB blurs a level.
///
/// ```
/// let img = lfast::Plane::from_vec(9, 9, vec![100; 81]).unwrap();
/// assert!(lfast::cpu::opencv::blur::blur_7x7_sigma2(&img).data.iter().all(|&v| v == 100));
/// ```
pub fn blur_7x7_sigma2(img: &Plane<u8>) -> Plane<u8> {
    use rayon::prelude::*;
    let k = kernel();
    let fma = has_fma();
    let (w, h) = (img.width as usize, img.height as usize);
    let mut out = Plane::<u8>::new(img.width, img.height);
    if w == 0 || h == 0 {
        return out;
    }
    // horizontal pass over rows -3..h+3 (reflect-101)
    let mut rows = vec![0f32; w * (h + 6)];
    // one padded line per worker, reused from row to row
    rows.par_chunks_mut(w).enumerate().for_each_init(
        || vec![0f32; w + 6],
        |line, (yy, o)| {
            let sy = reflect101(yy as i64 - 3, h as i64);
            let src = &img.data[sy * w..(sy + 1) * w];
            for (l, &s) in line[3..w + 3].iter_mut().zip(src) {
                *l = s as f32;
            }
            for x in (0..3).chain(w + 3..w + 6) {
                line[x] = src[reflect101(x as i64 - 3, w as i64)] as f32;
            }
            #[cfg(target_arch = "x86_64")]
            if fma {
                // SAFETY: FMA was detected just above
                return unsafe { row_pass_fma(line, &k, o) };
            }
            row_pass(line, &k, o);
        },
    );
    out.data.par_chunks_mut(w).enumerate().for_each(|(y, o)| {
        let r: [&[f32]; 7] = std::array::from_fn(|j| &rows[(y + j) * w..(y + j + 1) * w]);
        #[cfg(target_arch = "x86_64")]
        if fma {
            // SAFETY: FMA was detected just above
            return unsafe { col_pass_fma(r, &k, o) };
        }
        col_pass(r, &k, o);
    });
    let _ = fma;
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hardware_fma_path_equals_the_portable_one() {
        let (w, h) = (37u32, 29u32);
        let img = Plane::from_vec(w, h, (0..w * h).map(|i| (i.wrapping_mul(2246822519) >> 9) as u8).collect()).unwrap();
        let k = kernel();
        let (wu, hu) = (w as usize, h as usize);
        let mut rows = vec![0f32; wu * (hu + 6)];
        for (yy, o) in rows.chunks_mut(wu).enumerate() {
            let sy = reflect101(yy as i64 - 3, h as i64);
            let line: Vec<f32> =
                (0..wu + 6).map(|x| img.data[sy * wu + reflect101(x as i64 - 3, w as i64)] as f32).collect();
            row_pass(&line, &k, o);
        }
        let mut want = vec![0u8; wu * hu];
        for (y, o) in want.chunks_mut(wu).enumerate() {
            col_pass(std::array::from_fn(|j| &rows[(y + j) * wu..(y + j + 1) * wu]), &k, o);
        }
        assert_eq!(blur_7x7_sigma2(&img).data, want);
    }

    #[test]
    fn kernel_is_the_formula() {
        assert_eq!(kernel(), kernel_from_formula());
    }

    #[test]
    fn impulse_by_hand() {
        // a 255 impulse: the centre is 255 * k3^2 = 11.91 -> 12, its
        // neighbour 255 * k3 * k2 = 10.51 -> 11 (as cv2.sepFilter2D gives)
        let mut img = Plane::<u8>::new(21, 21);
        img.data[10 * 21 + 10] = 255;
        let b = blur_7x7_sigma2(&img);
        let row: Vec<u8> = (7..14).map(|x| b.at(x, 10)).collect();
        assert_eq!(row, [4, 7, 11, 12, 11, 7, 4]);
        assert_eq!(b.at(7, 7), 1);
        assert_eq!(b.at(10, 3), 0);
    }

    #[test]
    fn matches_a_naive_2d_sum_away_from_half_ties() {
        // the separable float result equals the exact 2-D sum rounded, except
        // where that sum is within f32 error of a .5 tie
        let (w, h) = (23u32, 17u32);
        let img =
            Plane::from_vec(w, h, (0..w * h).map(|i| (i.wrapping_mul(2654435761) >> 11) as u8).collect()).unwrap();
        let k = kernel().map(|v| v as f64);
        let b = blur_7x7_sigma2(&img);
        for y in 0..h as i64 {
            for x in 0..w as i64 {
                let mut s = 0f64;
                for j in 0..7 {
                    for i in 0..7 {
                        let p =
                            img.data[reflect101(y + j - 3, h as i64) * w as usize + reflect101(x + i - 3, w as i64)];
                        s += k[j as usize] * k[i as usize] * p as f64;
                    }
                }
                if (s - s.floor() - 0.5).abs() > 1e-3 {
                    assert_eq!(b.data[(y * w as i64 + x) as usize], s.round() as u8, "({x}, {y})");
                }
            }
        }
    }
}
