//! SPEC 4 (second half) on the GPU: shaders/otsu.wgsl, mirroring
//! src/cpu/otsu.rs with the same exact 192-bit comparison (in u32 limbs).
//! `hist` -> `otsu[l]` = T1 = k + 1, or 0 when the level has no edges.

use super::buffers::Buffers;
use super::kernel::{Binding, Kernel, PARAMS, Slot, b};
use super::pass::Pass;
use crate::error::Result;

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/otsu.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] = &[
    PARAMS,
    b(1, "hist", Slot::Read),
    b(2, "otsu", Slot::ReadWrite),
];

/// Otsu's threshold per level: one workgroup of 256 invocations per level.
#[derive(Debug)]
pub struct OtsuPass {
    kernel: Kernel,
}

impl Pass for OtsuPass {
    type Bound = wgpu::BindGroup;
    const NAME: &'static str = "otsu";

    fn new(device: &wgpu::Device) -> Self {
        Self {
            kernel: Kernel::new(device, Self::NAME, SOURCE, "main", BINDINGS),
        }
    }

    fn bind(&self, device: &wgpu::Device, b: &Buffers) -> Result<wgpu::BindGroup> {
        self.kernel.bind(
            device,
            &[("P", &b.params), ("hist", &b.hist), ("otsu", &b.otsu)],
        )
    }

    fn record(&self, pass: &mut wgpu::ComputePass<'_>, bound: &wgpu::BindGroup, b: &Buffers) {
        self.kernel
            .dispatch(pass, bound, [b.layout.n_levels(), 1, 1]);
    }
}
