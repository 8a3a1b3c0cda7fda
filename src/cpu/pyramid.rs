//! SPEC 10: the image pyramid, each level resized from the previous one with
//! integer bilinear weights in Q11 (OpenCV INTER_LINEAR's fixed point).
//! Mirrors shaders/pyramid.wgsl. Weights are computed from integers only, so
//! the GPU derives the same ones without any float.

use super::simd::dispatch;
use crate::image::Plane;
use rayon::prelude::*;

/// Fixed-point bits of the interpolation weights.
pub const COEF_BITS: u32 = 11;
const ONE: i32 = 1 << COEF_BITS;

/// Source index and Q11 weight of the right/lower neighbour for destination
/// index `d` when resizing `src_len -> dst_len`: the source coordinate is
/// `(d + 0.5) * src/dst - 0.5 = ((2d+1)*src - dst) / (2*dst)`, clamped to
/// the image as OpenCV does (weight 0 at both ends).
///
/// ```
/// use lfast::cpu::pyramid::tap;
/// assert_eq!(tap(0, 4, 2), (0, 1024)); // halving: sample between 0 and 1
/// assert_eq!(tap(0, 2, 4), (0, 0));    // doubling: -0.25 clamps to 0
/// ```
#[inline]
pub fn tap(d: u32, src_len: u32, dst_len: u32) -> (u32, i32) {
    let num = (2 * d as i64 + 1) * src_len as i64 - dst_len as i64;
    let den = 2 * dst_len as i64;
    if num < 0 {
        return (0, 0);
    }
    let s = num / den;
    if s >= src_len as i64 - 1 {
        return (src_len - 1, 0);
    }
    let rem = num - s * den;
    // round(rem / den * 2048), half up
    let w = ((rem * ONE as i64 * 2 + den) / (2 * den)) as i32;
    (s as u32, w)
}

/// Resizes `src` to `dw x dh` (bilinear, Q11 weights, result rounded):
/// `out = (wy0 * (wx0*p00 + wx1*p01) + wy1 * (wx0*p10 + wx1*p11) + 2^21) >> 22`.
pub fn resize(src: &Plane<u8>, dw: u32, dh: u32) -> Plane<u8> {
    let mut out = Plane::new(dw, dh);
    resize_into(src, dw, dh, &mut out);
    out
}

/// [`resize`] into a reused buffer.
pub fn resize_into(src: &Plane<u8>, dw: u32, dh: u32, out: &mut Plane<u8>) {
    out.reshape(dw, dh);
    if src.is_empty() || dw == 0 || dh == 0 {
        out.data.fill(0); // nothing to sample
        return;
    }
    let (sx, wx): (Vec<u32>, Vec<i32>) = (0..dw).map(|x| tap(x, src.width, dw)).unzip();
    let sx1: Vec<u32> = sx.iter().map(|&s| (s + 1).min(src.width - 1)).collect();
    // Source columns are non-decreasing in x (tap is monotone and clamped), so
    // the last entries bound every read of the gather loop below.
    assert!(sx.iter().zip(&sx1).all(|(a, b)| a <= b) && sx1.last().is_none_or(|&v| v < src.width));
    let w = dw as usize;
    let groups = HGroups::new(&sx, &sx1, &wx, src.width);
    // horizontal taps of source row `sy` at every destination column
    let hrow = |sy: u32, out: &mut [i32]| {
        let r = src.row(sy);
        let done = groups.run(r, out);
        for x in done.iter().copied().flat_map(|g| 8 * g..8 * g + 8).chain(8 * groups.n_groups()..w) {
            let (s0, s1, k) = (sx[x], sx1[x], wx[x]);
            // SAFETY: s0 <= s1 <= sx1.last() < src.width == r.len(), asserted in `resize_into`.
            let (a, b) = unsafe { (*r.get_unchecked(s0 as usize), *r.get_unchecked(s1 as usize)) };
            out[x] = (ONE - k) * a as i32 + k * b as i32;
        }
    };
    const BAND: usize = 16;
    out.data.par_chunks_mut(w * BAND).enumerate().for_each(|(band, rows)| {
        // the two source rows last interpolated, reused by the next destination row
        let (mut h0, mut h1) = (vec![0i32; w], vec![0i32; w]);
        let mut have: (u32, u32) = (u32::MAX, u32::MAX);
        for (k, row) in rows.chunks_mut(w).enumerate() {
            let (sy, wy) = tap((band * BAND + k) as u32, src.height, dh);
            let sy1 = (sy + 1).min(src.height - 1);
            if have.0 != sy {
                if have.1 == sy {
                    std::mem::swap(&mut h0, &mut h1);
                    have.1 = u32::MAX;
                } else {
                    hrow(sy, &mut h0);
                }
                have.0 = sy;
            }
            if have.1 != sy1 {
                hrow(sy1, &mut h1);
                have.1 = sy1;
            }
            vblend(&h0, &h1, wy, row);
        }
    });
}

