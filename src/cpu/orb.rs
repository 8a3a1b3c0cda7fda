//! SPEC 11: the rBRIEF descriptor on the smoothed level image, with the ORB
//! pattern of data/orb_bit_pattern_31.txt (embedded at compile time).
//! Mirrors shaders/orb.wgsl.

use crate::image::Plane;
use crate::keypoint::Descriptor;
use crate::spec::SUBPIXEL;
pub use crate::spec::pattern::{FinePair, PATTERN_TEXT, Pair, Pattern, RotatedPatterns};

/// No rotated offset exceeds this (|x|, |y| <= 15 rotated stay within 15 * sqrt(2)).
const REACH: i32 = 22;

/// The descriptor at (x, y) of the smoothed image with a (rotated) table:
/// bit i of byte j is set iff `I(a) < I(b)` for pair `8*j + i`, reads clamped.
pub fn describe(smoothed: &Plane<u8>, x: u32, y: u32, table: &[Pair]) -> Descriptor {
    let (x, y) = (x as i32, y as i32);
    let mut d = [0u8; 32];
    let (w, h) = (smoothed.width as i32, smoothed.height as i32);
    if x >= REACH && y >= REACH && x + REACH < w && y + REACH < h {
        // every sample is inside: read by linear offset, no clamping
        #[cfg(target_arch = "x86_64")]
        if let Some(t) = table.first_chunk::<256>() {
            // the gathers read 4 bytes from each sample: 3 more columns to the right
            let reach_ok = t.as_flattened().iter().fold(true, |ok, &v| ok & (v.unsigned_abs() <= REACH as u8));
            if x + REACH + 3 < w && reach_ok && std::is_x86_feature_detected!("avx2") {
                // SAFETY: AVX2 checked just above; every offset of `t` is within
                // REACH, and REACH <= x, y, x + REACH + 3 < w, y + REACH < h
                // (this branch), which is describe_avx2's contract.
                return unsafe { describe_avx2(&smoothed.data, (y * w + x) as usize, w as usize, t) };
            }
        }
        let c = (y * w + x) as isize;
        let px = |dx: i8, dy: i8| smoothed.data[(c + dy as isize * w as isize + dx as isize) as usize];
        for (j, byte) in d.iter_mut().enumerate() {
            for i in 0..8 {
                let p = table[8 * j + i];
                *byte |= ((px(p[0], p[1]) < px(p[2], p[3])) as u8) << i;
            }
        }
        return d;
    }
    for (j, byte) in d.iter_mut().enumerate() {
        for i in 0..8 {
            let p = table[8 * j + i];
            let a = smoothed.clamped(x + p[0] as i32, y + p[1] as i32);
            let b = smoothed.clamped(x + p[2] as i32, y + p[3] as i32);
            *byte |= ((a < b) as u8) << i;
        }
    }
    d
}

