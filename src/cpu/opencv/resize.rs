//! `resize(INTER_LINEAR_EXACT)` for 8-bit gray (resize.cpp, `resize_bitExact`
//! with `interpolationLinear`): coefficients in 8-bit fixed point, the
//! horizontal pass in 8 fractional bits, the vertical in 16, rounded half up.

use crate::image::Plane;

/// Per destination index: source offset, weight of the next sample (/256),
/// and the range `[min, max)` that interpolates (left of it: the first
/// sample, right of it: the last).
struct Axis {
    ofs: Vec<u32>,
    c1: Vec<u32>,
    min: usize,
    max: usize,
}

fn axis(src: u32, dst: u32) -> Axis {
    let inv_scale = dst as f64 / src as f64;
    let scale = 1.0 / inv_scale;
    let (mut ofs, mut c1) = (vec![0u32; dst as usize], vec![0u32; dst as usize]);
    let (mut min, mut max) = (0usize, dst as usize);
    for d in 0..dst as usize {
        let f = scale * (d as f64 + 0.5) - 0.5;
        let i = f.floor();
        if i >= 0.0 && src > 1 {
            if i < (src - 1) as f64 {
                ofs[d] = i as u32;
                // ufixedpoint16(softdouble): cvRound(v * 256), negative -> 0
                c1[d] = ((f - i) * 256.0).round_ties_even() as u32;
            } else {
                ofs[d] = src - 1;
                max = max.min(d);
            }
        } else {
            min = min.max(d + 1);
        }
    }
    // an interpolating index past the end would be clamped: no such index
    // (min <= max holds whenever dst >= 1)
    let max = max.max(min);
    Axis { ofs, c1, min, max }
}

/// One source row resized horizontally, in 8 fractional bits: the first
/// sample left of `min`, the last from `max` on, and between them
/// `(256 - c1) a + c1 b` of the two samples at `ofs`.
#[inline(always)]
fn hline(row: &[u8], ax: &Axis, out: &mut [u32]) {
    let n = out.len();
    let (first, last) = ((row[0] as u32) << 8, (row[ax.ofs[n - 1] as usize] as u32) << 8);
    out[..ax.min].fill(first);
    out[ax.max..].fill(last);
    let mid = ax.min..ax.max;
    for ((o, &p), &c) in out[mid.clone()].iter_mut().zip(&ax.ofs[mid.clone()]).zip(&ax.c1[mid]) {
        let p = p as usize;
        *o = (256 - c) * row[p] as u32 + c * row[p + 1] as u32;
    }
}

/// [`hline`]'s interpolating range eight samples at a time: one 32-bit
/// gather of the 4 bytes at each offset gives both samples (bytes 0 and 1),
/// then `256 a + c1 (b - a)`, which is `(256 - c1) a + c1 b` in exact u32.
///
/// # Safety
/// The CPU has AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn hline_avx2(row: &[u8], ax: &Axis, out: &mut [u32]) {
    use std::arch::x86_64::*;
    let n = out.len();
    let (first, last) = ((row[0] as u32) << 8, (row[ax.ofs[n - 1] as usize] as u32) << 8);
    out[..ax.min].fill(first);
    out[ax.max..].fill(last);
    let mut d = ax.min;
    let byte = _mm256_set1_epi32(0xff);
    // a gather reads 4 bytes from each offset: stop where one would pass the row's end
    while d + 8 <= ax.max && (ax.ofs[d + 7] as usize) + 4 <= row.len() {
        // SAFETY: d + 8 <= max <= n = ofs.len() = c1.len() = out.len(); the
        // offsets rise with d, so every gathered [ofs, ofs + 4) lies in `row`
        // (checked for the last, ofs[d + 7]); row.len() < 2^31 (a plane row).
        unsafe {
            let idx = _mm256_loadu_si256(ax.ofs.as_ptr().add(d).cast());
            let c = _mm256_loadu_si256(ax.c1.as_ptr().add(d).cast());
            let v = _mm256_i32gather_epi32::<1>(row.as_ptr().cast(), idx);
            let a = _mm256_and_si256(v, byte);
            let b = _mm256_and_si256(_mm256_srli_epi32::<8>(v), byte);
            let r = _mm256_add_epi32(_mm256_slli_epi32::<8>(a), _mm256_mullo_epi32(c, _mm256_sub_epi32(b, a)));
            _mm256_storeu_si256(out.as_mut_ptr().add(d).cast(), r);
        }
        d += 8;
    }
    for d in d..ax.max {
        let (p, c) = (ax.ofs[d] as usize, ax.c1[d]);
        out[d] = (256 - c) * row[p] as u32 + c * row[p + 1] as u32;
    }
}

/// `cv::resize(src, (w, h), INTER_LINEAR_EXACT)`.
///
/// ```
/// let img = lfast::Plane::from_vec(4, 1, vec![0, 100, 200, 255]).unwrap();
/// let r = lfast::cpu::opencv::resize::resize_linear_exact(&img, 2, 1);
/// assert_eq!(r.data, [50, 228]); // (0 + 100) / 2, (200 + 255) / 2 rounded up
/// ```
pub fn resize_linear_exact(src: &Plane<u8>, w: u32, h: u32) -> Plane<u8> {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") {
        // SAFETY: AVX2 was detected just above
        return unsafe { resize_avx2(src, w, h) };
    }
    resize_rows(src, w, h, hline)
}

