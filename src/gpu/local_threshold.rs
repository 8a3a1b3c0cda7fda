//! SPEC 5 on the GPU: shaders/local_threshold.wgsl, mirroring
//! src/cpu/local_threshold.rs. `m` + `grid` -> `windows` (min, max, lower
//! median, V3 per window), one workgroup per window, all levels in one dispatch.

use super::buffers::Buffers;
use super::kernel::{Binding, Kernel, PARAMS, Slot, b};
use super::pass::Pass;
use crate::error::Result;

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/local_threshold.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] = &[
    PARAMS,
    b(1, "m", Slot::Read),
    b(2, "grid", Slot::Read),
    b(3, "windows", Slot::ReadWrite),
];

/// The window statistics pass.
#[derive(Debug)]
pub struct LocalThresholdPass {
    kernel: Kernel,
}

impl Pass for LocalThresholdPass {
    type Bound = wgpu::BindGroup;
    const NAME: &'static str = "local_threshold";

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
                ("m", &b.m),
                ("grid", &b.grid),
                ("windows", &b.windows),
            ],
        )
    }

    fn record(&self, pass: &mut wgpu::ComputePass<'_>, bound: &wgpu::BindGroup, b: &Buffers) {
        let (nx, ny) = b.layout.max_windows();
        self.kernel
            .dispatch(pass, bound, [nx, ny, b.layout.n_levels()]);
    }
}
