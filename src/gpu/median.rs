//! SPEC 1 on the GPU: shaders/median.wgsl, mirroring src/cpu/median.rs.
//! `gray` -> `denoised`, all levels in one dispatch.

use super::kernel::{Binding, PARAMS, Slot, b};
use super::pass::{Groups, simple_pass};

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/median.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] =
    &[PARAMS, b(1, "src", Slot::Read), b(2, "dst", Slot::ReadWrite), b(3, "src4", Slot::Read)];

simple_pass! {
    /// The flagged-median pass.
    MedianPass = "median" {
        "src" = gray,
        "src4" = gray,
        "dst" = denoised,
    }
    dispatch |b| Groups::Direct(b.layout.quad_groups())
}
