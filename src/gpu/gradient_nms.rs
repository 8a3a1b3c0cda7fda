//! SPEC 2-3 on the GPU in one pass: shaders/gradient_nms.wgsl, equal to
//! [`gradient`](super::gradient) -> [`nms`](super::nms) (and to
//! src/cpu/fused.rs's rows) without writing gx, gy and S. `denoised` -> `m`,
//! `nms`, all levels in one dispatch. SPEC 4's histogram is counted by
//! [`local_threshold`](super::local_threshold)'s cells.

use super::kernel::{Binding, PARAMS, Slot, b};
use super::pass::{Groups, simple_pass};

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/gradient_nms.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] = &[
    PARAMS,
    b(1, "denoised", Slot::Read),
    b(2, "m", Slot::ReadWrite),
    b(3, "nms", Slot::ReadWrite),
    b(4, "denoised4", Slot::Read),
];

simple_pass! {
    /// The fused gradient and NMS pass.
    GradientNmsPass = "gradient_nms" {
        "denoised" = denoised,
        "denoised4" = denoised,
        "m" = m,
        "nms" = nms,
    }
    dispatch |b| Groups::Direct(b.layout.quad_groups())
}
