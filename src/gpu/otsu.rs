//! SPEC 4 (second half) on the GPU: shaders/otsu.wgsl, mirroring
//! src/cpu/otsu.rs with the same exact 192-bit comparison (in u32 limbs).
//! `hist` -> `otsu[l]` = T1 = k + 1, or 0 when the level has no edges.

use super::kernel::{Binding, PARAMS, Slot, b};
use super::pass::{Groups, simple_pass};

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/otsu.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] = &[PARAMS, b(1, "hist", Slot::Read), b(2, "otsu", Slot::ReadWrite)];

simple_pass! {
    /// Otsu's threshold per level: one workgroup of 256 invocations per level.
    OtsuPass = "otsu" {
        "hist" = hist,
        "otsu" = otsu,
    }
    dispatch |b| Groups::Direct([b.layout.n_levels(), 1, 1])
}
