//! Corners snapped to the Harris maximum nearby (docs/quality.md) on the GPU:
//! shaders/snap.wgsl, compiled after shaders/response.wgsl so that the Harris
//! response has one definition, mirroring src/cpu/snap.rs bit for bit. Runs
//! between corner NMS and the cap, on the `corners` list in place; does
//! nothing when `snap_radius` is 0.

use super::buffers::Buffers;
use super::kernel::{Binding, Kernel, PARAMS, Slot, b};
use super::pass::Pass;
use crate::error::Result;

/// The shader source (without the common prelude): the response shader, then the snap entry point.
pub const SOURCE: &str = concat!(include_str!("../../shaders/response.wgsl"), include_str!("../../shaders/snap.wgsl"));
/// Its bindings (those of the response shader it is compiled with, then its own).
pub const BINDINGS: &[Binding] = &[
    PARAMS,
    b(1, "cand_list", Slot::Read),
    b(2, "counters", Slot::Read),
    b(3, "denoised", Slot::Read),
    b(4, "resp", Slot::ReadWrite),
    b(5, "corners", Slot::ReadWrite),
    b(6, "mask", Slot::Read),
];

/// The snap pass: one invocation per keypoint slot, idle past the corner count.
#[derive(Debug)]
pub struct SnapPass {
    kernel: Kernel,
}

impl Pass for SnapPass {
    type Bound = wgpu::BindGroup;
    const NAME: &'static str = "snap";

    fn new(device: &wgpu::Device) -> Self {
        Self { kernel: Kernel::new(device, Self::NAME, SOURCE, "snap", BINDINGS) }
    }

    fn bind(&self, device: &wgpu::Device, b: &Buffers) -> Result<wgpu::BindGroup> {
        self.kernel.bind(
            device,
            &[
                ("P", &b.params),
                ("cand_list", &b.cand_list),
                ("counters", &b.counters),
                ("denoised", &b.denoised),
                ("resp", &b.resp),
                ("corners", &b.corners),
                ("mask", &b.mask),
            ],
        )
    }

    fn record(&self, pass: &mut wgpu::ComputePass<'_>, bound: &wgpu::BindGroup, b: &Buffers) {
        if b.layout.params.snap_radius > 0 {
            self.kernel.dispatch(pass, bound, [b.layout.capacity.div_ceil(64), 1, 1]);
        }
    }
}
