//! SPEC 11 smoothing on the GPU: shaders/blur.wgsl, mirroring src/cpu/blur.rs.
//! `gray` -> `smooth` in one quad pass over all levels (the horizontal sums
//! stay in registers), on the tiles marked in `blur_tiles` only (those the
//! descriptors read; the select pass marks them).

use super::kernel::{Binding, PARAMS, Slot, b};
use super::pass::{Groups, simple_pass};

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/blur.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] =
    &[PARAMS, b(1, "gray", Slot::Read), b(2, "smoothed", Slot::ReadWrite), b(3, "blur_tiles", Slot::Read)];

simple_pass! {
    /// The 7x7 Gaussian blur pass.
    BlurPass = "blur" {
        "gray" = gray,
        "smoothed" = smooth,
        "blur_tiles" = blur_tiles,
    }
    dispatch |b| Groups::Direct(b.layout.quad_groups())
}
