//! SPEC 7 rules 1 and 2 on the GPU: shaders/rules.wgsl, mirroring
//! src/cpu/rules.rs. `classes` -> `ruled` (NONE, WEAK, STRONG), all levels in
//! one dispatch.

use super::buffers::Buffers;
use super::kernel::{Binding, Kernel, PARAMS, Slot, b};
use super::pass::Pass;
use crate::error::Result;

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/rules.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] = &[
    PARAMS,
    b(1, "classes", Slot::Read),
    b(2, "ruled", Slot::ReadWrite),
];

/// The isolated-edge suppression pass (rules 1 and 2).
#[derive(Debug)]
pub struct RulesPass {
    kernel: Kernel,
}

impl Pass for RulesPass {
    type Bound = wgpu::BindGroup;
    const NAME: &'static str = "rules";

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
                ("classes", &b.classes),
                ("ruled", &b.ruled),
            ],
        )
    }

    fn record(&self, pass: &mut wgpu::ComputePass<'_>, bound: &wgpu::BindGroup, b: &Buffers) {
        self.kernel.dispatch(pass, bound, b.layout.pixel_groups());
    }
}
