//! SPEC 9 (Harris response) on the GPU: shaders/response.wgsl, mirroring
//! src/cpu/response.rs bit for bit. The candidate list (`cand_list`, see
//! [`CandListPass`](super::cand_list::CandListPass)) + `denoised` -> `resp`
//! (f32 bits at candidates, 0 elsewhere), all levels in one indirect dispatch
//! after a dispatch that zeroes `resp`.

use super::buffers::{Buffers, indirect};
use super::kernel::{Binding, Kernel, PARAMS, Slot, b};
use super::pass::Pass;
use crate::error::Result;

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

/// The entry points in dispatch order with their bindings: `clear` zeroes
/// `resp` (its memory is shared with `labels` and `edge_list`, see
/// [`footprint`](super::footprint)), `main` writes the candidates' responses.
pub const ENTRIES: [(&str, &[Binding]); 2] = [("clear", CLEAR_BINDINGS), ("main", BINDINGS)];
const CLEAR_BINDINGS: &[Binding] = &[PARAMS, BINDINGS[4]];

/// Words `clear` zeroes per workgroup (`CLEAR_GROUP` in the shader).
pub const CLEAR_GROUP: u32 = 2048;

/// The Harris response pass.
#[derive(Debug)]
pub struct ResponsePass {
    /// One kernel per entry of [`ENTRIES`], same order.
    kernels: Vec<Kernel>,
}

/// One bind group per kernel.
#[derive(Debug)]
pub struct ResponseBound {
    groups: Vec<wgpu::BindGroup>,
}

impl Pass for ResponsePass {
    type Bound = ResponseBound;
    const NAME: &'static str = "response";

    fn new(device: &wgpu::Device) -> Self {
        let module = super::kernel::compile(device, Self::NAME, SOURCE);
        let kernels = ENTRIES
            .iter()
            .map(|(e, bindings)| Kernel::from_module(device, &format!("{}::{e}", Self::NAME), &module, e, bindings))
            .collect();
        Self { kernels }
    }

    fn bind(&self, device: &wgpu::Device, b: &Buffers) -> Result<ResponseBound> {
        let buffers = [
            ("P", &b.params),
            ("cand_list", &b.cand_list),
            ("counters", &b.counters),
            ("denoised", &b.denoised),
            ("resp", &b.resp),
        ];
        let groups = self.kernels.iter().map(|k| k.bind_from(device, &buffers)).collect::<Result<Vec<_>>>()?;
        Ok(ResponseBound { groups })
    }

    fn record(&self, pass: &mut wgpu::ComputePass<'_>, bound: &ResponseBound, b: &Buffers) {
        // 0 at every pixel that is no candidate (corner NMS and snap read the
        // neighbours), then the candidates' responses
        let clear = b.layout.word_groups(b.layout.total_px, CLEAR_GROUP);
        self.kernels[0].dispatch(pass, &bound.groups[0], clear);
        self.kernels[1].dispatch_indirect(pass, &bound.groups[1], &b.indirect, indirect::CANDS);
    }
}
