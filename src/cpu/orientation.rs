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
    /// 31 bytes from column x-15), 32 i32 lanes per row with the [`DISC`]
    /// weights: the same integer sums in another order.
    fn disc_moments(rows: &[&[u8]; 31]) -> (i32, i32) {
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
}

#[cfg(test)]
mod tests {
    use super::*;

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
