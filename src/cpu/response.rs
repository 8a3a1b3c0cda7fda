//! SPEC 9: Harris corner response on D, as OpenCV ORB's HARRIS_SCORE (7x7 block,
//! 3x3 Sobel, k = 0.04). Mirrors shaders/response.wgsl: the sums are exact
//! integers, only the final formula is f32, evaluated in the same order.

use super::simd::dispatch;
use crate::image::Plane;

/// Harris block size.
pub const BLOCK: i32 = 7;
/// Harris k.
pub const HARRIS_K: f32 = 0.04;

/// The integer structure-tensor sums `(a, b, c) = (ΣIx², ΣIy², ΣIxIy)` over the
/// 7x7 block centred on (x, y), reads clamped (which changes nothing for p >= 4 from the sides).
#[inline]
pub fn structure_sums(img: &Plane<u8>, x: u32, y: u32) -> (i32, i32, i32) {
    let r = BLOCK / 2;
    let (x, y) = (x as i32, y as i32);
    let (w, h) = (img.width as i32, img.height as i32);
    if x > r && y > r && x + r + 2 < w && y + r + 1 < h {
        return structure_sums_inside(&img.data, w as usize, x as usize, y as usize);
    }
    structure_sums_clamped(img, x, y)
}

/// [`structure_sums`] with every read clamped: the border path, and the
/// reference the interior path is tested against.
fn structure_sums_clamped(img: &Plane<u8>, x: i32, y: i32) -> (i32, i32, i32) {
    let r = BLOCK / 2;
    let p = |dx: i32, dy: i32| img.clamped(dx, dy) as i32;
    let (mut a, mut b, mut c) = (0i32, 0i32, 0i32);
    for by in y - r..=y + r {
        for bx in x - r..=x + r {
            let ix = (p(bx + 1, by) - p(bx - 1, by)) * 2
                + (p(bx + 1, by - 1) - p(bx - 1, by - 1))
                + (p(bx + 1, by + 1) - p(bx - 1, by + 1));
            let iy = (p(bx, by + 1) - p(bx, by - 1)) * 2
                + (p(bx - 1, by + 1) - p(bx - 1, by - 1))
                + (p(bx + 1, by + 1) - p(bx + 1, by - 1));
            a += ix * ix;
            b += iy * iy;
            c += ix * iy;
        }
    }
    (a, b, c)
}

/// [`structure_sums`] when the 9x9 footprint and the column right of it lie inside the image.
#[inline]
fn structure_sums_inside(d: &[u8], w: usize, x: usize, y: usize) -> (i32, i32, i32) {
    let rows: [&[u8; 10]; 9] =
        std::array::from_fn(|r| d[(y + r - 4) * w + x - 4..][..10].try_into().expect("10 bytes"));
    sums_9x9(&rows)
}

dispatch! {
    /// The structure-tensor sums from the 9 rows of the footprint (columns
    /// x-4..=x+4, and x+5 so that each row is three 8-byte loads), 8 lanes wide
    /// (lane 7 is padding, left out of the sums): per footprint row, the
    /// horizontal difference `h = p[i+1] - p[i-1]` and smoothing
    /// `s = p[i-1] + 2 p[i] + p[i+1]`; then per block row
    /// `Ix = h_up + 2 h + h_down` and `Iy = s_down - s_up`, the 3x3 Sobel.
    fn sums_9x9(rows: &[&[u8; 10]; 9]) -> (i32, i32, i32) {
        let mut h = [[0i32; 8]; 9];
        let mut s = [[0i32; 8]; 9];
        for (r, row) in rows.iter().enumerate() {
            for i in 0..8 {
                let (l, m, rt) = (row[i] as i32, row[i + 1] as i32, row[i + 2] as i32);
                h[r][i] = rt - l;
                s[r][i] = l + 2 * m + rt;
            }
        }
        let (mut a, mut b, mut c) = ([0i32; 8], [0i32; 8], [0i32; 8]);
        // lanes outside, block rows inside: LLVM vectorises across the lanes
        for i in 0..8 {
            for by in 1..8 {
                let ix = h[by - 1][i] + 2 * h[by][i] + h[by + 1][i];
                let iy = s[by + 1][i] - s[by - 1][i];
                a[i] += ix * ix;
                b[i] += iy * iy;
                c[i] += ix * iy;
            }
        }
        (a[..7].iter().sum(), b[..7].iter().sum(), c[..7].iter().sum())
    }
}

