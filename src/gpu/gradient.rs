//! SPEC 2 on the GPU: shaders/gradient.wgsl, mirroring src/cpu/gradient.rs.
//! `denoised` -> `gx`, `gy` (i32 bits), `s`, `m`, all levels in one dispatch.

use super::kernel::{Binding, PARAMS, Slot, b};
use super::pass::{Groups, simple_pass};

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/gradient.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] = &[
    PARAMS,
    b(1, "denoised", Slot::Read),
    b(2, "gx", Slot::ReadWrite),
    b(3, "gy", Slot::ReadWrite),
    b(4, "s", Slot::ReadWrite),
    b(5, "m", Slot::ReadWrite),
];

simple_pass! {
    /// The LSD gradient pass.
    GradientPass = "gradient" {
        "denoised" = denoised,
        "gx" = gx,
        "gy" = gy,
        "s" = s,
        "m" = m,
    }
    dispatch |b| Groups::Direct(b.layout.column_groups())
}
