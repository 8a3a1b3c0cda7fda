//! OpenCV-style keypoints and descriptors.

use serde::{Deserialize, Serialize};

/// A detected feature with the fields and meaning of OpenCV's `cv::KeyPoint`.
///
/// - `pt`: position in input-image pixels (x right, y down).
/// - `size`: diameter of the meaningful neighbourhood (31 * scale for ORB/L-FAST, 7 for FAST).
/// - `angle`: orientation in degrees, [0, 360), or -1 when not computed.
/// - `response`: the strength used for ranking (Harris score, or FAST score).
/// - `octave`: pyramid level the point was found on.
/// - `class_id`: -1 (unused, as OpenCV's detectors leave it).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct KeyPoint {
    /// Position in input-image pixels.
    pub pt: glam::Vec2,
    /// Neighbourhood diameter in input-image pixels.
    pub size: f32,
    /// Orientation in degrees, [0, 360), or -1.
    pub angle: f32,
    /// Ranking strength.
    pub response: f32,
    /// Pyramid level.
    pub octave: i32,
    /// Object class, -1 if unused.
    pub class_id: i32,
}

impl KeyPoint {
    /// A keypoint at `(x, y)` with everything else as OpenCV's defaults
    /// (`angle = -1`, `response = 0`, `octave = 0`, `class_id = -1`).
    pub fn new(x: f32, y: f32, size: f32) -> Self {
        Self { pt: glam::Vec2::new(x, y), size, angle: -1.0, response: 0.0, octave: 0, class_id: -1 }
    }
}

/// A 256-bit binary descriptor: bit `i` of byte `j` is test `8*j + i` (SPEC 11).
pub type Descriptor = [u8; 32];

/// Hamming distance between two descriptors.
///
/// ```
/// assert_eq!(lfast::hamming(&[0u8; 32], &[0xffu8; 32]), 256);
/// ```
pub fn hamming(a: &Descriptor, b: &Descriptor) -> u32 {
    a.iter().zip(b).map(|(x, y)| (x ^ y).count_ones()).sum()
}
