//! SPEC 3 on the GPU: shaders/nms.wgsl, mirroring src/cpu/nms.rs.
//! `gx`, `gy`, `s` -> `nms` (1 = survivor), all levels in one dispatch.

use super::buffers::Buffers;
use super::kernel::Kernel;
use super::kernel::{Binding, PARAMS, Slot, b};
use super::pass::Pass;
use crate::error::Result;

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/nms.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] =
    &[PARAMS, b(1, "gx", Slot::Read), b(2, "gy", Slot::Read), b(3, "s", Slot::Read), b(4, "nms", Slot::ReadWrite)];

/// The gradient non-maximum suppression pass. It binds the [`StagePlanes`](super::buffers::StagePlanes):
/// give it buffers made by [`Buffers::with_stage_planes`].
#[derive(Debug)]
pub struct NmsPass {
    kernel: Kernel,
}

impl Pass for NmsPass {
    type Bound = wgpu::BindGroup;
    const NAME: &'static str = "nms";

    fn new(device: &wgpu::Device) -> Self {
        Self { kernel: Kernel::new(device, Self::NAME, SOURCE, "main", BINDINGS) }
    }

    fn bind(&self, device: &wgpu::Device, b: &Buffers) -> Result<wgpu::BindGroup> {
        let st = b.stage_planes()?;
        self.kernel.bind(device, &[("P", &b.params), ("gx", &st.gx), ("gy", &st.gy), ("s", &st.s), ("nms", &b.nms)])
    }

    fn record(&self, pass: &mut wgpu::ComputePass<'_>, bound: &wgpu::BindGroup, b: &Buffers) {
        self.kernel.dispatch(pass, bound, b.layout.column_groups());
    }
}
