//! SPEC 11: the rBRIEF descriptor on the smoothed level image, with the ORB
//! pattern of data/orb_bit_pattern_31.txt (embedded at compile time).
//! Mirrors shaders/orb.wgsl.

use crate::image::Plane;
use crate::keypoint::Descriptor;
pub use crate::spec::pattern::{PATTERN_TEXT, Pair, Pattern, RotatedPatterns};

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

/// OpenCV's per-keypoint rotation (`orientation_bins = 0`): f32 cos/sin of
/// the angle in degrees, offsets rounded half to even.
pub fn describe_continuous(smoothed: &Plane<u8>, x: u32, y: u32, angle_deg: f32, pattern: &Pattern) -> Descriptor {
    let a = angle_deg * (std::f32::consts::PI / 180.0);
    let (s, c) = (a.sin(), a.cos());
    // f32, as OpenCV computes it per keypoint
    let table = pattern.map_points(|px, py| {
        let (px, py) = (px as f32, py as f32);
        ((px * c - py * s).round_ties_even() as i8, (px * s + py * c).round_ties_even() as i8)
    });
    describe(smoothed, x, y, &table)
}

#[cfg(test)]
mod tests {
    use super::*;

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

    #[test]
    fn vector_and_scalar_reads_agree_everywhere() {
        // every pixel of a random image, every rotated table: describe (the
        // gather path inside, the scalar paths near the borders) == clamped reads
        let (w, h) = (61u32, 53u32);
        let img =
            Plane::from_vec(w, h, (0..w * h).map(|i| (i.wrapping_mul(2654435761) >> 13) as u8).collect()).unwrap();
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
