//! SPEC 3 on the GPU: shaders/nms.wgsl, mirroring src/cpu/nms.rs.
//! `gx`, `gy`, `s` -> `nms` (1 = survivor), all levels in one dispatch.

use super::kernel::{Binding, PARAMS, Slot, b};
use super::pass::{Groups, simple_pass};

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/nms.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] =
    &[PARAMS, b(1, "gx", Slot::Read), b(2, "gy", Slot::Read), b(3, "s", Slot::Read), b(4, "nms", Slot::ReadWrite)];

simple_pass! {
    /// The gradient non-maximum suppression pass.
    NmsPass = "nms" {
        "gx" = gx,
        "gy" = gy,
        "s" = s,
        "nms" = nms,
    }
    dispatch |b| Groups::Direct(b.layout.column_groups())
}
