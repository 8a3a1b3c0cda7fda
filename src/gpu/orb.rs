//! SPEC 11 description on the GPU: shaders/orb.wgsl, mirroring src/cpu/orb.rs.
//! Per final keypoint (indirect dispatch over `counters[KEYPOINTS]`): the
//! 256-bit rBRIEF descriptor on the `smooth` level into `descriptors[8i..8i+8]`,
//! with the pattern of the keypoint's bin, or rotated per keypoint by its
//! angle when `orientation_bins` is 0.

use super::buffers::{Buffers, indirect};
use super::kernel::{Binding, Kernel, PARAMS, Slot, b};
use super::pass::Pass;
use crate::error::Result;

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/orb.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] = &[
    PARAMS,
    b(1, "smoothed", Slot::Read),
    b(2, "keypoints", Slot::Read),
    b(3, "counters", Slot::Read),
    b(4, "patterns", Slot::Read),
    b(5, "descriptors", Slot::ReadWrite),
];

/// The descriptor pass.
#[derive(Debug)]
pub struct OrbPass {
    kernel: Kernel,
}

impl Pass for OrbPass {
    type Bound = wgpu::BindGroup;
    const NAME: &'static str = "orb";

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
                ("smoothed", &b.smooth),
                ("keypoints", &b.keypoints),
                ("counters", &b.counters),
                ("patterns", &b.patterns),
                ("descriptors", &b.descriptors),
            ],
        )
    }

    fn record(&self, pass: &mut wgpu::ComputePass<'_>, bound: &wgpu::BindGroup, b: &Buffers) {
        self.kernel
            .dispatch_indirect(pass, bound, &b.indirect, indirect::KEYPOINTS);
    }
}