/// [`describe`]'s interior case with AVX2: per 8 pairs, the linear offsets of
/// both samples from one 32-byte load of the table, two 32-bit gathers (the
/// low byte is the sample), one compare, and a movemask that is the
/// descriptor byte (lane i = pair 8j + i = bit i).
///
/// # Safety
/// The CPU has AVX2. `c = y * w + x` is a pixel of `data` (a `w`-wide plane
/// of `h` rows) with `REACH <= x`, `x + REACH + 3 < w`, `REACH <= y`,
/// `y + REACH < h`, and every coordinate in `table` is within `-REACH..=REACH`:
/// so every gathered 4 bytes, from `c + dy * w + dx` to 3 bytes on, lie in
/// rows `y - REACH..=y + REACH` at columns `x - REACH..=x + REACH + 3`, inside `data`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn describe_avx2(data: &[u8], c: usize, w: usize, table: &[Pair; 256]) -> Descriptor {
    use std::arch::x86_64::*;
    let mut d = [0u8; 32];
    // SAFETY (whole body): `c < data.len()` by the contract, so `base` is in
    // bounds; the gathers' addresses are in `data` as the contract says; the
    // table loads read 32 bytes = 8 pairs at pair 8j, j < 32, inside `table`.
    unsafe {
        let base = data.as_ptr().add(c).cast::<i32>();
        let wv = _mm256_set1_epi32(w as i32);
        let byte = _mm256_set1_epi32(0xff);
        for (j, out) in d.iter_mut().enumerate() {
            // lanes: [ax, ay, bx, by] as the bytes of one little-endian i32
            let p = _mm256_loadu_si256(table.as_ptr().add(8 * j).cast::<__m256i>());
            let ax = _mm256_srai_epi32::<24>(_mm256_slli_epi32::<24>(p));
            let ay = _mm256_srai_epi32::<24>(_mm256_slli_epi32::<16>(p));
            let bx = _mm256_srai_epi32::<24>(_mm256_slli_epi32::<8>(p));
            let by = _mm256_srai_epi32::<24>(p);
            let oa = _mm256_add_epi32(_mm256_mullo_epi32(ay, wv), ax);
            let ob = _mm256_add_epi32(_mm256_mullo_epi32(by, wv), bx);
            let a = _mm256_and_si256(_mm256_i32gather_epi32::<1>(base, oa), byte);
            let b = _mm256_and_si256(_mm256_i32gather_epi32::<1>(base, ob), byte);
            // bit i iff I(a) < I(b)
            *out = _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpgt_epi32(b, a))) as u8;
        }
    }
    d
}

/// The smoothed image between pixels, bilinearly in 1/16 px: at `(px, py)`
/// (1/16 px, pixel k at 16 k) the pixels `(ix, iy) = (px, py) >> 4` to
/// `(ix + 1, iy + 1)`, reads clamped, weighed by `(16 - fx, fx)` and
/// `(16 - fy, fy)`, `(fx, fy) = (px, py) & 15`: 256 times the interpolated
/// value, an exact integer (at most `255 * 256`).
///
/// ```
/// use lfast::{Plane, cpu::orb::sample_fine};
/// let img = Plane::from_vec(2, 2, vec![0, 160, 32, 0]).unwrap();
/// assert_eq!(sample_fine(&img, 0, 0), 0); // on pixel (0, 0)
/// assert_eq!(sample_fine(&img, 8, 0), 256 * 80); // halfway to (1, 0)
/// assert_eq!(sample_fine(&img, 4, 8), 12 * 8 * 0 + 4 * 8 * 160 + 12 * 8 * 32 + 4 * 8 * 0);
/// ```
pub fn sample_fine(img: &Plane<u8>, px: i32, py: i32) -> u32 {
    let (ix, iy, fx, fy) = (px >> 4, py >> 4, (px & 15) as u32, (py & 15) as u32);
    let p = |dx: i32, dy: i32| img.clamped(ix + dx, iy + dy) as u32;
    let top = p(0, 0) * (16 - fx) + p(1, 0) * fx;
    let bottom = p(0, 1) * (16 - fx) + p(1, 1) * fx;
    top * (16 - fy) + bottom * fy
}

/// The descriptor of a keypoint at a sub-pixel position (docs/algorithm.md,
/// "The descriptor at the sub-pixel position"): pixel (x, y) moved by
/// `sub / 16` px, each sample of `table` (offsets in 1/16 px,
/// [`Pattern::rotated_fine`]) read by [`sample_fine`]; bit i of byte j is set
/// iff sample a < sample b of pair `8*j + i`. Mirrors shaders/orb.wgsl `fine_word`.
pub fn describe_fine(smoothed: &Plane<u8>, x: u32, y: u32, sub: [i8; 2], table: &[FinePair]) -> Descriptor {
    describe_fine_within(smoothed, x, y, sub, table, crate::spec::pattern::fine_reach(table))
}