/// The horizontal taps in groups of 8 destination columns whose 8 source
/// pairs `(s0, s0 + 1)` lie in one 16-byte window of the source row: such a
/// group is one byte shuffle, one widening and one multiply-add of pairs
/// (`(ONE - k) * a + k * b`, the same integers as the scalar loop) with AVX2.
/// Groups that do not fit (an upscale, the clamped right end) stay scalar.
struct HGroups {
    /// Per group of 8 columns: the window start, or `u32::MAX` if scalar.
    base: Vec<u32>,
    /// Per group: byte indices into the window, `s0 - base, s0 + 1 - base` per column.
    shuffle: Vec<[u8; 16]>,
    /// Per group: the weights `ONE - k, k` per column, as i16 pairs.
    weights: Vec<[i16; 16]>,
    /// The groups with `base == u32::MAX`, left to the scalar loop.
    scalar: Vec<usize>,
    avx2: bool,
}

impl HGroups {
    fn new(sx: &[u32], sx1: &[u32], wx: &[i32], src_w: u32) -> Self {
        #[cfg(target_arch = "x86_64")]
        let avx2 = std::is_x86_feature_detected!("avx2");
        #[cfg(not(target_arch = "x86_64"))]
        let avx2 = false;
        let n = if avx2 { sx.len() / 8 } else { 0 };
        let (mut base, mut shuffle, mut weights) =
            (Vec::with_capacity(n), Vec::with_capacity(n), Vec::with_capacity(n));
        for g in 0..n {
            let cols = 8 * g..8 * g + 8;
            let b = sx[8 * g];
            let fits = cols.clone().all(|x| sx1[x] == sx[x] + 1 && sx1[x] - b < 16) && b + 16 <= src_w;
            base.push(if fits { b } else { u32::MAX });
            let mut sh = [0u8; 16];
            let mut wt = [0i16; 16];
            for (i, x) in cols.enumerate() {
                if fits {
                    sh[2 * i] = (sx[x] - b) as u8;
                    sh[2 * i + 1] = (sx1[x] - b) as u8;
                }
                wt[2 * i] = (ONE - wx[x]) as i16;
                wt[2 * i + 1] = wx[x] as i16;
            }
            shuffle.push(sh);
            weights.push(wt);
        }
        let scalar = (0..n).filter(|&g| base[g] == u32::MAX).collect();
        Self { base, shuffle, weights, scalar, avx2 }
    }

    /// Number of 8-column groups (the columns past `8 * n_groups()` are scalar).
    fn n_groups(&self) -> usize {
        self.base.len()
    }

    /// Runs the vector groups of row `r` into `out`; returns the groups left to the caller.
    fn run(&self, r: &[u8], out: &mut [i32]) -> &[usize] {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: AVX2 was detected in `new`; see `run_avx2` for the bounds.
            unsafe { self.run_avx2(r, out) };
        }
        &self.scalar
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn run_avx2(&self, r: &[u8], out: &mut [i32]) {
        use std::arch::x86_64::*;
        assert!(out.len() >= 8 * self.base.len());
        for (g, &b) in self.base.iter().enumerate() {
            if b == u32::MAX {
                continue;
            }
            let b = b as usize;
            assert!(b + 16 <= r.len());
            // SAFETY: the window r[b..b + 16] is in bounds (asserted), as is out[8g..8g + 8];
            // unaligned loads and stores are used throughout.
            unsafe {
                let win = _mm_loadu_si128(r.as_ptr().add(b) as *const __m128i);
                let ctl = _mm_loadu_si128(self.shuffle[g].as_ptr() as *const __m128i);
                let pairs = _mm256_cvtepu8_epi16(_mm_shuffle_epi8(win, ctl));
                let wts = _mm256_loadu_si256(self.weights[g].as_ptr() as *const __m256i);
                let v = _mm256_madd_epi16(pairs, wts);
                _mm256_storeu_si256(out.as_mut_ptr().add(8 * g) as *mut __m256i, v);
            }
        }
    }
}

dispatch! {
    /// Vertical blend of two horizontally interpolated rows, rounded to bytes.
    fn vblend(h0: &[i32], h1: &[i32], wy: i32, out: &mut [u8]) {
        let (h0, h1) = (&h0[..out.len()], &h1[..out.len()]);
        for x in 0..out.len() {
            let v = (ONE - wy) * h0[x] + wy * h1[x];
            out[x] = ((v + (1 << (2 * COEF_BITS - 1))) >> (2 * COEF_BITS)) as u8;
        }
    }
}

/// The plain per-pixel form of [`resize`], the reference it is tested against.
pub fn resize_naive(src: &Plane<u8>, dw: u32, dh: u32) -> Plane<u8> {
    let mut out = Plane::<u8>::new(dw, dh);
    for y in 0..dh {
        let (sy, wy) = tap(y, src.height, dh);
        for x in 0..dw {
            let (sx, wx) = tap(x, src.width, dw);
            let p = |xx: u32, yy: u32| src.at(xx.min(src.width - 1), yy.min(src.height - 1)) as i32;
            let h0 = (ONE - wx) * p(sx, sy) + wx * p(sx + 1, sy);
            let h1 = (ONE - wx) * p(sx, sy + 1) + wx * p(sx + 1, sy + 1);
            let v = (ONE - wy) * h0 + wy * h1;
            out.data[(y * dw + x) as usize] = ((v + (1 << (2 * COEF_BITS - 1))) >> (2 * COEF_BITS)) as u8;
        }
    }
    out
}