/// [`harris`] at the 3x3 square centred on (x, y): `out[j][i]` at
/// (x - 1 + i, y - 1 + j). `None` unless the square's footprint, x-5..=x+5 by
/// y-5..=y+5, lies inside the image. The nine 7x7 blocks overlap: their
/// gradients are computed once and summed by columns (`rect_3x3`).
///
/// ```
/// use lfast::{Plane, cpu::response::{harris, harris_3x3}};
/// let img = Plane::from_vec(12, 11, (0..132u32).map(|i| (i * i % 251) as u8).collect()).unwrap();
/// let sq = harris_3x3(&img, 5, 5).unwrap();
/// assert_eq!(sq[0][2], harris(&img, 6, 4));
/// assert!(harris_3x3(&img, 7, 5).is_none()); // x + 5 = 12 is outside
/// ```
pub fn harris_3x3(img: &Plane<u8>, x: u32, y: u32) -> Option<[[f32; 3]; 3]> {
    harris_rect::<11, 3, 3>(img, x.checked_sub(1)?, y.checked_sub(1)?, rect_3x3)
}

/// [`harris`] at the 7x7 square centred on (x, y), as [`harris_3x3`]:
/// `out[j][i]` at (x - 3 + i, y - 3 + j); `None` unless the footprint
/// x-7..=x+7 by y-7..=y+7 lies inside the image. The snap of radius 2 reads
/// its 5x5 square and the ring around it (the sub-pixel fit's neighbours).
///
/// ```
/// use lfast::{Plane, cpu::response::{harris, harris_7x7}};
/// let img = Plane::from_vec(18, 17, (0..306u32).map(|i| (i * i % 251) as u8).collect()).unwrap();
/// let sq = harris_7x7(&img, 8, 8).unwrap();
/// assert_eq!(sq[0][6], harris(&img, 11, 5));
/// assert!(harris_7x7(&img, 11, 8).is_none()); // x + 7 = 18 is outside
/// ```
pub fn harris_7x7(img: &Plane<u8>, x: u32, y: u32) -> Option<[[f32; 7]; 7]> {
    harris_rect::<15, 7, 7>(img, x.checked_sub(3)?, y.checked_sub(3)?, rect_7x7)
}

/// A kernel of [`harris_rect`]: the footprint rows in, the responses of the
/// rectangle out ([`rect_responses`] of [`sums_rect`]).
type RectKernel<const F: usize, const SY: usize, const SX: usize> = fn(&[[u8; 18]; F]) -> [[f32; SX]; SY];

/// [`harris`] at the `SY x SX` pixels whose top-left is (x0, y0), `out[j][i]`
/// at (x0 + i, y0 + j), through `kernel` from the footprint x0-4..x0+SX+4 by
/// y0-4..y0+SY+4 (`F = SY + 8` rows of `SX + 8` pixels); `None` where the
/// footprint leaves the image.
#[inline(always)]
fn harris_rect<const F: usize, const SY: usize, const SX: usize>(
    img: &Plane<u8>,
    x0: u32,
    y0: u32,
    kernel: RectKernel<F, SY, SX>,
) -> Option<[[f32; SX]; SY]> {
    let (w, h) = (img.width as usize, img.height as usize);
    let (x0, y0) = (x0 as usize, y0 as usize);
    if x0 < 4 || y0 < 4 || x0 + SX + 4 > w || y0 + SY + 4 > h {
        return None;
    }
    let mut rows = [[0u8; 18]; F];
    for (k, row) in rows.iter_mut().enumerate() {
        row[..SX + 8].copy_from_slice(&img.data[(y0 - 4 + k) * w + x0 - 4..][..SX + 8]);
    }
    Some(kernel(&rows))
}

/// [`harris_from_sums`] of each block of [`sums_rect`]'s `[a, b, c]`, over
/// the flattened rectangle so that the AVX2 build computes 8 at a time (the
/// same f32 operations in the same order: bit-identical).
#[inline(always)]
fn rect_responses<const SY: usize, const SX: usize>(sums: &[[[i32; SX]; SY]; 3]) -> [[f32; SX]; SY] {
    let mut out = [[0f32; SX]; SY];
    let [a, b, c] = sums.each_ref().map(|p| p.as_flattened());
    for (k, o) in out.as_flattened_mut().iter_mut().enumerate() {
        *o = harris_from_sums(a[k], b[k], c[k]);
    }
    out
}

