//! SPEC 11: the rBRIEF test pattern (shared/data/orb_bit_pattern_31.txt,
//! copied to data/) and its tables pre-rotated to the angle bins. The CPU
//! (src/cpu/orb.rs) and the GPU (src/gpu/buffers.rs uploads the tables) share it.

use super::SUBPIXEL;
use super::angle::AngleBins;
use crate::error::{Error, Result};
use std::sync::OnceLock;

/// The pattern table as shipped: 256 rows `x1 y1 x2 y2`.
pub const PATTERN_TEXT: &str = include_str!("../../data/orb_bit_pattern_31.txt");

/// One test: bit = `I(a) < I(b)` with `a = (x1, y1)`, `b = (x2, y2)` offsets.
pub type Pair = [i8; 4];

/// One test with its offsets in 1/[`SUBPIXEL`] pixel (`[x1, y1, x2, y2]`):
/// the rotated pattern of the sub-pixel descriptor (docs/algorithm.md).
pub type FinePair = [i16; 4];

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
            return Err(Error::Pattern {
                line: text.lines().count(),
                reason: format!("expected 256 rows, found {}", pairs.len()),
            });
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
        // offsets within 15 * sqrt(2) of the centre: they fit i8
        self.rotated_in_steps(angle, 1.0).into_iter().map(|p| p.map(|c| c as i8)).collect()
    }

    /// The pattern rotated by `angle` radians in 1/[`SUBPIXEL`] pixel steps:
    /// `16 (x cos - y sin)` and `16 (x sin + y cos)` rounded half to even, as
    /// `[x1, y1, x2, y2]` (the sub-pixel descriptor, [`FinePair`]).
    pub fn rotated_fine(&self, angle: f64) -> Vec<FinePair> {
        self.rotated_in_steps(angle, SUBPIXEL as f64)
    }

    /// The pattern rotated by `angle` radians, in units of `1 / step` pixel:
    /// `step (x cos - y sin)`, `step (x sin + y cos)`, rounded half to even
    /// (a `step` of 1 multiplies exactly, so [`Self::rotated`] is cvRound's).
    fn rotated_in_steps(&self, angle: f64, step: f64) -> Vec<FinePair> {
        let (s, c) = angle.sin_cos();
        let rot = |x: i8, y: i8| {
            let (x, y) = (x as f64, y as f64);
            ((step * (x * c - y * s)).round_ties_even() as i16, (step * (x * s + y * c)).round_ties_even() as i16)
        };
        self.pairs
            .iter()
            .map(|p| {
                let ((ax, ay), (bx, by)) = (rot(p[0], p[1]), rot(p[2], p[3]));
                [ax, ay, bx, by]
            })
            .collect()
    }

    /// The pairs with `f` applied to both points of each, as a table on the
    /// stack (the per-keypoint rotation of `orientation_bins = 0` and of
    /// `descriptor = "opencv"` allocates nothing). A pattern has 256 pairs
    /// ([`parse`](Self::parse) refuses any other count).
    pub(crate) fn map_points(&self, f: impl Fn(i8, i8) -> (i8, i8)) -> [Pair; 256] {
        let mut t = [[0i8; 4]; 256];
        for (o, p) in t.iter_mut().zip(&self.pairs) {
            let (ax, ay) = f(p[0], p[1]);
            let (bx, by) = f(p[2], p[3]);
            *o = [ax, ay, bx, by];
        }
        t
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

/// How far (pixels, along x and along y) from a keypoint's pixel its
/// descriptor reads the smoothed level, in every descriptor mode: the
/// whole-pixel tables and the rotation of the continuous mode stay within
/// [`Pattern::radius`] (a rotated point rounded), and a sub-pixel sample at
/// most one pixel further (its pixel is the keypoint's moved by less than
/// half a pixel, `SUBPIXEL_MAX` / 16, plus the offset in 1/16 px rounded,
/// and the bilinear read takes the next pixel too). The GPU smooths only the
/// 16x16 tiles within this reach of a keypoint (shaders/select.wgsl marks
/// them, shaders/blur.wgsl reads the marks). The tests check it against every
/// table.
///
/// ```
/// assert_eq!(lfast::spec::pattern::descriptor_reach(), lfast::spec::pattern::Pattern::orb().radius() + 1);
/// ```
pub fn descriptor_reach() -> i32 {
    Pattern::orb().radius() + 1
}

/// The largest |offset| of a sub-pixel table (1/16 px).
pub fn fine_reach(table: &[FinePair]) -> i32 {
    // (a plain fold: vectorised through `dispatch!` LLVM unrolled it into a
    // block that valgrind's translator cannot hold, and the C test runs
    // under memcheck)
    table.as_flattened().iter().fold(0, |m, &v| m.max(v.unsigned_abs())) as i32
}

/// The pattern pre-rotated to every bin centre (SPEC 11, `orientation_bins`).
#[derive(Clone, Debug)]
pub struct RotatedPatterns {
    /// The bins the tables belong to.
    pub bins: AngleBins,
    /// `tables[b]` is the pattern rotated to bin b's centre angle.
    pub tables: Vec<Vec<Pair>>,
    /// `fine[b]`: the same rotation in 1/16 pixel, for keypoints with a
    /// sub-pixel position ([`Pattern::rotated_fine`]).
    pub fine: Vec<Vec<FinePair>>,
    /// `fine_reach[b]`: the largest |offset| of `fine[b]` (1/16 px), which
    /// decides whether a keypoint's samples all lie inside its plane.
    pub fine_reach: Vec<i32>,
}

impl RotatedPatterns {
    /// Tables for `bins` (>= 1) bins.
    pub fn new(pattern: &Pattern, bins: u32) -> Self {
        let bins = AngleBins::new(bins);
        let tables = (0..bins.len() as u32).map(|b| pattern.rotated(bins.centre(b))).collect();
        let fine: Vec<Vec<FinePair>> = (0..bins.len() as u32).map(|b| pattern.rotated_fine(bins.centre(b))).collect();
        let fine_reach = fine.iter().map(|t| fine_reach(t)).collect();
        Self { bins, tables, fine, fine_reach }
    }
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

    /// Every pixel a descriptor reads, in every mode, lies within
    /// `descriptor_reach` of the keypoint's pixel: the bin tables' points,
    /// the continuous rotation's (as cpu::orb rounds it) at many angles, and
    /// the sub-pixel samples (offset plus a sub-pixel move of at most
    /// SUBPIXEL_MAX / 16 either way, the bilinear read's next pixel included).
    #[test]
    fn descriptor_reach_bounds_every_read() {
        let reach = descriptor_reach();
        let p = Pattern::orb();
        let sub = crate::spec::SUBPIXEL_MAX as i32;
        for bins in [1u32, 2, 3, 7, 12, 30, 45, 90, 180, 360] {
            let r = RotatedPatterns::new(p, bins);
            for t in &r.tables {
                assert!(t.as_flattened().iter().all(|&c| (c as i32).abs() <= reach), "{bins} bins");
            }
            for t in &r.fine {
                for &o in t.as_flattened() {
                    for s in [-sub, 0, sub] {
                        // pixels (o + s) >> 4 and the next
                        let lo = (o as i32 + s) >> 4;
                        assert!(
                            lo >= -reach && lo < reach,
                            "{bins} bins, offset {o}, sub {s}: pixels {lo} and {}",
                            lo + 1
                        );
                    }
                }
            }
        }
        for k in 0..3600 {
            let a = (k as f32 / 10.0).to_radians();
            let (sn, cs) = a.sin_cos();
            for q in p.pairs.iter().flat_map(|q| [(q[0], q[1]), (q[2], q[3])]) {
                let (x, y) = (q.0 as f32, q.1 as f32);
                let rx = (x * cs - y * sn).round_ties_even() as i32;
                let ry = (x * sn + y * cs).round_ties_even() as i32;
                assert!(rx.abs() <= reach && ry.abs() <= reach, "angle {k}/10");
            }
        }
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
}
