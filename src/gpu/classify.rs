//! SPEC 6 on the GPU: shaders/classify.wgsl, mirroring src/cpu/classify.rs.
//! `m`, `nms`, `otsu`, `windows`, `grid` -> `classes`, all levels in one dispatch.

use super::buffers::Buffers;
use super::kernel::{Binding, Kernel, PARAMS, Slot, b};
use super::pass::Pass;
use crate::error::Result;

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/classify.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] = &[
    PARAMS,
    b(1, "m", Slot::Read),
    b(2, "nms", Slot::Read),
    b(3, "otsu", Slot::Read),
    b(4, "windows", Slot::Read),
    b(5, "grid", Slot::Read),
    b(6, "classes", Slot::ReadWrite),
];

/// The double dual threshold pass.
#[derive(Debug)]
pub struct ClassifyPass {
    kernel: Kernel,
}

impl Pass for ClassifyPass {
    type Bound = wgpu::BindGroup;
    const NAME: &'static str = "classify";

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
                ("nms", &b.nms),
                ("otsu", &b.otsu),
                ("windows", &b.windows),
                ("grid", &b.grid),
                ("classes", &b.classes),
            ],
        )
    }

    fn record(&self, pass: &mut wgpu::ComputePass<'_>, bound: &wgpu::BindGroup, b: &Buffers) {
        self.kernel.dispatch(pass, bound, b.layout.pixel_groups());
    }
}