/// All levels: level 0 is `base` itself, level l is resized from level l-1
/// to `sizes[l]` (from [`Config::level_sizes`](crate::Config::level_sizes)).
pub fn pyramid(base: &Plane<u8>, sizes: &[(u32, u32)]) -> Vec<Plane<u8>> {
    let mut levels = Vec::new();
    pyramid_into(base, sizes, &mut levels);
    levels
}

/// [`pyramid`] into reused level buffers.
pub fn pyramid_into(base: &Plane<u8>, sizes: &[(u32, u32)], levels: &mut Vec<Plane<u8>>) {
    levels.resize_with(sizes.len().max(1), Default::default);
    levels[0].reshape(base.width, base.height);
    levels[0].data.copy_from_slice(&base.data);
    build_levels(sizes, levels);
}

/// Levels 1.. of a pyramid whose level 0 is already in `levels[0]`.
pub fn build_levels(sizes: &[(u32, u32)], levels: &mut Vec<Plane<u8>>) {
    levels.resize_with(sizes.len().max(1), Default::default);
    levels.truncate(sizes.len().max(1));
    let (head, rest) = levels.split_at_mut(1);
    build_levels_from(&head[0], sizes, rest);
}

/// Levels 1.. of a pyramid over `base` into `rest` (`rest[i]` is level i+1),
/// each resized from the one before (SPEC 10).
pub fn build_levels_from(base: &Plane<u8>, sizes: &[(u32, u32)], rest: &mut [Plane<u8>]) {
    for (i, &(w, h)) in sizes.iter().enumerate().skip(1).take(rest.len()) {
        let (done, todo) = rest.split_at_mut(i - 1);
        let prev = if i == 1 { base } else { &done[i - 2] };
        resize_into(prev, w, h, &mut todo[0]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Config;

    #[test]
    fn kitti_level_sizes() {
        let sizes = Config::default().level_sizes(1241, 376);
        assert_eq!(
            sizes,
            vec![(1241, 376), (1034, 313), (862, 261), (718, 218), (598, 181), (499, 151), (416, 126), (346, 105)]
        );
    }

    #[test]
    fn constant_image_stays_constant() {
        let src = Plane::from_vec(13, 7, vec![201u8; 91]).unwrap();
        let dst = resize(&src, 11, 6);
        assert!(dst.data.iter().all(|&v| v == 201));
    }

    #[test]
    fn halving_averages_pairs() {
        // 4x1 -> 2x1: samples at source x = 0.5 and 2.5
        let src = Plane::from_vec(4, 1, vec![0u8, 100, 200, 255]).unwrap();
        assert_eq!(resize(&src, 2, 1).data, vec![50, 228]); // (200+255)/2 = 227.5 -> 228
    }

    #[test]
    fn weights_by_hand() {
        // 1241 -> 1034: destination 1 samples source (3*1241 - 1034)/2068 = 1.3002..
        let (s, w) = tap(1, 1241, 1034);
        assert_eq!(s, 1);
        assert_eq!(w, ((2689.0 / 2068.0 - 1.0) * 2048.0f64).round() as i32);
        // the last destination pixel samples 0.9 of the way to the last source pixel
        assert_eq!(tap(1033, 1241, 1034), (1239, 1843));
        // upscaling past the last source pixel clamps with weight 0
        assert_eq!(tap(3, 2, 4), (1, 0));
    }

    proptest::proptest! {
        #[test]
        fn matches_naive(sw in 1u32..60, sh in 1u32..60, dw in 1u32..60, dh in 1u32..60, seed in proptest::prelude::any::<u64>()) {
            let mut s = seed;
            let data: Vec<u8> = (0..sw * sh).map(|_| { s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407); (s >> 56) as u8 }).collect();
            let src = Plane::from_vec(sw, sh, data).unwrap();
            proptest::prop_assert_eq!(resize(&src, dw, dh), resize_naive(&src, dw, dh));
        }
    }

    proptest::proptest! {
        #[test]
        fn matches_naive_at_pyramid_ratios(sw in 16u32..400, sh in 1u32..6, pct in 40u32..130, seed in proptest::prelude::any::<u64>()) {
            // downscales (the vector groups) and mild upscales (scalar groups), widths across 8-column groups
            let mut s = seed;
            let data: Vec<u8> = (0..sw * sh).map(|_| { s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407); (s >> 56) as u8 }).collect();
            let src = Plane::from_vec(sw, sh, data).unwrap();
            let (dw, dh) = ((sw * pct / 100).max(1), (sh * pct / 100).max(1));
            proptest::prop_assert_eq!(resize(&src, dw, dh), resize_naive(&src, dw, dh));
        }
    }

    #[test]
    fn tiny_sizes() {
        let src = Plane::from_vec(1, 1, vec![9u8]).unwrap();
        assert_eq!(resize(&src, 1, 1).data, vec![9]);
        assert_eq!(resize(&src, 3, 2).data, vec![9; 6]);
    }
}
