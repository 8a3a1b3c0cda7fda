//! SPEC 8 (the L-FAST corner test) on the GPU: shaders/lfast.wgsl, mirroring
//! src/cpu/lfast.rs. `edges` (+ `mask` when `Params::use_mask` is 1) ->
//! `cand` (1 = candidate), all levels in one dispatch.

use super::buffers::Buffers;
use super::kernel::{Binding, Kernel, PARAMS, Slot, b};
use super::pass::Pass;
use crate::error::Result;

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/lfast.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] = &[
    PARAMS,
    b(1, "edges", Slot::Read),
    b(2, "mask", Slot::Read),
    b(3, "cand", Slot::ReadWrite),
];

/// The L-FAST candidate pass.
#[derive(Debug)]
pub struct LfastPass {
    kernel: Kernel,
}

impl Pass for LfastPass {
    type Bound = wgpu::BindGroup;
    const NAME: &'static str = "lfast";

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
                ("edges", &b.edges),
                ("mask", &b.mask),
                ("cand", &b.cand),
            ],
        )
    }

    fn record(&self, pass: &mut wgpu::ComputePass<'_>, bound: &wgpu::BindGroup, b: &Buffers) {
        self.kernel.dispatch(pass, bound, b.layout.pixel_groups());
    }
}