/// The structure-tensor sums `[a, b, c]` of the 7x7 blocks centred on the
/// pixels of an `SY x SX` rectangle (`SX` at most 10), `[j][i]` at (i, j) of
/// it, from the `F = SY + 8` rows of its footprint (`SX + 8` pixels each,
/// zero-padded to 18). As [`sums_9x9`]: per footprint row `h` and `s`, then
/// Ix, Iy and their products at the `G = F - 2` gradient rows (16 lanes);
/// then 7-row column sums for each row of the rectangle, and 7-column sums of
/// those.
#[inline(always)]
fn sums_rect<const F: usize, const G: usize, const SY: usize, const SX: usize>(
    rows: &[[u8; 18]; F],
) -> [[[i32; SX]; SY]; 3] {
    // |h| <= 255, s <= 1020, and so |Ix|, |Iy| <= 1020: i16 lanes hold them
    // (16 to a vector); the products need i32.
    let mut h = [[0i16; 16]; F];
    let mut s = [[0i16; 16]; F];
    for (r, row) in rows.iter().enumerate() {
        for i in 0..16 {
            let (l, m, rt) = (row[i] as i16, row[i + 1] as i16, row[i + 2] as i16);
            h[r][i] = rt - l;
            s[r][i] = l + 2 * m + rt;
        }
    }
    // Ix, Iy at gradient row g (footprint rows g..=g+2), column i. The
    // products are formed where the column sums take them (twice a row:
    // entering and leaving), not stored: a stored array of them cost a
    // memset per call (~2.5 KB for the 7x7 square, per keypoint).
    let grad = |g: usize, i: usize| ((h[g][i] + 2 * h[g + 1][i] + h[g + 2][i]) as i32, (s[g + 2][i] - s[g][i]) as i32);
    debug_assert_eq!(G, SY + 6);
    let mut out = [[[0i32; SX]; SY]; 3];
    // the 7-row column sums of block row 0, then slid down a row at a time
    let mut col = [[0i32; 16]; 3];
    for g in 0..7 {
        for i in 0..16 {
            let (x, y) = grad(g, i);
            col[0][i] += x * x;
            col[1][i] += y * y;
            col[2][i] += x * y;
        }
    }
    for j in 0..SY {
        if j > 0 {
            for i in 0..16 {
                let ((xa, ya), (xr, yr)) = (grad(j + 6, i), grad(j - 1, i));
                col[0][i] += xa * xa - xr * xr;
                col[1][i] += ya * ya - yr * yr;
                col[2][i] += xa * ya - xr * yr;
            }
        }
        for (o, col) in out.iter_mut().zip(&col) {
            for (i, o) in o[j].iter_mut().enumerate() {
                *o = col[i..i + 7].iter().sum();
            }
        }
    }
    out
}

dispatch! {
    /// The responses of the 3x3 square (11-row footprint): [`rect_responses`] of [`sums_rect`].
    fn rect_3x3(rows: &[[u8; 18]; 11]) -> [[f32; 3]; 3] {
        rect_responses(&sums_rect::<11, 9, 3, 3>(rows))
    }
}

dispatch! {
    /// The responses of a 1x8 strip (9-row footprint): [`rect_responses`] of [`sums_rect`].
    fn rect_strip(rows: &[[u8; 18]; 9]) -> [[f32; 8]; 1] {
        rect_responses(&sums_rect::<9, 7, 1, 8>(rows))
    }
}

/// Pixels of a [`harris_strip`].
pub const STRIP: u32 = 8;

/// [`harris`] at (x + i, y) for i in 0..8, from one 9x16 footprint (x-4..=x+11
/// by y-4..=y+4); `None` unless it lies inside the image.
///
/// ```
/// use lfast::{Plane, cpu::response::{harris, harris_strip}};
/// let img = Plane::from_vec(20, 11, (0..220u32).map(|i| (i * i % 251) as u8).collect()).unwrap();
/// let strip = harris_strip(&img, 5, 5).unwrap();
/// assert_eq!(strip[3], harris(&img, 8, 5));
/// assert!(harris_strip(&img, 9, 5).is_none()); // x + 11 = 20 is outside
/// ```
pub fn harris_strip(img: &Plane<u8>, x: u32, y: u32) -> Option<[f32; 8]> {
    harris_rect::<9, 1, 8>(img, x, y, rect_strip).map(|[row]| row)
}

dispatch! {
    /// The responses of the 7x7 square (15-row footprint): [`rect_responses`] of [`sums_rect`].
    fn rect_7x7(rows: &[[u8; 18]; 15]) -> [[f32; 7]; 7] {
        rect_responses(&sums_rect::<15, 13, 7, 7>(rows))
    }
}