/// [`resize_linear_exact`] with the portable horizontal pass (the reference
/// of the AVX2 path in the tests).
pub fn resize_linear_exact_scalar(src: &Plane<u8>, w: u32, h: u32) -> Plane<u8> {
    resize_rows(src, w, h, hline)
}

/// [`resize_rows`] compiled for AVX2 (the vertical pass vectorises), with
/// [`hline_avx2`].
///
/// # Safety
/// The CPU has AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn resize_avx2(src: &Plane<u8>, w: u32, h: u32) -> Plane<u8> {
    // SAFETY: this function's own contract (AVX2)
    resize_rows(src, w, h, |row, ax, out| unsafe { hline_avx2(row, ax, out) })
}

/// The two passes: each source row a destination row needs is resized
/// horizontally once (two row buffers, the lower reused when the next
/// destination row moves down by one source row), then the pair is mixed
/// vertically in 16 fractional bits, rounded half up.
#[inline(always)]
fn resize_rows(src: &Plane<u8>, w: u32, h: u32, hl: impl Fn(&[u8], &Axis, &mut [u32])) -> Plane<u8> {
    let mut out = Plane::<u8>::new(w, h);
    if w == 0 || h == 0 || src.width == 0 || src.height == 0 {
        return out;
    }
    let ax = axis(src.width, w);
    let ay = axis(src.height, h);
    let sw = src.width as usize;
    let row = |y: usize| &src.data[y * sw..(y + 1) * sw];
    let (mut r0, mut r1) = (vec![0u32; w as usize], vec![0u32; w as usize]);
    // the source rows now in r0 and r1 (usize::MAX: none)
    let (mut y0, mut y1) = (usize::MAX, usize::MAX);
    for d in 0..h as usize {
        let dst = &mut out.data[d * w as usize..(d + 1) * w as usize];
        if d < ay.min || d >= ay.max {
            let y = if d < ay.min { 0 } else { src.height as usize - 1 };
            if y0 != y {
                hl(row(y), &ax, &mut r0);
                y0 = y;
            }
            for (o, &v) in dst.iter_mut().zip(&r0) {
                *o = ((v + 128) >> 8) as u8;
            }
            continue;
        }
        let y = ay.ofs[d] as usize;
        if y0 != y {
            if y1 == y {
                std::mem::swap(&mut r0, &mut r1);
                y0 = y;
                y1 = usize::MAX;
            } else {
                hl(row(y), &ax, &mut r0);
                y0 = y;
            }
        }
        if y1 != y + 1 {
            hl(row(y + 1), &ax, &mut r1);
            y1 = y + 1;
        }
        let c1 = ay.c1[d];
        for ((o, &a), &b) in dst.iter_mut().zip(&r0).zip(&r1) {
            *o = ((a * (256 - c1) + b * c1 + 32768) >> 16) as u8;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn by_hand() {
        // 5 -> 4: scale 1.25, f = 1.25 (d + 0.5) - 0.5 = 0.125, 1.375, 2.625, 3.875
        // weights of the next sample: 32, 96, 160, 224 (/256)
        let img = Plane::from_vec(5, 1, vec![0, 64, 128, 192, 255]).unwrap();
        let r = resize_linear_exact(&img, 4, 1);
        // 0*224 + 64*32 = 2048 -> 8; 64*160 + 128*96 = 22528 -> 88;
        // 128*96 + 192*160 = 43008 -> 168; 192*32 + 255*224 = 63264 -> 247.1 -> 247
        assert_eq!(r.data, [8, 88, 168, 247]);
    }

    #[test]
    fn simd_equals_scalar_across_sizes() {
        let mut r = crate::rng::SplitMix64::new(5);
        // widths around multiples of 8 and the gather's 4-byte reach, the
        // pyramid's ratio and others, up and down, 1-pixel planes
        for (sw, sh, dw, dh) in [
            (1241, 376, 1034, 313),
            (40, 33, 33, 28),
            (41, 9, 34, 8),
            (17, 17, 14, 14),
            (9, 3, 8, 3),
            (8, 8, 7, 7),
            (5, 4, 9, 7),
            (1, 1, 1, 1),
            (1, 6, 3, 5),
            (6, 1, 5, 1),
            (64, 48, 13, 11),
            (100, 7, 83, 6),
        ] {
            let img = Plane::from_vec(sw, sh, (0..sw * sh).map(|_| r.next_u64() as u8).collect()).unwrap();
            assert_eq!(
                resize_linear_exact(&img, dw, dh).data,
                resize_linear_exact_scalar(&img, dw, dh).data,
                "{sw}x{sh} -> {dw}x{dh}"
            );
        }
    }

    #[test]
    fn identity_and_constant() {
        let img = Plane::from_vec(7, 5, (0..35u8).map(|v| v * 7).collect()).unwrap();
        assert_eq!(resize_linear_exact(&img, 7, 5).data, img.data);
        let c = Plane::from_vec(13, 11, vec![77; 143]).unwrap();
        assert!(resize_linear_exact(&c, 10, 9).data.iter().all(|&v| v == 77));
    }
}