/// [`describe_fine`] given `reach`, the table's largest |offset|
/// ([`crate::spec::pattern::fine_reach`], kept per table in
/// [`crate::spec::pattern::RotatedPatterns::fine_reach`]): the fold over the
/// table's 1024 offsets took a fifth of a keypoint's descriptor. The vector
/// path's unclamped reads rely on `reach`, hence crate-private.
pub(crate) fn describe_fine_within(
    smoothed: &Plane<u8>,
    x: u32,
    y: u32,
    sub: [i8; 2],
    table: &[FinePair],
    reach: i32,
) -> Descriptor {
    debug_assert_eq!(reach, crate::spec::pattern::fine_reach(table));
    let (ox, oy) = (x as i32 * SUBPIXEL + sub[0] as i32, y as i32 * SUBPIXEL + sub[1] as i32);
    #[cfg(target_arch = "x86_64")]
    if let Some(t) = table.first_chunk::<256>() {
        let (w, h) = (smoothed.width as i32, smoothed.height as i32);
        // the loads read 4 bytes from (ix, iy) and (ix, iy + 1): columns
        // up to ix + 3 (so ix + 1 is inside too), rows up to iy + 1
        let inside = (ox - reach) >> 4 >= 0
            && ((ox + reach) >> 4) + 3 < w
            && (oy - reach) >> 4 >= 0
            && ((oy + reach) >> 4) + 1 < h;
        let (data, wu, hu) = (&smoothed.data, smoothed.width as usize, smoothed.height as usize);
        if std::is_x86_feature_detected!("avx2") && w > 0 && h > 0 && wu * hu <= data.len() {
            // SAFETY: AVX2 checked just above, and the plane is w x h, not
            // empty. Inside, every sample's (ix, iy) lies in 0 <= ix,
            // ix + 3 < w, 0 <= iy, iy + 1 < h (`inside`, with reach the
            // table's largest offset); elsewhere the reads are clamped, and
            // o is a pixel of the plane (|o| < 2^20) plus a sub-pixel offset:
            // describe_fine_avx2's contract either way.
            return unsafe {
                if inside {
                    describe_fine_avx2::<false>(data, wu, hu, [ox, oy], t)
                } else {
                    describe_fine_avx2::<true>(data, wu, hu, [ox, oy], t)
                }
            };
        }
    }
    fine_by_samples(smoothed, [ox, oy], table)
}

/// [`describe_fine`] by its definition, every sample through [`sample_fine`]
/// (`o`: the keypoint in 1/16 px): the border path, and the reference the
/// AVX2 path is tested against.
fn fine_by_samples(smoothed: &Plane<u8>, o: [i32; 2], table: &[FinePair]) -> Descriptor {
    let mut d = [0u8; 32];
    for (j, byte) in d.iter_mut().enumerate() {
        for i in 0..8 {
            let p = table[8 * j + i];
            let a = sample_fine(smoothed, o[0] + p[0] as i32, o[1] + p[1] as i32);
            let b = sample_fine(smoothed, o[0] + p[2] as i32, o[1] + p[3] as i32);
            *byte |= ((a < b) as u8) << i;
        }
    }
    d
}

