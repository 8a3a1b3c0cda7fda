//! SPEC 9 (Harris response) on the GPU: shaders/response.wgsl, mirroring
//! src/cpu/response.rs bit for bit. The candidate list (`cand_list`, see
//! [`CandListPass`](super::cand_list::CandListPass)) + `denoised` -> `resp`
//! (f32 bits at candidates, 0 elsewhere), all levels in one indirect dispatch.

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
    /// The Harris response pass.
    ResponsePass = "response" {
        "cand_list" = cand_list,
        "counters" = counters,
        "denoised" = denoised,
        "resp" = resp,
    }
    dispatch |b| Groups::Indirect(indirect::CANDS);
    // 0 at every pixel that is no candidate (a memset: cheaper than a store
    // per pixel from the shader)
    clear resp
}
