//! SPEC 9 (corner NMS) on the GPU: shaders/corner_nms.wgsl, mirroring
//! src/cpu/corner_nms.rs. `cand` + `resp` -> survivors appended to `corners`
//! as [`GpuKeypoint`](super::GpuKeypoint)s, counted in `counters[counter::CORNERS]`,
//! in no particular order ([`SelectPass`](super::select::SelectPass) orders them).

use super::kernel::{Binding, PARAMS, Slot, b};
use super::pass::{Groups, simple_pass};

/// The shader source (without the common prelude).
/// (with shaders/cand_list.wgsl, the candidate work list it shares).
pub const SOURCE: &str =
    concat!(include_str!("../../shaders/corner_nms.wgsl"), include_str!("../../shaders/cand_list.wgsl"));
/// Its bindings.
pub const BINDINGS: &[Binding] = &[
    PARAMS,
    b(1, "cand", Slot::Read),
    b(2, "resp", Slot::Read),
    b(3, "corners", Slot::ReadWrite),
    b(4, "counters", Slot::ReadWrite),
];

// The append cursor (and the other counters of the frame) start at 0.
simple_pass! {
    /// The corner NMS pass.
    CornerNmsPass = "corner_nms" {
        "cand" = cand,
        "resp" = resp,
        "corners" = corners,
        "counters" = counters,
    }
    dispatch |b| Groups::Direct(b.layout.column_groups()); clear counters
}
