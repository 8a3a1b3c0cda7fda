//! SPEC 9 (corner NMS) on the GPU: shaders/corner_nms.wgsl, mirroring
//! src/cpu/corner_nms.rs. The candidate list + `cand` + `resp` -> survivors
//! appended to `corners` as [`GpuKeypoint`](super::GpuKeypoint)s, counted in
//! `counters[counter::CORNERS]`, in no particular order
//! ([`SelectPass`](super::select::SelectPass) orders them); one indirect
//! dispatch over the list ([`LfastPass`](super::lfast::LfastPass) appends it;
//! [`CandListPass`](super::cand_list::CandListPass) builds it from a `cand`
//! plane).

use super::buffers::indirect;
use super::kernel::{Binding, PARAMS, Slot, b};
use super::pass::{Groups, simple_pass};

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/corner_nms.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] = &[
    PARAMS,
    b(1, "cand", Slot::Read),
    b(2, "cand_list", Slot::Read),
    b(3, "resp", Slot::Read),
    b(4, "corners", Slot::ReadWrite),
    b(5, "counters", Slot::ReadWrite),
];

// The append cursor starts at 0: the lfast pass (or the candidate-list pass,
// run alone) clears the counters.
simple_pass! {
    /// The corner NMS pass.
    CornerNmsPass = "corner_nms" {
        "cand" = cand,
        "cand_list" = cand_list,
        "resp" = resp,
        "corners" = corners,
        "counters" = counters,
    }
    dispatch |b| Groups::Indirect(indirect::CANDS)
}
