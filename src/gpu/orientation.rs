//! SPEC 11 orientation on the GPU: shaders/orientation.wgsl, mirroring
//! src/cpu/orientation.rs. Per final keypoint (indirect dispatch over
//! `counters[KEYPOINTS]`): m10, m01 on the unsmoothed `gray` level, the
//! orientation bin, and an approximate angle, written back into `keypoints`.

use super::buffers::{Buffers, indirect};
use super::kernel::{Binding, Kernel, PARAMS, Slot, b};
use super::pass::Pass;
use crate::error::Result;

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/orientation.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] = &[
    PARAMS,
    b(1, "gray", Slot::Read),
    b(2, "keypoints", Slot::ReadWrite),
    b(3, "counters", Slot::Read),
    b(4, "angle_bounds", Slot::Read),
];

/// The orientation pass.
#[derive(Debug)]
pub struct OrientationPass {
    kernel: Kernel,
}

impl Pass for OrientationPass {
    type Bound = wgpu::BindGroup;
    const NAME: &'static str = "orientation";

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
                ("gray", &b.gray),
                ("keypoints", &b.keypoints),
                ("counters", &b.counters),
                ("angle_bounds", &b.angle_bounds),
            ],
        )
    }

    fn record(&self, pass: &mut wgpu::ComputePass<'_>, bound: &wgpu::BindGroup, b: &Buffers) {
        self.kernel
            .dispatch_indirect(pass, bound, &b.indirect, indirect::KEYPOINTS);
    }
}