/// OpenCV's Harris response from the integer sums, with its scaling.
#[inline]
pub fn harris_from_sums(a: i32, b: i32, c: i32) -> f32 {
    let scale = 1.0f32 / ((1 << 2) as f32 * BLOCK as f32 * 255.0);
    let scale_sq_sq = scale * scale * scale * scale;
    let (a, b, c) = (a as f32, b as f32, c as f32);
    (a * b - c * c - HARRIS_K * (a + b) * (a + b)) * scale_sq_sq
}

/// Harris response at (x, y).
///
/// ```
/// let flat = lfast::Plane::from_vec(9, 9, vec![100u8; 81]).unwrap();
/// assert_eq!(lfast::cpu::response::harris(&flat, 4, 4), 0.0);
/// ```
pub fn harris(img: &Plane<u8>, x: u32, y: u32) -> f32 {
    let (a, b, c) = structure_sums(img, x, y);
    harris_from_sums(a, b, c)
}

/// Responses of all candidates.
///
/// Candidates in raster order (as L-FAST gives them) that share a row within
/// [`STRIP`] pixels take their responses from one [`harris_strip`]: on KITTI
/// 2.5-3.7 candidates per strip. Equal to [`harris`] at each, bit for bit.
///
/// ```
/// use lfast::{Plane, cpu::response::{harris, responses}};
/// let img = Plane::from_vec(24, 12, (0..288u32).map(|i| (i * 7 % 253) as u8).collect()).unwrap();
/// let cands = [[5, 5], [6, 5], [9, 5], [20, 5], [7, 6]];
/// let r = responses(&img, &cands);
/// assert!(cands.iter().zip(&r).all(|(&[x, y], v)| v.to_bits() == harris(&img, x, y).to_bits()));
/// ```
pub fn responses(img: &Plane<u8>, cands: &[[u32; 2]]) -> Vec<f32> {
    use rayon::prelude::*;
    let mut out = vec![0f32; cands.len()];
    out.par_chunks_mut(RESPONSE_CHUNK)
        .zip(cands.par_chunks(RESPONSE_CHUNK))
        .for_each(|(o, c)| responses_into(img, c, o));
    out
}

/// Candidates per parallel task of [`responses`].
const RESPONSE_CHUNK: usize = 512;