/// [`describe_fine`] with AVX2, 8 pairs at a time: the pairs' two points as
/// lanes of i32 (a permute of the table's words), their pixels and
/// fractions, two 4-byte loads per point (pixels ix, ix + 1 of rows iy and
/// iy + 1; scalar loads into the lanes, not `vpgatherdd`: 30-40% faster on
/// the Zen 5 measured), the bilinear weights in 16-bit multiplies (every product and sum
/// is below 2^16), one compare and a movemask for the byte.
///
/// With `CLAMP` (keypoints near the border) each of a sample's four pixels
/// is read at its coordinates clamped to the plane, as [`sample_fine`] reads
/// it: four byte loads per point, put together as the two rows' pixel pairs.
///
/// # Safety
/// The CPU has AVX2. `data` is a `w`-wide plane of `h` rows (`w * h <=
/// data.len()`). Without `CLAMP`, for every offset `(u, v)` of `table` the
/// pixel `((o[0] + u) >> 4, (o[1] + v) >> 4) = (ix, iy)` has `0 <= ix`,
/// `ix + 3 < w`, `0 <= iy` and `iy + 1 < h`: so both loaded 4 bytes lie in
/// `data`. With `CLAMP`, `w, h >= 1` and `o` is any position whose samples
/// do not overflow i32 (|o| < 2^30): every read is clamped into the plane.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn describe_fine_avx2<const CLAMP: bool>(
    data: &[u8],
    w: usize,
    h: usize,
    o: [i32; 2],
    table: &[FinePair; 256],
) -> Descriptor {
    use std::arch::x86_64::*;
    let mut d = [0u8; 32];
    // SAFETY (whole body): the table loads read 64 bytes = 8 pairs at pair
    // 8j, j < 32, inside `table`; the loads' addresses are in `data` by the contract.
    unsafe {
        let base = data.as_ptr();
        let wv = _mm256_set1_epi32(w as i32);
        let (ox, oy) = (_mm256_set1_epi32(o[0]), _mm256_set1_epi32(o[1]));
        let (byte, fifteen, sixteen) = (_mm256_set1_epi32(0xff), _mm256_set1_epi32(15), _mm256_set1_epi32(16));
        // words of a pair: [x1 | y1 << 16, x2 | y2 << 16]; this permute puts the
        // four first words, then the four second words, of four pairs in a row
        let split = _mm256_setr_epi32(0, 2, 4, 6, 1, 3, 5, 7);
        let (wmax, hmax) = (_mm256_set1_epi32(w as i32 - 1), _mm256_set1_epi32(h as i32 - 1));
        // the weighted sum of a row pair's pixels (bytes 0 and 1 of each lane)
        let bilinear = |top: __m256i, bottom: __m256i, fx, fy, gx, gy| {
            let left_right = |r: __m256i| {
                let (l, rt) = (_mm256_and_si256(r, byte), _mm256_and_si256(_mm256_srli_epi32::<8>(r), byte));
                _mm256_add_epi32(_mm256_mullo_epi16(l, gx), _mm256_mullo_epi16(rt, fx))
            };
            _mm256_add_epi32(_mm256_mullo_epi16(left_right(top), gy), _mm256_mullo_epi16(left_right(bottom), fy))
        };
        // 256 times the bilinear value at the points (x, y) (lanes of i32, 1/16 px)
        let sample = |x: __m256i, y: __m256i| {
            let (px, py) = (_mm256_add_epi32(x, ox), _mm256_add_epi32(y, oy));
            let (ix, iy) = (_mm256_srai_epi32::<4>(px), _mm256_srai_epi32::<4>(py));
            let (fx, fy) = (_mm256_and_si256(px, fifteen), _mm256_and_si256(py, fifteen));
            let (gx, gy) = (_mm256_sub_epi32(sixteen, fx), _mm256_sub_epi32(sixteen, fy));
            if CLAMP {
                // pixels (x0 | x1, y0 | y1), each coordinate clamped, as
                // (p(x0) | p(x1) << 8) per row: what the 4-byte loads give inside
                let zero = _mm256_setzero_si256();
                let clamp = |v: __m256i, max: __m256i| _mm256_min_epi32(_mm256_max_epi32(v, zero), max);
                let one = _mm256_set1_epi32(1);
                let (x0, x1) = (clamp(ix, wmax), clamp(_mm256_add_epi32(ix, one), wmax));
                let (r0, r1) = (
                    _mm256_mullo_epi32(clamp(iy, hmax), wv),
                    _mm256_mullo_epi32(clamp(_mm256_add_epi32(iy, one), hmax), wv),
                );
                let mut at = [[0i32; 8]; 4];
                for (a, v) in at.iter_mut().zip([
                    _mm256_add_epi32(r0, x0),
                    _mm256_add_epi32(r0, x1),
                    _mm256_add_epi32(r1, x0),
                    _mm256_add_epi32(r1, x1),
                ]) {
                    _mm256_storeu_si256(a.as_mut_ptr().cast(), v);
                }
                let px = |k: usize, l: usize| *base.add(at[k][l] as usize) as i32;
                let pair = |k: usize, l: usize| px(k, l) | px(k + 1, l) << 8;
                let top = _mm256_setr_epi32(
                    pair(0, 0),
                    pair(0, 1),
                    pair(0, 2),
                    pair(0, 3),
                    pair(0, 4),
                    pair(0, 5),
                    pair(0, 6),
                    pair(0, 7),
                );
                let bottom = _mm256_setr_epi32(
                    pair(2, 0),
                    pair(2, 1),
                    pair(2, 2),
                    pair(2, 3),
                    pair(2, 4),
                    pair(2, 5),
                    pair(2, 6),
                    pair(2, 7),
                );
                return bilinear(top, bottom, fx, fy, gx, gy);
            }
            let mut at = [0i32; 8];
            _mm256_storeu_si256(at.as_mut_ptr().cast(), _mm256_add_epi32(_mm256_mullo_epi32(iy, wv), ix));
            // 4 bytes at each lane's index (the pixels ix, ix + 1 and two
            // more) of row iy and of row iy + 1, by scalar loads: faster
            // than two vpgatherdd on the Zen 5 measured
            let four = |l: usize, row: usize| base.add(at[l] as usize + row).cast::<i32>().read_unaligned();
            let top = _mm256_setr_epi32(
                four(0, 0),
                four(1, 0),
                four(2, 0),
                four(3, 0),
                four(4, 0),
                four(5, 0),
                four(6, 0),
                four(7, 0),
            );
            let bottom = _mm256_setr_epi32(
                four(0, w),
                four(1, w),
                four(2, w),
                four(3, w),
                four(4, w),
                four(5, w),
                four(6, w),
                four(7, w),
            );
            bilinear(top, bottom, fx, fy, gx, gy)
        };
        for (j, out) in d.iter_mut().enumerate() {
            let p = table.as_ptr().add(8 * j).cast::<__m256i>();
            let lo = _mm256_permutevar8x32_epi32(_mm256_loadu_si256(p), split);
            let hi = _mm256_permutevar8x32_epi32(_mm256_loadu_si256(p.add(1)), split);
            let (a, b) = (_mm256_permute2x128_si256::<0x20>(lo, hi), _mm256_permute2x128_si256::<0x31>(lo, hi));
            let x_of = |v: __m256i| _mm256_srai_epi32::<16>(_mm256_slli_epi32::<16>(v));
            let va = sample(x_of(a), _mm256_srai_epi32::<16>(a));
            let vb = sample(x_of(b), _mm256_srai_epi32::<16>(b));
            // bit i iff a < b
            *out = _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpgt_epi32(vb, va))) as u8;
        }
    }
    d
}

