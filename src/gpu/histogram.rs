//! SPEC 4 (first half) on the GPU: shaders/histogram.wgsl, mirroring
//! src/cpu/histogram.rs. `m` -> `hist` (256 bins per level), all levels in one
//! dispatch. The pipeline's histogram comes from
//! [`local_threshold`](super::local_threshold)'s cells; this pass is the
//! per-stage reference the tests compare it with.

use super::kernel::{Binding, PARAMS, Slot, b};
use super::pass::{Groups, simple_pass};

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/histogram.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] = &[PARAMS, b(1, "m", Slot::Read), b(2, "hist", Slot::ReadWrite)];

// The bins are accumulated with atomics: start from zero every frame.
simple_pass! {
    /// The magnitude histogram pass.
    HistogramPass = "histogram" {
        "m" = m,
        "hist" = hist,
    }
    dispatch |b| Groups::Direct(b.layout.column_groups()); clear hist
}
