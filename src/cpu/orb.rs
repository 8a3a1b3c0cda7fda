//! SPEC 11: the rBRIEF descriptor on the smoothed level image, with the ORB
//! pattern of data/orb_bit_pattern_31.txt (embedded at compile time).
//! Mirrors shaders/orb.wgsl.

use super::orientation::AngleBins;
use crate::error::{Error, Result};
use crate::image::Plane;
use crate::keypoint::Descriptor;
use std::sync::OnceLock;

/// The pattern table as shipped: 256 rows `x1 y1 x2 y2`.
pub const PATTERN_TEXT: &str = include_str!("../../data/orb_bit_pattern_31.txt");

/// One test: bit = `I(a) < I(b)` with `a = (x1, y1)`, `b = (x2, y2)` offsets.
pub type Pair = [i8; 4];

/// The 256 tests of rBRIEF.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Pattern {
    /// Tests in bit order.
    pub pairs: Vec<Pair>,
}

impl Pattern {
    /// Parses the text format: `#` comments, blank lines, then 256 rows of four integers.
    pub fn parse(text: &str) -> Result<Self> {
        let mut pairs = Vec::with_capacity(256);
        for (i, line) in text.lines().enumerate() {
            let line = line.trim();
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            let bad = |reason: String| Error::Pattern { line: i + 1, reason };
            let v: Vec<i8> = line
                .split_whitespace()
                .map(|t| t.parse::<i8>().map_err(|e| bad(format!("`{t}`: {e}"))))
                .collect::<Result<_>>()?;
            if v.len() != 4 {
                return Err(bad(format!("expected 4 numbers, found {}", v.len())));
            }
            if v.iter().any(|c| c.unsigned_abs() > 15) {
                return Err(bad("offset outside the 31x31 patch".into()));
            }
            pairs.push([v[0], v[1], v[2], v[3]]);
        }
        if pairs.len() != 256 {
            return Err(Error::Pattern { line: text.lines().count(), reason: format!("expected 256 rows, found {}", pairs.len()) });
        }
        Ok(Self { pairs })
    }

    /// The embedded ORB pattern (checked by a test, so parsing cannot fail).
    pub fn orb() -> &'static Pattern {
        static P: OnceLock<Pattern> = OnceLock::new();
        P.get_or_init(|| Pattern::parse(PATTERN_TEXT).expect("data/orb_bit_pattern_31.txt is valid (tested)"))
    }

    /// The pattern rotated by `angle` radians, offsets rounded half to even
    /// (OpenCV's cvRound): `x' = x cos - y sin`, `y' = x sin + y cos`.
    pub fn rotated(&self, angle: f64) -> Vec<Pair> {
        let (s, c) = angle.sin_cos();
        self.map_points(|x, y| {
            let (x, y) = (x as f64, y as f64);
            ((x * c - y * s).round_ties_even() as i8, (x * s + y * c).round_ties_even() as i8)
        })
    }

    /// The pairs with `f` applied to both points of each.
    fn map_points(&self, f: impl Fn(i8, i8) -> (i8, i8)) -> Vec<Pair> {
        self.pairs
            .iter()
            .map(|p| {
                let (ax, ay) = f(p[0], p[1]);
                let (bx, by) = f(p[2], p[3]);
                [ax, ay, bx, by]
            })
            .collect()
    }

    /// Largest distance of any (rotated) sample from the keypoint, rounded up.
    pub fn radius(&self) -> i32 {
        self.pairs
            .iter()
            .flat_map(|p| [(p[0], p[1]), (p[2], p[3])])
            .map(|(x, y)| ((x as f64).hypot(y as f64) + 0.5).ceil() as i32)
            .max()
            .unwrap_or(0)
    }
}

/// The pattern pre-rotated to every bin centre (SPEC 11, `orientation_bins`).
#[derive(Clone, Debug)]
pub struct RotatedPatterns {
    /// The bins the tables belong to.
    pub bins: AngleBins,
    /// `tables[b]` is the pattern rotated to bin b's centre angle.
    pub tables: Vec<Vec<Pair>>,
}

impl RotatedPatterns {
    /// Tables for `bins` (>= 1) bins.
    pub fn new(pattern: &Pattern, bins: u32) -> Self {
        let bins = AngleBins::new(bins);
        let tables = (0..bins.len() as u32).map(|b| pattern.rotated(bins.centre(b))).collect();
        Self { bins, tables }
    }
}

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
    fn embedded_pattern_parses() {
        let p = Pattern::orb();
        assert_eq!(p.pairs.len(), 256);
        assert_eq!(p.pairs[0], [8, -3, 9, 5]);
        assert_eq!(p.pairs[1], [4, 2, 7, -12]);
        assert!(p.radius() <= 19);
    }

    #[test]
    fn parse_errors_name_the_line() {
        let e = Pattern::parse("# c\n1 2 3\n").unwrap_err().to_string();
        assert!(e.contains("line 2") && e.contains("4 numbers"), "{e}");
        let e = Pattern::parse("1 2 3 x\n").unwrap_err().to_string();
        assert!(e.contains("line 1"), "{e}");
        let e = Pattern::parse("1 2 3 4\n").unwrap_err().to_string();
        assert!(e.contains("256 rows"), "{e}");
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

    #[test]
    fn border_and_interior_paths_agree() {
        // the same patch content seen at an interior point and through clamped reads
        let img = Plane::from_vec(80, 80, (0..6400u32).map(|i| (i.wrapping_mul(2654435761) >> 24) as u8).collect()).unwrap();
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
        let img = Plane::from_vec(64, 64, (0..64 * 64).map(|i| ((i * 2654435761u64 as usize) >> 7) as u8).collect()).unwrap();
        let rp = RotatedPatterns::new(Pattern::orb(), 4);
        for b in 0..4u32 {
            let deg = b as f32 * 90.0;
            assert_eq!(describe_continuous(&img, 32, 32, deg, Pattern::orb()), describe(&img, 32, 32, &rp.tables[b as usize]));
        }
    }
}