/// OpenCV's per-keypoint rotation (`orientation_bins = 0`): f32 cos/sin of
/// the angle in degrees, offsets rounded half to even.
pub fn describe_continuous(smoothed: &Plane<u8>, x: u32, y: u32, angle_deg: f32, pattern: &Pattern) -> Descriptor {
    let a = angle_deg * (std::f32::consts::PI / 180.0);
    describe(smoothed, x, y, &rotated_f32(pattern, a.cos(), a.sin()))
}

/// The pattern turned by the angle of cosine `c` and sine `s` as OpenCV's
/// ORB turns it per keypoint: `cvRound(x c - y s)`, `cvRound(x s + y c)` in
/// f32 (`descriptor = "opencv"` and `orientation_bins = 0`).
pub fn rotated_f32(pattern: &Pattern, c: f32, s: f32) -> [Pair; 256] {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") {
        // SAFETY: AVX2 was detected just above
        return unsafe { rotated_f32_avx2(pattern, c, s) };
    }
    rotated_f32_scalar(pattern, c, s)
}

/// [`rotated_f32`] one point at a time (the reference of the AVX2 path).
pub fn rotated_f32_scalar(pattern: &Pattern, c: f32, s: f32) -> [Pair; 256] {
    use crate::cpu::opencv::cv_round;
    pattern.map_points(|px, py| {
        let (px, py) = (px as f32, py as f32);
        (cv_round(px * c - py * s) as i8, cv_round(px * s + py * c) as i8)
    })
}

