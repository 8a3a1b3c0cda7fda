//! SPEC 2-4 (first half) on the GPU in one pass: shaders/gradient_nms.wgsl,
//! equal to [`gradient`](super::gradient) -> [`nms`](super::nms) ->
//! [`histogram`](super::histogram) (and to src/cpu/fused.rs's rows) without
//! writing gx, gy and S. `denoised` -> `m`, `nms`, `hist`, all levels in one dispatch.

use super::kernel::{Binding, PARAMS, Slot, b};
use super::pass::{Groups, simple_pass};

/// The shader source (without the common prelude).
/// (with shaders/histogram_bins.wgsl, the M8 counting it shares).
pub const SOURCE: &str =
    concat!(include_str!("../../shaders/gradient_nms.wgsl"), include_str!("../../shaders/histogram_bins.wgsl"));
/// Its bindings.
pub const BINDINGS: &[Binding] = &[
    PARAMS,
    b(1, "denoised", Slot::Read),
    b(2, "m", Slot::ReadWrite),
    b(3, "nms", Slot::ReadWrite),
    b(4, "hist", Slot::ReadWrite),
];

// The bins are accumulated with atomics: start from zero every frame.
simple_pass! {
    /// The fused gradient, NMS and magnitude histogram pass.
    GradientNmsPass = "gradient_nms" {
        "denoised" = denoised,
        "m" = m,
        "nms" = nms,
        "hist" = hist,
    }
    dispatch |b| Groups::Direct(b.layout.column_groups()); clear hist
}
