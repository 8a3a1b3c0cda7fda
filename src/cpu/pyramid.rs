//! SPEC 10: the image pyramid, each level resized from the previous one with
//! integer bilinear weights in Q11 (OpenCV INTER_LINEAR's fixed point).
//! Mirrors shaders/pyramid.wgsl. Weights are computed from integers only, so
//! the GPU derives the same ones without any float.

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

/// Resizes `src` to `dw x dh` (bilinear, Q11 weights, result rounded).
pub fn resize(src: &Plane<u8>, dw: u32, dh: u32) -> Plane<u8> {
    let xt: Vec<(u32, i32)> = (0..dw).map(|x| tap(x, src.width, dw)).collect();
    let mut out = Plane::<u8>::new(dw, dh);
    out.data.par_chunks_mut(dw as usize).enumerate().for_each(|(y, row)| {
        let (sy, wy) = tap(y as u32, src.height, dh);
        let r0 = src.row(sy);
        let r1 = src.row((sy + 1).min(src.height - 1));
        for (o, &(sx, wx)) in row.iter_mut().zip(&xt) {
            let sx1 = (sx + 1).min(src.width - 1) as usize;
            let sx = sx as usize;
            let h0 = (ONE - wx) * r0[sx] as i32 + wx * r0[sx1] as i32;
            let h1 = (ONE - wx) * r1[sx] as i32 + wx * r1[sx1] as i32;
            let v = (ONE - wy) * h0 + wy * h1;
            *o = ((v + (1 << (2 * COEF_BITS - 1))) >> (2 * COEF_BITS)) as u8;
        }
    });
    out
}

/// All levels: level 0 is `base` itself, level l is resized from level l-1
/// to `sizes[l]` (from [`Config::level_sizes`](crate::Config::level_sizes)).
pub fn pyramid(base: &Plane<u8>, sizes: &[(u32, u32)]) -> Vec<Plane<u8>> {
    let mut levels: Vec<Plane<u8>> = Vec::with_capacity(sizes.len());
    for (l, &(w, h)) in sizes.iter().enumerate() {
        let next = if l == 0 { base.clone() } else { resize(&levels[l - 1], w, h) };
        levels.push(next);
    }
    levels
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

    #[test]
    fn tiny_sizes() {
        let src = Plane::from_vec(1, 1, vec![9u8]).unwrap();
        assert_eq!(resize(&src, 1, 1).data, vec![9]);
        assert_eq!(resize(&src, 3, 2).data, vec![9; 6]);
    }
}
