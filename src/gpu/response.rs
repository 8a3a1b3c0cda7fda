//! SPEC 9 (Harris response) on the GPU: shaders/response.wgsl, mirroring
//! src/cpu/response.rs bit for bit. `cand` + `denoised` -> `resp` (f32 bits at
//! candidates, 0 elsewhere), all levels in one dispatch.

use super::buffers::Buffers;
use super::kernel::{Binding, Kernel, PARAMS, Slot, b};
use super::pass::Pass;
use crate::error::Result;

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/response.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] = &[
    PARAMS,
    b(1, "cand", Slot::Read),
    b(2, "denoised", Slot::Read),
    b(3, "resp", Slot::ReadWrite),
];

/// The Harris response pass.
#[derive(Debug)]
pub struct ResponsePass {
    kernel: Kernel,
}

impl Pass for ResponsePass {
    type Bound = wgpu::BindGroup;
    const NAME: &'static str = "response";

    fn new(device: &wgpu::Device) -> Self {
        Self {
            kernel: Kernel::new(device, Self::NAME, SOURCE, "main", BINDINGS),
        }
    }

    fn bind(&self, device: &wgpu::Device, b: &Buffers) -> Result<wgpu::BindGroup> {
        self.kernel.bind(
            device,
            &[
                ("P", &b.params),
                ("cand", &b.cand),
                ("denoised", &b.denoised),
                ("resp", &b.resp),
            ],
        )
    }

    fn record(&self, pass: &mut wgpu::ComputePass<'_>, bound: &wgpu::BindGroup, b: &Buffers) {
        self.kernel.dispatch(pass, bound, b.layout.pixel_groups());
    }
}