/// [`rotated_f32`] four points (8 coordinates, `x y x y ...`) at a time:
/// with `v = [x, y, ...]` and `w = [y, x, ...]` (swapped in pairs), `v c +
/// w [-s, s, ...]` is `[x c - y s, y c + x s, ...]`, which equals the scalar
/// `x c - y s` and `x s + y c` bit for bit (negation is exact, `a + (-b)` is
/// `a - b`, addition commutes; a multiply and an add, never fused).
/// `_mm256_cvtps_epi32` rounds half to even under the default rounding mode,
/// as `cvRound` does.
///
/// # Safety
/// The CPU has AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn rotated_f32_avx2(pattern: &Pattern, c: f32, s: f32) -> [Pair; 256] {
    use std::arch::x86_64::*;
    let coords = pattern.pairs.as_flattened();
    let mut out = [[0i8; 4]; 256];
    let flat = out.as_flattened_mut();
    let (vc, vs) = (_mm256_set1_ps(c), _mm256_setr_ps(-s, s, -s, s, -s, s, -s, s));
    let mut lanes = [0i32; 8];
    for (src, dst) in coords.chunks_exact(8).zip(flat.chunks_exact_mut(8)) {
        // SAFETY: `src` holds 8 bytes (chunks_exact), the load reads 8
        let bytes = unsafe { _mm_loadl_epi64(src.as_ptr().cast()) };
        let v = _mm256_cvtepi32_ps(_mm256_cvtepi8_epi32(bytes));
        let w = _mm256_permute_ps::<0b10_11_00_01>(v);
        let r = _mm256_add_ps(_mm256_mul_ps(v, vc), _mm256_mul_ps(w, vs));
        // SAFETY: `lanes` holds 8 i32
        unsafe { _mm256_storeu_si256(lanes.as_mut_ptr().cast(), _mm256_cvtps_epi32(r)) };
        for (d, &l) in dst.iter_mut().zip(&lanes) {
            *d = l as i8;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotated_f32_simd_equals_scalar() {
        let p = Pattern::orb();
        // every 1/8 degree, and the exact quarter turns
        for k in 0..2880 {
            let a = (k as f32 / 8.0) * (std::f32::consts::PI / 180.0);
            let (c, s) = (a.cos(), a.sin());
            assert_eq!(rotated_f32(p, c, s), rotated_f32_scalar(p, c, s), "{} degrees", k as f32 / 8.0);
        }
        for (c, s) in [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0), (0.5, 0.5)] {
            assert_eq!(rotated_f32(p, c, s), rotated_f32_scalar(p, c, s), "cos {c} sin {s}");
        }
        // unrotated is the pattern itself
        assert_eq!(rotated_f32(p, 1.0, 0.0).as_slice(), p.pairs.as_slice());
    }

    #[test]
    fn one_bit_by_hand() {
        // Pair 0 is (8,-3) vs (9,5). Unrotated at (20,20): bit 0 of byte 0 is
        // I(28,17) < I(29,25). Make it true, then false.
        let mut img = Plane::<u8>::new(41, 41);
        img.data.fill(100);
        img.data[25 * 41 + 29] = 101;
        let d = describe(&img, 20, 20, &Pattern::orb().pairs);
        assert_eq!(d[0] & 1, 1);
        img.data[25 * 41 + 29] = 100;
        let d = describe(&img, 20, 20, &Pattern::orb().pairs);
        assert_eq!(d[0] & 1, 0);
        // Rotated by 90°: (x, y) -> (-y, x), so pair 0 reads (3, 8) vs (-5, 9).
        let r = Pattern::orb().rotated(std::f64::consts::FRAC_PI_2);
        assert_eq!(r[0], [3, 8, -5, 9]);
        img.data[(20 + 9) * 41 + 20 - 5] = 200;
        let d = describe(&img, 20, 20, &r);
        assert_eq!(d[0] & 1, 1);
    }

    /// A w x h image of hashed pixel values (every grey level, no structure).
    fn hashed_image(w: u32, h: u32) -> Plane<u8> {
        Plane::from_vec(w, h, (0..w * h).map(|i| (i.wrapping_mul(2654435761) >> 13) as u8).collect()).unwrap()
    }

    #[test]
    fn vector_and_scalar_reads_agree_everywhere() {
        // every pixel of a random image, every rotated table: describe (the
        // gather path inside, the scalar paths near the borders) == clamped reads
        let (w, h) = (61u32, 53u32);
        let img = hashed_image(w, h);
        let rp = RotatedPatterns::new(Pattern::orb(), 30);
        for (k, t) in rp.tables.iter().enumerate() {
            for y in (0..h).step_by(1 + k % 3) {
                for x in 0..w {
                    let mut want = [0u8; 32];
                    for (j, byte) in want.iter_mut().enumerate() {
                        for i in 0..8 {
                            let p = t[8 * j + i];
                            let a = img.clamped(x as i32 + p[0] as i32, y as i32 + p[1] as i32);
                            let b = img.clamped(x as i32 + p[2] as i32, y as i32 + p[3] as i32);
                            *byte |= ((a < b) as u8) << i;
                        }
                    }
                    assert_eq!(describe(&img, x, y, t), want, "table {k} at ({x}, {y})");
                }
            }
        }
    }

    #[test]
    fn border_and_interior_paths_agree() {
        // the same patch content seen at an interior point and through clamped reads
        let img =
            Plane::from_vec(80, 80, (0..6400u32).map(|i| (i.wrapping_mul(2654435761) >> 24) as u8).collect()).unwrap();
        let rp = RotatedPatterns::new(Pattern::orb(), 30);
        for t in &rp.tables {
            assert!(t.iter().all(|p| p.iter().all(|&c| (c as i32).abs() <= REACH)));
        }
        for (x, y) in [(40, 40), (22, 22), (57, 57), (21, 40), (40, 58), (0, 0), (79, 79)] {
            let clamped = {
                let mut d = [0u8; 32];
                for (j, byte) in d.iter_mut().enumerate() {
                    for i in 0..8 {
                        let p = rp.tables[7][8 * j + i];
                        let a = img.clamped(x + p[0] as i32, y + p[1] as i32);
                        let b = img.clamped(x + p[2] as i32, y + p[3] as i32);
                        *byte |= ((a < b) as u8) << i;
                    }
                }
                d
            };
            assert_eq!(describe(&img, x as u32, y as u32, &rp.tables[7]), clamped, "({x}, {y})");
        }
    }

    /// [`describe_fine`] through its reference, [`fine_by_samples`].
    fn fine_naive(img: &Plane<u8>, x: u32, y: u32, sub: [i8; 2], t: &[FinePair]) -> Descriptor {
        fine_by_samples(img, [16 * x as i32 + sub[0] as i32, 16 * y as i32 + sub[1] as i32], t)
    }

    #[test]
    fn fine_reads_on_planes_smaller_than_the_pattern_are_clamped() {
        // every pixel of planes narrower or shorter than the pattern's reach,
        // a 1x1 one included: every read clamped
        let rp = RotatedPatterns::new(Pattern::orb(), 180);
        for (w, h) in [(1u32, 1u32), (2, 3), (5, 1), (1, 7), (17, 9), (40, 3)] {
            let img = hashed_image(w, h);
            for k in [0usize, 61, 150] {
                for y in 0..h {
                    for x in 0..w {
                        for sub in [[-7i8, -7], [0, 0], [7, 3], [-2, 7]] {
                            assert_eq!(
                                describe_fine(&img, x, y, sub, &rp.fine[k]),
                                fine_naive(&img, x, y, sub, &rp.fine[k]),
                                "{w}x{h}, bin {k} at ({x}, {y}), {sub:?}"
                            );
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn fine_vector_and_scalar_reads_agree_everywhere() {
        // every pixel of a random image (the unclamped loads inside, clamped
        // ones near the borders), every 1/16 offset in turn, several bins
        let (w, h) = (67u32, 59u32);
        let img = hashed_image(w, h);
        let rp = RotatedPatterns::new(Pattern::orb(), 180);
        for k in [0usize, 7, 44, 91, 135, 179] {
            let t = &rp.fine[k];
            for y in 0..h {
                for x in 0..w {
                    let n = (x * 7 + y * 3 + k as u32) % 225;
                    let sub = [(n % 15) as i8 - 7, (n / 15) as i8 - 7];
                    assert_eq!(
                        describe_fine(&img, x, y, sub, t),
                        fine_naive(&img, x, y, sub, t),
                        "bin {k} at ({x}, {y}), {sub:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn fine_at_whole_pixel_offsets_is_the_pixel_descriptor() {
        // offsets that are whole pixels and no sub-pixel shift: every sample is
        // 256 times a pixel, so the bits are those of `describe`
        let img = Plane::from_vec(70, 64, (0..70 * 64u32).map(|i| (i.wrapping_mul(2246822519) >> 20) as u8).collect())
            .unwrap();
        let rp = RotatedPatterns::new(Pattern::orb(), 30);
        for t in [&rp.tables[0], &rp.tables[11], &rp.tables[23]] {
            let fine: Vec<FinePair> = t.iter().map(|p| p.map(|c| 16 * c as i16)).collect();
            for (x, y) in [(35, 32), (22, 22), (0, 0), (69, 63), (40, 5), (47, 41)] {
                assert_eq!(describe_fine(&img, x, y, [0, 0], &fine), describe(&img, x, y, t), "({x}, {y})");
            }
        }
    }

    #[test]
    fn one_fine_sample_by_hand() {
        // a 2x2 patch: (0,0)=10 (1,0)=50 (0,1)=90 (1,1)=130; at (5/16, 12/16):
        // top 11*10 + 5*50 = 360, bottom 11*90 + 5*130 = 1640, 4*360 + 12*1640
        let img = Plane::from_vec(2, 2, vec![10, 50, 90, 130]).unwrap();
        assert_eq!(sample_fine(&img, 5, 12), 4 * 360 + 12 * 1640);
        // negative positions floor and clamp: (-1/16, 0) is 15/16 of pixel -1 (= 0) and 1/16 of pixel 0
        assert_eq!(sample_fine(&img, -1, 0), 256 * 10);
        assert_eq!(sample_fine(&img, 31, 31), 256 * 130);
    }

    #[test]
    fn continuous_matches_binned_at_bin_centres() {
        let img =
            Plane::from_vec(64, 64, (0..64 * 64).map(|i| ((i * 2654435761u64 as usize) >> 7) as u8).collect()).unwrap();
        let rp = RotatedPatterns::new(Pattern::orb(), 4);
        for b in 0..4u32 {
            let deg = b as f32 * 90.0;
            assert_eq!(
                describe_continuous(&img, 32, 32, deg, Pattern::orb()),
                describe(&img, 32, 32, &rp.tables[b as usize])
            );
        }
    }
}
