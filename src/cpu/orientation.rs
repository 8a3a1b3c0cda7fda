//! SPEC 11: keypoint orientation by the intensity centroid (ORB): the
//! moments over the radius-15 disc. The disc, the angle and the integer angle
//! bins are shared with the GPU path in [`crate::spec::angle`].
//! Mirrors shaders/orientation.wgsl.

use super::simd::dispatch;
use crate::image::Plane;
pub use crate::spec::angle::{AngleBins, HALF_PATCH, UMAX, angle_deg, compute_umax};

/// Intensity moments `(m10, m01)` over the radius-15 disc around (x, y), reads
/// clamped to the image. `|m| < 2^21`, so they fit i32 with room.
pub fn moments(img: &Plane<u8>, x: u32, y: u32) -> (i32, i32) {
    let (x, y) = (x as i32, y as i32);
    let inside =
        x >= HALF_PATCH && y >= HALF_PATCH && x + HALF_PATCH < img.width as i32 && y + HALF_PATCH < img.height as i32;
    let (mut m10, mut m01) = (0i32, 0i32);
    if inside {
        let w = img.width as usize;
        let rows: [&[u8]; 31] = std::array::from_fn(|r| &img.data[(y as usize + r - 15) * w + x as usize - 15..][..31]);
        (m10, m01) = disc_moments(&rows);
    } else {
        for u in -HALF_PATCH..=HALF_PATCH {
            m10 += u * img.clamped(x + u, y) as i32;
        }
        for v in 1..=HALF_PATCH {
            let mut v_sum = 0;
            let r = UMAX[v as usize];
            for u in -r..=r {
                let plus = img.clamped(x + u, y + v) as i32;
                let minus = img.clamped(x + u, y - v) as i32;
                v_sum += plus - minus;
                m10 += u * (plus + minus);
            }
            m01 += v * v_sum;
        }
    }
    (m10, m01)
}

/// Per disc row `|v|` and lane `k` (column `k - 15`, lane 31 padding): the
/// column `k - 15` where it lies in the disc (`|k - 15| <= UMAX[|v|]`), else 0;
/// and 1 where it lies in the disc, else 0.
const DISC: ([[i32; 32]; 16], [[i32; 32]; 16]) = {
    let (mut u, mut m) = ([[0i32; 32]; 16], [[0i32; 32]; 16]);
    let mut v = 0;
    while v < 16 {
        let mut k = 0;
        while k < 31 {
            let du = k as i32 - HALF_PATCH;
            if du.abs() <= UMAX[v] {
                u[v][k] = du;
                m[v][k] = 1;
            }
            k += 1;
        }
        v += 1;
    }
    (u, m)
};

dispatch! {
    /// [`moments`] inside the image from the disc's 31 rows (`rows[v + 15]`,
    /// 31 bytes from column x-15): [`disc_moments_avx2`] in the AVX2 and AVX-512 builds,
    /// else [`disc_moments_i32`].
    fn disc_moments<const AVX2>(rows: &[&[u8]; 31]) -> (i32, i32) {
        #[cfg(target_arch = "x86_64")]
        if AVX2 {
            // SAFETY: AVX2 is only set in the builds with AVX2 (the AVX2 and AVX-512 ones)
            return unsafe { disc_moments_avx2(rows) };
        }
        disc_moments_i32(rows)
    }
}

/// [`disc_moments`] in 32 i32 lanes per row with the [`DISC`] weights: the
/// same integer sums as [`moments`] in another order.
#[inline(always)]
fn disc_moments_i32(rows: &[&[u8]; 31]) -> (i32, i32) {
    let load = |r: &[u8]| {
        let mut p = [0i32; 32];
        for (q, &v) in p.iter_mut().zip(&r[..31]) {
            *q = v as i32;
        }
        p
    };
    let (cols, inside) = (&DISC.0, &DISC.1);
    let mut m10 = [0i32; 32];
    let mut m01 = [0i32; 32];
    let c = load(rows[15]);
    for k in 0..32 {
        m10[k] = cols[0][k] * c[k];
    }
    for v in 1..16 {
        let (p, m) = (load(rows[15 + v]), load(rows[15 - v]));
        for k in 0..32 {
            m10[k] += cols[v][k] * (p[k] + m[k]);
            m01[k] += v as i32 * inside[v][k] * (p[k] - m[k]);
        }
    }
    (m10.iter().sum(), m01.iter().sum())
}

/// [`DISC`]'s weights in i16 for [`disc_moments_avx2`], per row `|v|` and
/// half: the first half weighs columns 0..16 of the 31, the second columns
/// 15..31 with column 15 (its lane 0) at 0, as the first half has it. `.0`:
/// the column `u`, for m10; `.1`: `v` where the column lies in the disc, for m01.
type DiscHalves = [[[i16; 16]; 2]; 16];
const DISC16: (DiscHalves, DiscHalves) = {
    let (mut u, mut m) = ([[[0i16; 16]; 2]; 16], [[[0i16; 16]; 2]; 16]);
    let mut v = 0;
    while v < 16 {
        let mut k = 0;
        while k < 16 {
            u[v][0][k] = DISC.0[v][k] as i16;
            m[v][0][k] = (v as i32 * DISC.1[v][k]) as i16;
            if k > 0 {
                u[v][1][k] = DISC.0[v][15 + k] as i16;
                m[v][1][k] = (v as i32 * DISC.1[v][15 + k]) as i16;
            }
            k += 1;
        }
        v += 1;
    }
    (u, m)
};

