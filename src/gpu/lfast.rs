//! SPEC 8 (the L-FAST corner test) on the GPU: shaders/lfast.wgsl, mirroring
//! src/cpu/lfast.rs. `edges` (+ `mask` when `Params::use_mask` is 1) ->
//! `cand` (1 = candidate), all levels in one dispatch.

use super::kernel::{Binding, PARAMS, Slot, b};
use super::pass::{Groups, simple_pass};

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/lfast.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] =
    &[PARAMS, b(1, "edges", Slot::Read), b(2, "mask", Slot::Read), b(3, "cand", Slot::ReadWrite)];

simple_pass! {
    /// The L-FAST candidate pass.
    LfastPass = "lfast" {
        "edges" = edges,
        "mask" = mask,
        "cand" = cand,
    }
    dispatch |b| Groups::Direct(b.layout.column_groups())
}
