//! What the brute-force Hamming matchers (src/cpu/matcher.rs,
//! src/gpu/matcher.rs, shaders/matcher.wgsl) share: the options, their
//! fixed-point ratio, the sentinels and the match record. The definitions
//! they follow are in src/cpu/matcher.rs.

use crate::error::{Error, Result};

/// "No index": a query without a train descriptor (empty train set).
pub const NO_INDEX: u32 = u32::MAX;
/// "No distance": `d2` when there is a single train descriptor.
pub const NO_DISTANCE: u32 = u32::MAX;
/// Fixed-point denominator of the ratio test.
pub const RATIO_ONE: u32 = 1 << 16;

/// How matches are filtered.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MatchOptions {
    /// Keep a match only when the two descriptors are each other's nearest.
    pub cross_check: bool,
    /// Lowe's ratio `d1 < ratio * d2`, in (0, 1]; `None` = no ratio test.
    pub ratio: Option<f32>,
    /// Largest Hamming distance kept (256 = no limit).
    pub max_distance: u32,
}

impl Default for MatchOptions {
    /// Cross-check, ratio 0.8, distance at most 64: a common setting for
    /// ORB descriptors in visual odometry.
    fn default() -> Self {
        Self { cross_check: true, ratio: Some(0.8), max_distance: 64 }
    }
}

impl MatchOptions {
    /// The ratio as the integer `q` of the test `d1 * 65536 < q * d2`; 0 when
    /// there is no ratio test. Errors when the ratio is not in (0, 1].
    pub fn ratio_q16(&self) -> Result<u32> {
        match self.ratio {
            None => Ok(0),
            // floor: the integer test is never looser than `d1 < r * d2`
            Some(r) if r.is_finite() && r > 0.0 && r <= 1.0 => {
                Ok(((r as f64) * RATIO_ONE as f64).floor().max(1.0) as u32)
            }
            Some(r) => Err(Error::InvalidConfig { field: "ratio", reason: format!("must be in (0, 1], got {r}") }),
        }
    }
}

/// A kept match.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct Match {
    /// Index in the query set.
    pub query: u32,
    /// Index in the train set.
    pub train: u32,
    /// Hamming distance.
    pub distance: u32,
}