/// [`disc_moments_i32`] with AVX2: each row as two halves of 16 i16 lanes
/// (bytes 0..16 and 15..31, so no read passes the 31), rows `±v` added and
/// subtracted (|p ± m| <= 510), then multiplied by [`DISC16`]'s weights and
/// summed in pairs into i32 lanes by `vpmaddwd` (|product| <= 510 * 15): the
/// same integer sums in another order. Checked against
/// [`disc_moments_i32`] in `tests::disc_moments_avx2_equals_i32`.
///
/// # Safety
/// The CPU has AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn disc_moments_avx2(rows: &[&[u8]; 31]) -> (i32, i32) {
    use std::arch::x86_64::*;
    let halves = |r: &[u8]| {
        let r = &r[..31];
        // SAFETY: two 16-byte loads at 0 and 15 of the 31 bytes of `r`
        unsafe {
            (
                _mm256_cvtepu8_epi16(_mm_loadu_si128(r.as_ptr().cast())),
                _mm256_cvtepu8_epi16(_mm_loadu_si128(r.as_ptr().add(15).cast())),
            )
        }
    };
    // SAFETY: a 32-byte load of 16 i16
    let w = |t: &[i16; 16]| unsafe { _mm256_loadu_si256(t.as_ptr().cast()) };
    let (u, m) = (&DISC16.0, &DISC16.1);
    let (c0, c1) = halves(rows[15]);
    let mut a10 = _mm256_add_epi32(_mm256_madd_epi16(c0, w(&u[0][0])), _mm256_madd_epi16(c1, w(&u[0][1])));
    let mut a01 = _mm256_setzero_si256();
    for v in 1..16 {
        let ((p0, p1), (m0, m1)) = (halves(rows[15 + v]), halves(rows[15 - v]));
        let s10 = _mm256_add_epi32(
            _mm256_madd_epi16(_mm256_add_epi16(p0, m0), w(&u[v][0])),
            _mm256_madd_epi16(_mm256_add_epi16(p1, m1), w(&u[v][1])),
        );
        let s01 = _mm256_add_epi32(
            _mm256_madd_epi16(_mm256_sub_epi16(p0, m0), w(&m[v][0])),
            _mm256_madd_epi16(_mm256_sub_epi16(p1, m1), w(&m[v][1])),
        );
        a10 = _mm256_add_epi32(a10, s10);
        a01 = _mm256_add_epi32(a01, s01);
    }
    let sum = |a: __m256i| {
        let mut l = [0i32; 8];
        // SAFETY: a 32-byte store into 8 i32
        unsafe { _mm256_storeu_si256(l.as_mut_ptr().cast(), a) };
        l.iter().sum::<i32>()
    };
    (sum(a10), sum(a01))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    #[cfg(target_arch = "x86_64")]
    fn disc_moments_avx2_equals_i32() {
        if !std::is_x86_feature_detected!("avx2") {
            return;
        }
        let mut r = crate::rng::SplitMix64::new(3);
        for round in 0..2000 {
            // extremes (every pixel 0 or 255, one side bright) and random bytes
            let patch: Vec<[u8; 31]> = (0..31)
                .map(|v| {
                    std::array::from_fn(|k| match round % 4 {
                        0 => [0, 255][(r.next_u64() & 1) as usize],
                        1 => 255 * ((v > 15) == (k % 3 == 0)) as u8,
                        _ => r.next_u64() as u8,
                    })
                })
                .collect();
            let rows: [&[u8]; 31] = std::array::from_fn(|v| &patch[v][..]);
            // SAFETY: AVX2 checked above
            assert_eq!(unsafe { disc_moments_avx2(&rows) }, disc_moments_i32(&rows), "round {round}");
        }
    }

    #[test]
    fn moments_of_a_ramp() {
        // intensity grows to the right: centroid points along +x, angle 0
        let img = Plane::from_vec(41, 41, (0..41 * 41).map(|i| (i % 41 * 5) as u8).collect()).unwrap();
        let (m10, m01) = moments(&img, 20, 20);
        assert!(m10 > 0);
        assert_eq!(m01, 0);
        assert_eq!(angle_deg(m10, m01), 0.0);
        // downward ramp (y grows): 90 degrees, as OpenCV reports in image coordinates
        let img = Plane::from_vec(41, 41, (0..41 * 41).map(|i| (i / 41 * 5) as u8).collect()).unwrap();
        let (m10, m01) = moments(&img, 20, 20);
        assert_eq!((m10, angle_deg(m10, m01)), (0, 90.0));
        // every position, border included, against the plain disc sum with clamped reads
        let img = Plane::from_vec(41, 41, (0..41 * 41).map(|i| ((i * 7919) % 251) as u8).collect()).unwrap();
        for y in 0..41 {
            for x in 0..41 {
                let (mut m10, mut m01) = (0, 0);
                for v in -15..=15i32 {
                    let r = UMAX[v.unsigned_abs() as usize];
                    for u in -r..=r {
                        let i = img.clamped(x + u, y + v) as i32;
                        m10 += u * i;
                        m01 += v * i;
                    }
                }
                assert_eq!(moments(&img, x as u32, y as u32), (m10, m01), "({x}, {y})");
            }
        }
    }
}
