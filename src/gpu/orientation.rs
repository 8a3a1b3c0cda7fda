//! SPEC 11 orientation on the GPU: shaders/orientation.wgsl, mirroring
//! src/cpu/orientation.rs. Per final keypoint (indirect dispatch over
//! `counters[KEYPOINTS]`): m10, m01 on the unsmoothed `gray` level, the
//! orientation bin, and an approximate angle, written back into `keypoints`.

use super::buffers::indirect;
use super::kernel::{Binding, PARAMS, Slot, b};
use super::pass::{Groups, simple_pass};

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/orientation.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] = &[
    PARAMS,
    b(1, "gray", Slot::Read),
    b(2, "keypoints", Slot::ReadWrite),
    b(3, "counters", Slot::Read),
    b(4, "angle_bounds", Slot::Read),
];

simple_pass! {
    /// The orientation pass.
    OrientationPass = "orientation" {
        "gray" = gray,
        "keypoints" = keypoints,
        "counters" = counters,
        "angle_bounds" = angle_bounds,
    }
    dispatch |b| Groups::Indirect(indirect::KEYPOINTS)
}
