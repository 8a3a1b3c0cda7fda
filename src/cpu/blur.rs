//! Separable Gaussian blur with integer Q8 weights and BORDER_REFLECT_101, as
//! OpenCV's fixed-point GaussianBlur for 8-bit images. SPEC 11 uses the 7x7,
//! sigma 2 kernel before sampling descriptors. Mirrors shaders/blur.wgsl.

use super::simd::dispatch;
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

/// Separable blur: horizontal pass to Q8, vertical pass to Q16, rounded:
/// `out = (sum_y w_y * sum_x w_x * p + 2^15) >> 16`, BORDER_REFLECT_101.
/// The horizontal sums fit u16 because the weights sum to 256.
pub fn gaussian_blur(src: &Plane<u8>, kernel: &[u32]) -> Plane<u8> {
    let mut out = Plane::new(src.width, src.height);
    gaussian_blur_into(src, kernel, &mut out);
    out
}

/// [`gaussian_blur`] into a reused plane. The horizontal pass runs in bands
/// of rows, so no plane of it is kept.
pub fn gaussian_blur_into(src: &Plane<u8>, kernel: &[u32], out: &mut Plane<u8>) {
    out.reshape(src.width, src.height);
    if src.is_empty() {
        return;
    }
    match kernel.len() {
        7 if is_symmetric(kernel) => blur_n::<7>(src, kernel.try_into().expect("length checked"), vrow7_sym, out),
        7 => blur_n::<7>(src, kernel.try_into().expect("length checked"), vrow7, out),
        5 => blur_n::<5>(src, kernel.try_into().expect("length checked"), vrow5, out),
        3 => blur_n::<3>(src, kernel.try_into().expect("length checked"), vrow3, out),
        _ => *out = blur_any(src, kernel),
    }
}

/// `k[i] == k[len - 1 - i]` for every tap, as every Gaussian kernel is.
fn is_symmetric(k: &[u32]) -> bool {
    k.iter().eq(k.iter().rev())
}

dispatch! {
    /// Horizontal taps over the interior of a row: `out[x] = sum_k k[k] * s[x + k]`.
    fn hrow7(s: &[u8], k: &[u16; 7], out: &mut [u16]) {
        for (x, o) in out.iter_mut().enumerate() {
            let mut acc = 0u16;
            for (i, &kw) in k.iter().enumerate() {
                acc += kw * s[x + i] as u16;
            }
            *o = acc;
        }
    }
}

dispatch! {
    /// [`hrow7`] for a symmetric kernel: the two pixels of a weight are added
    /// first, four multiplies instead of seven, the same sums (every partial
    /// sum is at most the total, `255 * 256`, so u16 holds it).
    fn hrow7_sym(s: &[u8], k: &[u16; 7], out: &mut [u16]) {
        let n = out.len();
        let s = &s[..n + 6];
        for x in 0..n {
            let pair = |i: usize| s[x + i] as u16 + s[x + 6 - i] as u16;
            out[x] = k[0] * pair(0) + k[1] * pair(1) + k[2] * pair(2) + k[3] * s[x + 3] as u16;
        }
    }
}

/// One output row of the vertical pass from the `N` rows of horizontal sums
/// it weighs: `out[x] = (sum_i k[i] * t[i][x] + 2^15) >> 16`, the sum kept in
/// registers (no accumulator row to load and store per tap).
#[inline(always)]
fn vrow<const N: usize>(t: [&[u16]; N], k: &[u32; N], out: &mut [u8]) {
    let n = out.len();
    let t = t.map(|r| &r[..n]);
    for x in 0..n {
        let mut a = 0u32;
        for i in 0..N {
            a += k[i] * t[i][x] as u32;
        }
        out[x] = ((a + (1 << 15)) >> 16) as u8;
    }
}

dispatch! {
    /// [`vrow`] for 7 taps.
    fn vrow7(t: [&[u16]; 7], k: &[u32; 7], out: &mut [u8]) {
        vrow(t, k, out)
    }
}

dispatch! {
    /// [`vrow`] for a symmetric 7-tap kernel: rows of equal weight are added
    /// first, four multiplies instead of seven, the same sums.
    fn vrow7_sym(t: [&[u16]; 7], k: &[u32; 7], out: &mut [u8]) {
        let n = out.len();
        let [t0, t1, t2, t3, t4, t5, t6] = t;
        let (t0, t1, t2, t3, t4, t5, t6) = (&t0[..n], &t1[..n], &t2[..n], &t3[..n], &t4[..n], &t5[..n], &t6[..n]);
        for x in 0..n {
            let a = k[0] * (t0[x] as u32 + t6[x] as u32)
                + k[1] * (t1[x] as u32 + t5[x] as u32)
                + k[2] * (t2[x] as u32 + t4[x] as u32)
                + k[3] * t3[x] as u32;
            out[x] = ((a + (1 << 15)) >> 16) as u8;
        }
    }
}

dispatch! {
    /// [`vrow`] for 5 taps.
    fn vrow5(t: [&[u16]; 5], k: &[u32; 5], out: &mut [u8]) {
        vrow(t, k, out)
    }
}

dispatch! {
    /// [`vrow`] for 3 taps.
    fn vrow3(t: [&[u16]; 3], k: &[u32; 3], out: &mut [u8]) {
        vrow(t, k, out)
    }
}

