//! SPEC 4 (first half) on the GPU: shaders/histogram.wgsl, mirroring
//! src/cpu/histogram.rs. `m` -> `hist` (256 bins per level), all levels in one dispatch.

use super::buffers::Buffers;
use super::kernel::{Binding, Kernel, PARAMS, Slot, b};
use super::pass::Pass;
use crate::error::Result;

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/histogram.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] = &[PARAMS, b(1, "m", Slot::Read), b(2, "hist", Slot::ReadWrite)];

/// The magnitude histogram pass.
#[derive(Debug)]
pub struct HistogramPass {
    kernel: Kernel,
}

impl Pass for HistogramPass {
    type Bound = wgpu::BindGroup;
    const NAME: &'static str = "histogram";

    fn new(device: &wgpu::Device) -> Self {
        Self {
            kernel: Kernel::new(device, Self::NAME, SOURCE, "main", BINDINGS),
        }
    }

    fn bind(&self, device: &wgpu::Device, b: &Buffers) -> Result<wgpu::BindGroup> {
        self.kernel
            .bind(device, &[("P", &b.params), ("m", &b.m), ("hist", &b.hist)])
    }

    fn record(&self, pass: &mut wgpu::ComputePass<'_>, bound: &wgpu::BindGroup, b: &Buffers) {
        self.kernel.dispatch(pass, bound, b.layout.pixel_groups());
    }

    /// The bins are accumulated with atomics: start from zero every frame.
    fn prepare(&self, encoder: &mut wgpu::CommandEncoder, b: &Buffers) {
        encoder.clear_buffer(&b.hist, 0, None);
    }
}
