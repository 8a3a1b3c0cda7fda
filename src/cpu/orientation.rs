//! SPEC 11: keypoint orientation by the intensity centroid (ORB): the
//! moments over the radius-15 disc. The disc, the angle and the integer angle
//! bins are shared with the GPU path in [`crate::spec::angle`].
//! Mirrors shaders/orientation.wgsl.

use crate::image::Plane;
pub use crate::spec::angle::{AngleBins, HALF_PATCH, UMAX, angle_deg, compute_umax};

/// Intensity moments `(m10, m01)` over the radius-15 disc around (x, y), reads
/// clamped to the image. `|m| < 2^21`, so they fit i32 with room.
pub fn moments(img: &Plane<u8>, x: u32, y: u32) -> (i32, i32) {
    let (x, y) = (x as i32, y as i32);
    let inside = x >= HALF_PATCH && y >= HALF_PATCH && x + HALF_PATCH < img.width as i32 && y + HALF_PATCH < img.height as i32;
    let (mut m10, mut m01) = (0i32, 0i32);
    if inside {
        // Row slices around the centre: the inner loops vectorise.
        let w = img.width as usize;
        let c = y as usize * w + x as usize;
        let d = &img.data;
        let h = HALF_PATCH as usize;
        for (k, &p) in d[c - h..=c + h].iter().enumerate() {
            m10 += (k as i32 - HALF_PATCH) * p as i32;
        }
        for v in 1..=h {
            let r = UMAX[v] as usize;
            let (up, down) = (c - v * w, c + v * w);
            let (plus, minus) = (&d[down - r..=down + r], &d[up - r..=up + r]);
            let mut v_sum = 0;
            for (k, (&p, &m)) in plus.iter().zip(minus).enumerate() {
                let (p, m) = (p as i32, m as i32);
                v_sum += p - m;
                m10 += (k as i32 - r as i32) * (p + m);
            }
            m01 += v as i32 * v_sum;
        }
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