/// Output rows per task of [`blur_n`]: each band computes the horizontal sums
/// of its rows and the `N - 1` around them, so no plane of sums is kept
/// (2 bytes per pixel; docs/pipeline.md, "Memory") for 6 rows in 64 done twice.
const BAND_ROWS: usize = 64;

/// `vrow`: the dispatched [`vrow`] for `N` taps.
fn blur_n<const N: usize>(
    src: &Plane<u8>,
    kernel: &[u32; N],
    vrow: fn([&[u16]; N], &[u32; N], &mut [u8]),
    out: &mut Plane<u8>,
) {
    let (w, h) = (src.width as usize, src.height as usize);
    let r = N / 2;
    let k16: [u16; N] = kernel.map(|v| v as u16);
    let hsum = |y: usize, row: &mut [u16]| {
        let s = src.row(y as u32);
        let tap = |x: usize| {
            kernel
                .iter()
                .enumerate()
                .map(|(i, &k)| k as u16 * s[reflect101(x as i32 + i as i32 - r as i32, w as i32)] as u16)
                .sum::<u16>()
        };
        if w > 2 * r && N == 7 {
            let k7: &[u16; 7] = k16.as_slice().try_into().expect("N == 7");
            if is_symmetric(kernel) {
                hrow7_sym(s, k7, &mut row[r..w - r]);
            } else {
                hrow7(s, k7, &mut row[r..w - r]);
            }
            for x in (0..r).chain(w - r..w) {
                row[x] = tap(x);
            }
        } else {
            for (x, o) in row.iter_mut().enumerate() {
                *o = tap(x);
            }
        }
    };
    // the vertical taps of output row y read the horizontal sums of these rows
    let tap_row = |y: usize, i: usize| reflect101(y as i32 + i as i32 - r as i32, h as i32);
    // each thread's rows of horizontal sums, kept from band to band and from
    // frame to frame (taken, so that a nested call finds none): grown, never
    // cleared, as every row a band reads is written first
    thread_local!(static TMP: std::cell::Cell<Vec<u16>> = const { std::cell::Cell::new(Vec::new()) });
    out.data.par_chunks_mut(BAND_ROWS * w).enumerate().for_each(|(b, band)| {
        let (y0, y1) = (b * BAND_ROWS, b * BAND_ROWS + band.len() / w);
        // the rows the band reads: y0 - r ..= y1 - 1 + r, reflected; a range
        let rows = (y0..y1).flat_map(|y| (0..N).map(move |i| tap_row(y, i)));
        let (lo, hi) = rows.fold((usize::MAX, 0), |(lo, hi), yy| (lo.min(yy), hi.max(yy)));
        let mut kept = TMP.take();
        let n = (hi - lo + 1) * w;
        if kept.len() < n {
            kept.resize(n, 0);
        }
        let tmp = &mut kept[..n];
        for (k, row) in tmp.chunks_mut(w).enumerate() {
            hsum(lo + k, row);
        }
        let tmp = &*tmp;
        for (k, row) in band.chunks_mut(w).enumerate() {
            let t: [&[u16]; N] = std::array::from_fn(|i| {
                let yy = tap_row(y0 + k, i) - lo;
                &tmp[yy * w..(yy + 1) * w]
            });
            vrow(t, kernel, row);
        }
        TMP.set(kept);
    });
}

/// Any kernel length, straightforward loops (the reference for the fast paths).
fn blur_any(src: &Plane<u8>, kernel: &[u32]) -> Plane<u8> {
    let (w, h) = (src.width as usize, src.height as usize);
    let r = (kernel.len() / 2) as i32;
    let mut tmp = vec![0u32; w * h];
    for y in 0..h {
        let s = src.row(y as u32);
        for x in 0..w {
            tmp[y * w + x] = kernel
                .iter()
                .enumerate()
                .map(|(k, &wk)| wk * s[reflect101(x as i32 + k as i32 - r, w as i32)] as u32)
                .sum();
        }
    }
    let mut out = Plane::<u8>::new(src.width, src.height);
    for y in 0..h {
        for x in 0..w {
            let acc: u32 = kernel
                .iter()
                .enumerate()
                .map(|(k, &wk)| wk * tmp[reflect101(y as i32 + k as i32 - r, h as i32) * w + x])
                .sum();
            out.data[y * w + x] = ((acc + (1 << 15)) >> 16) as u8;
        }
    }
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

    proptest::proptest! {
        #[test]
        // heights up to 3 bands of rows and a few past (BAND_ROWS = 64)
        fn fast_paths_match_reference(w in 1u32..80, h in proptest::prop_oneof![1u32..20, 60u32..200], seed in proptest::prelude::any::<u64>(), ks in 0usize..4) {
            let mut s = seed;
            let data: Vec<u8> = (0..w * h).map(|_| { s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407); (s >> 56) as u8 }).collect();
            let img = Plane::from_vec(w, h, data).unwrap();
            // the last kernel is not symmetric: the general 7-tap path
            let k = [gaussian_kernel_q8(3, 0.7), gaussian_kernel_q8(5, 0.8), ORB_KERNEL.to_vec(), vec![10, 30, 50, 60, 50, 40, 16]][ks].clone();
            proptest::prop_assert_eq!(gaussian_blur(&img, &k), blur_any(&img, &k));
        }
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
