//! SPEC 1 on the GPU: shaders/median.wgsl, mirroring src/cpu/median.rs.
//! `gray` -> `denoised`, all levels in one dispatch.

use super::buffers::Buffers;
use super::kernel::{Binding, Kernel, PARAMS, Slot, b};
use super::pass::Pass;
use crate::error::Result;

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/median.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] = &[PARAMS, b(1, "src", Slot::Read), b(2, "dst", Slot::ReadWrite)];

/// The flagged-median pass.
#[derive(Debug)]
pub struct MedianPass {
    kernel: Kernel,
}

impl Pass for MedianPass {
    type Bound = wgpu::BindGroup;
    const NAME: &'static str = "median";

    fn new(device: &wgpu::Device) -> Self {
        Self { kernel: Kernel::new(device, Self::NAME, SOURCE, "main", BINDINGS) }
    }

    fn bind(&self, device: &wgpu::Device, b: &Buffers) -> Result<wgpu::BindGroup> {
        self.kernel.bind(device, &[("P", &b.params), ("src", &b.gray), ("dst", &b.denoised)])
    }

    fn record(&self, pass: &mut wgpu::ComputePass<'_>, bound: &wgpu::BindGroup, b: &Buffers) {
        self.kernel.dispatch(pass, bound, b.layout.pixel_groups());
    }
}
