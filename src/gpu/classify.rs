//! SPEC 6 on the GPU: shaders/classify.wgsl, mirroring src/cpu/classify.rs.
//! `m`, `nms`, `otsu`, `windows`, `grid` -> `classes`, all levels in one dispatch.

use super::kernel::{Binding, PARAMS, Slot, b};
use super::pass::{Groups, simple_pass};

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/classify.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] = &[
    PARAMS,
    b(1, "m", Slot::Read),
    b(2, "nms", Slot::Read),
    b(3, "otsu", Slot::Read),
    b(4, "windows", Slot::Read),
    b(5, "grid", Slot::Read),
    b(6, "classes", Slot::ReadWrite),
];

simple_pass! {
    /// The double dual threshold pass.
    ClassifyPass = "classify" {
        "m" = m,
        "nms" = nms,
        "otsu" = otsu,
        "windows" = windows,
        "grid" = grid,
        "classes" = classes,
    }
    dispatch |b| Groups::Direct(b.layout.quad_groups())
}
