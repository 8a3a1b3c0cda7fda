//! SPEC 5 on the GPU: shaders/local_threshold.wgsl, mirroring
//! src/cpu/local_threshold.rs. `m` + `grid` -> `windows` (min, max, lower
//! median, V3 per window), one workgroup per window, all levels in one dispatch.

use super::kernel::{Binding, PARAMS, Slot, b};
use super::pass::{Groups, simple_pass};

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/local_threshold.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] =
    &[PARAMS, b(1, "m", Slot::Read), b(2, "grid", Slot::Read), b(3, "windows", Slot::ReadWrite)];

simple_pass! {
    /// The window statistics pass.
    LocalThresholdPass = "local_threshold" {
        "m" = m,
        "grid" = grid,
        "windows" = windows,
    }
    dispatch |b| {
        let (nx, ny) = b.layout.max_windows();
        Groups::Direct([nx, ny, b.layout.n_levels()])
    }
}
