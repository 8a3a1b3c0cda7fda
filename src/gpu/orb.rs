//! SPEC 11 description on the GPU: shaders/orb.wgsl, mirroring src/cpu/orb.rs.
//! Per final keypoint (indirect dispatch over `counters[KEYPOINTS]`): the
//! 256-bit rBRIEF descriptor on the `smooth` level into `descriptors[8i..8i+8]`,
//! with the pattern of the keypoint's bin, or rotated per keypoint by its
//! angle when `orientation_bins` is 0.

use super::buffers::indirect;
use super::kernel::{Binding, PARAMS, Slot, b};
use super::pass::{Groups, simple_pass};

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/orb.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] = &[
    PARAMS,
    b(1, "smoothed", Slot::Read),
    b(2, "keypoints", Slot::Read),
    b(3, "counters", Slot::Read),
    b(4, "patterns", Slot::Read),
    b(5, "descriptors", Slot::ReadWrite),
];

simple_pass! {
    /// The descriptor pass.
    OrbPass = "orb" {
        "smoothed" = smooth,
        "keypoints" = keypoints,
        "counters" = counters,
        "patterns" = patterns,
        "descriptors" = descriptors,
    }
    dispatch |b| Groups::Indirect(indirect::KEYPOINT_GROUPS)
}
