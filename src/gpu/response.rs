//! SPEC 9 (Harris response) on the GPU: shaders/response.wgsl, mirroring
//! src/cpu/response.rs bit for bit. `cand` + `denoised` -> `resp` (f32 bits at
//! candidates, 0 elsewhere), all levels in one dispatch.

use super::kernel::{Binding, PARAMS, Slot, b};
use super::pass::{Groups, simple_pass};

/// The shader source (without the common prelude).
/// (with shaders/cand_list.wgsl, the candidate work list it shares).
pub const SOURCE: &str =
    concat!(include_str!("../../shaders/response.wgsl"), include_str!("../../shaders/cand_list.wgsl"));
/// Its bindings.
pub const BINDINGS: &[Binding] =
    &[PARAMS, b(1, "cand", Slot::Read), b(2, "denoised", Slot::Read), b(3, "resp", Slot::ReadWrite)];

simple_pass! {
    /// The Harris response pass.
    ResponsePass = "response" {
        "cand" = cand,
        "denoised" = denoised,
        "resp" = resp,
    }
    dispatch |b| Groups::Direct(b.layout.column_groups());
    // 0 at every pixel that is no candidate (a memset: cheaper than a store
    // per pixel from the shader)
    clear resp
}
