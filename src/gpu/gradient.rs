//! SPEC 2 on the GPU: shaders/gradient.wgsl, mirroring src/cpu/gradient.rs.
//! `denoised` -> `gx`, `gy` (i32 bits), `s`, `m`, all levels in one dispatch.

use super::buffers::Buffers;
use super::kernel::Kernel;
use super::kernel::{Binding, PARAMS, Slot, b};
use super::pass::Pass;
use crate::error::Result;

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/gradient.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] = &[
    PARAMS,
    b(1, "denoised", Slot::Read),
    b(2, "gx", Slot::ReadWrite),
    b(3, "gy", Slot::ReadWrite),
    b(4, "s", Slot::ReadWrite),
    b(5, "m", Slot::ReadWrite),
];

/// The LSD gradient pass. It binds the [`StagePlanes`](super::buffers::StagePlanes):
/// give it buffers made by [`Buffers::with_stage_planes`].
#[derive(Debug)]
pub struct GradientPass {
    kernel: Kernel,
}

impl Pass for GradientPass {
    type Bound = wgpu::BindGroup;
    const NAME: &'static str = "gradient";

    fn new(device: &wgpu::Device) -> Self {
        Self { kernel: Kernel::new(device, Self::NAME, SOURCE, "main", BINDINGS) }
    }

    fn bind(&self, device: &wgpu::Device, b: &Buffers) -> Result<wgpu::BindGroup> {
        let st = b.stage_planes()?;
        self.kernel.bind(
            device,
            &[("P", &b.params), ("denoised", &b.denoised), ("gx", &st.gx), ("gy", &st.gy), ("s", &st.s), ("m", &b.m)],
        )
    }

    fn record(&self, pass: &mut wgpu::ComputePass<'_>, bound: &wgpu::BindGroup, b: &Buffers) {
        self.kernel.dispatch(pass, bound, b.layout.column_groups());
    }
}
