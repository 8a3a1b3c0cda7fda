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