/// [`responses`] of one chunk, in order.
fn responses_into(img: &Plane<u8>, cands: &[[u32; 2]], out: &mut [f32]) {
    let mut i = 0;
    while i < cands.len() {
        let [x, y] = cands[i];
        let mut j = i + 1;
        while j < cands.len() && cands[j][1] == y && cands[j][0] > cands[j - 1][0] && cands[j][0] < x + STRIP {
            j += 1;
        }
        if j - i >= 2
            && let Some(strip) = harris_strip(img, x, y)
        {
            for k in i..j {
                out[k] = strip[(cands[k][0] - x) as usize];
            }
            i = j;
            continue;
        }
        out[i] = harris(img, x, y);
        i += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corner_beats_edge_beats_flat() {
        // bright quadrant x >= 10, y >= 10 in a 21x21 image
        let img =
            Plane::from_vec(21, 21, (0..441).map(|i| if i % 21 >= 10 && i / 21 >= 10 { 200 } else { 20 }).collect())
                .unwrap();
        let corner = harris(&img, 10, 10);
        let edge = harris(&img, 10, 16); // on the vertical edge, away from the corner
        let flat = harris(&img, 3, 3);
        assert!(corner > 0.0);
        assert!(edge < 0.0, "an edge has a negative Harris score, got {edge}");
        assert_eq!(flat, 0.0);
    }

    #[test]
    fn inside_path_matches_clamped_reads() {
        let img =
            Plane::from_vec(30, 25, (0..750u32).map(|i| (i.wrapping_mul(2654435761) >> 24) as u8).collect()).unwrap();
        for y in 0..25 {
            for x in 0..30 {
                let (a, b, c) = structure_sums_clamped(&img, x, y);
                assert_eq!(structure_sums(&img, x as u32, y as u32), (a, b, c), "({x}, {y})");
            }
        }
    }

    /// A random w x h image with `levels` grey levels spread over 0..=255.
    fn random_levels(w: u32, h: u32, seed: u64, levels: u64) -> Plane<u8> {
        let mut r = crate::rng::SplitMix64::new(seed);
        let px = (0..w * h).map(|_| (r.next_u64() % levels * 255 / (levels - 1).max(1)) as u8).collect();
        Plane::from_vec(w, h, px).unwrap()
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(100))]
        #[test]
        fn inside_path_matches_clamped_reads_random(w in 9u32..40, h in 9u32..30, seed in proptest::prelude::any::<u64>(),
                                                    levels in 1u64..256) {
            // random images with few or many grey levels, every pixel tested
            let img = random_levels(w, h, seed, levels);
            for y in 0..h as i32 {
                for x in 0..w as i32 {
                    let want = structure_sums_clamped(&img, x, y);
                    proptest::prop_assert_eq!(structure_sums(&img, x as u32, y as u32), want, "({}, {})", x, y);
                }
            }
        }
    }

    use proptest::test_runner::TestCaseError;

    /// [`harris_3x3`] or [`harris_7x7`].
    type Square<const S: usize> = fn(&Plane<u8>, u32, u32) -> Option<[[f32; S]; S]>;

    /// `square(img, x, y)` (S x S, footprint S + 8) against [`harris`] at every
    /// centre, the ones too near a side included (`None` there).
    fn check_square<const S: usize>(img: &Plane<u8>, square: Square<S>) -> Result<(), TestCaseError> {
        let (r, f) = (S as u32 / 2, S as u32 / 2 + 4);
        for y in 0..img.height {
            for x in 0..img.width {
                let inside = x >= f && y >= f && x + f < img.width && y + f < img.height;
                match square(img, x, y) {
                    None => proptest::prop_assert!(!inside, "({}, {})", x, y),
                    Some(sq) => {
                        proptest::prop_assert!(inside);
                        for j in 0..S as u32 {
                            for i in 0..S as u32 {
                                let want = harris(img, x + i - r, y + j - r);
                                proptest::prop_assert_eq!(sq[j as usize][i as usize].to_bits(), want.to_bits());
                            }
                        }
                    }
                }
            }
        }
        Ok(())
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(50))]
        #[test]
        fn squares_match_harris(w in 11u32..40, h in 11u32..30, seed in proptest::prelude::any::<u64>(),
                                levels in 1u64..256) {
            let img = random_levels(w, h, seed, levels);
            check_square(&img, harris_3x3)?;
            check_square(&img, harris_7x7)?;
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(60))]
        #[test]
        fn responses_match_harris(w in 1u32..48, h in 1u32..24, seed in proptest::prelude::any::<u64>(),
                                  levels in 1u64..256, density in 1u32..6, shuffle in proptest::prelude::any::<bool>()) {
            // raster-ordered candidates (strips), any order (no strips), every
            // position including the sides (clamped reads there)
            let img = random_levels(w, h, seed, levels);
            let mut r = crate::rng::SplitMix64::new(seed ^ 0x5eed);
            let mut cands: Vec<[u32; 2]> = (0..h)
                .flat_map(|y| (0..w).map(move |x| [x, y]))
                .filter(|_| r.next_u64().is_multiple_of(density as u64))
                .collect();
            if shuffle {
                cands.reverse();
            }
            let got = responses(&img, &cands);
            for (&[x, y], v) in cands.iter().zip(&got) {
                proptest::prop_assert_eq!(v.to_bits(), harris(&img, x, y).to_bits(), "({}, {})", x, y);
            }
        }
    }

    #[test]
    fn squares_and_strip_at_extreme_contrast() {
        // a checkerboard of 0 and 255: the largest gradients, sums near i32's range
        let board = |w: u32, h: u32| {
            Plane::from_vec(w, h, (0..w * h).map(|i| if (i % w + i / w).is_multiple_of(2) { 255 } else { 0 }).collect())
                .unwrap()
        };
        let img = board(16, 15);
        check_square(&img, harris_3x3).unwrap();
        check_square(&img, harris_7x7).unwrap();
        let img = board(16, 9);
        let strip = harris_strip(&img, 4, 4).unwrap();
        for i in 0..8 {
            assert_eq!(strip[i as usize].to_bits(), harris(&img, 4 + i, 4).to_bits());
        }
    }

    #[test]
    fn sums_by_hand() {
        // A vertical step of 10 at columns 4|5 in a 9x9 image: at (4,4) the 7x7
        // block's columns 4 and 5 see Ix = (10-0)*2 + 10 + 10 = 40, others 0.
        let img = Plane::from_vec(9, 9, (0..81).map(|i| if i % 9 >= 5 { 10 } else { 0 }).collect()).unwrap();
        let (a, b, c) = structure_sums(&img, 4, 4);
        assert_eq!((a, b, c), (2 * 7 * 40 * 40, 0, 0));
    }
}
