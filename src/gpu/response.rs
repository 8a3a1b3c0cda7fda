//! SPEC 9 (Harris response) on the GPU: shaders/response.wgsl, mirroring
//! src/cpu/response.rs bit for bit. The candidate list (`cand_list`, see
//! [`CandListPass`](super::cand_list::CandListPass)) + `denoised` -> `resp`
//! (f32 bits at the candidates), all levels in one indirect dispatch over
//! the list.
//!
//! `resp` shares its memory with `labels` and `edge_list` (see
//! [`footprint`](super::footprint)), and its words at pixels that are no
//! candidate keep whatever those stages left: its only reader, corner NMS,
//! reads the responses of candidates (`cand` bits) only. Zeroing the
//! rest in a dispatch of its own took ~0.9 ms of a KITTI frame's ~33 on
//! lavapipe.

use super::buffers::indirect;
use super::kernel::{Binding, PARAMS, Slot, b};
use super::pass::{Groups, simple_pass};

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/response.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] = &[
    PARAMS,
    b(1, "cand_list", Slot::Read),
    b(2, "counters", Slot::Read),
    b(3, "denoised", Slot::Read),
    b(4, "resp", Slot::ReadWrite),
];

simple_pass! {
    /// The Harris response of every listed candidate.
    ResponsePass = "response" {
        "cand_list" = cand_list,
        "counters" = counters,
        "denoised" = denoised,
        "resp" = resp,
    }
    dispatch |b| Groups::Indirect(indirect::CANDS)
}
