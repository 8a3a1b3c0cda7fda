//! SPEC 9 (corner NMS) on the GPU: shaders/corner_nms.wgsl, mirroring
//! src/cpu/corner_nms.rs. `cand` + `resp` -> survivors appended to `corners`
//! as [`GpuKeypoint`](super::GpuKeypoint)s, counted in `counters[counter::CORNERS]`,
//! in no particular order ([`SelectPass`](super::select::SelectPass) orders them).

use super::buffers::Buffers;
use super::kernel::{Binding, Kernel, PARAMS, Slot, b};
use super::pass::Pass;
use crate::error::Result;

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/corner_nms.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] = &[
    PARAMS,
    b(1, "cand", Slot::Read),
    b(2, "resp", Slot::Read),
    b(3, "corners", Slot::ReadWrite),
    b(4, "counters", Slot::ReadWrite),
];

/// The corner NMS pass.
#[derive(Debug)]
pub struct CornerNmsPass {
    kernel: Kernel,
}

impl Pass for CornerNmsPass {
    type Bound = wgpu::BindGroup;
    const NAME: &'static str = "corner_nms";

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
                ("cand", &b.cand),
                ("resp", &b.resp),
                ("corners", &b.corners),
                ("counters", &b.counters),
            ],
        )
    }

    fn record(&self, pass: &mut wgpu::ComputePass<'_>, bound: &wgpu::BindGroup, b: &Buffers) {
        self.kernel.dispatch(pass, bound, b.layout.pixel_groups());
    }

    /// The append cursor (and the other counters of the frame) start at 0.
    fn prepare(&self, encoder: &mut wgpu::CommandEncoder, b: &Buffers) {
        encoder.clear_buffer(&b.counters, 0, None);
    }
}
