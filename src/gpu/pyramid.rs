//! SPEC 10 on the GPU: shaders/pyramid.wgsl, mirroring src/cpu/pyramid.rs.
//! `gray` level l-1 -> `gray` level l for l = 1..n_levels, one dispatch per
//! level, the level given by the dynamic offset of `level_index`.

use super::buffers::Buffers;
use super::kernel::{Binding, DYNAMIC_STRIDE, Kernel, PARAMS, Slot, b};
use super::pass::Pass;
use crate::error::{Error, Result};
use crate::image::MAX_SIDE;

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/pyramid.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] = &[
    PARAMS,
    b(1, "level_index", Slot::UniformDynamic),
    b(2, "gray", Slot::ReadWrite),
    b(3, "gray4", Slot::ReadWrite),
    b(4, "grid", Slot::Read),
    b(5, "grid4", Slot::Read),
];

/// The pyramid pass.
#[derive(Debug)]
pub struct PyramidPass {
    kernel: Kernel,
}

impl Pass for PyramidPass {
    type Bound = wgpu::BindGroup;
    const NAME: &'static str = "pyramid";

    fn new(device: &wgpu::Device) -> Self {
        Self { kernel: Kernel::new(device, Self::NAME, SOURCE, "main", BINDINGS) }
    }

    /// Fails for a level 0 side over [`MAX_SIDE`]: the taps' table holds a
    /// source index in 16 bits (`layout::push_pyramid_taps`).
    fn bind(&self, device: &wgpu::Device, b: &Buffers) -> Result<wgpu::BindGroup> {
        let (w, h) = b.size();
        if w > MAX_SIDE || h > MAX_SIDE {
            return Err(Error::InvalidImage {
                width: w,
                height: h,
                reason: format!("a side exceeds the limit of {MAX_SIDE} pixels"),
            });
        }
        self.kernel.bind(
            device,
            &[
                ("P", &b.params),
                ("level_index", &b.level_index),
                ("gray", &b.gray),
                ("gray4", &b.gray),
                ("grid", &b.grid),
                ("grid4", &b.grid),
            ],
        )
    }

    fn record(&self, pass: &mut wgpu::ComputePass<'_>, bound: &wgpu::BindGroup, b: &Buffers) {
        for l in 1..b.layout.sizes.len() {
            self.kernel.dispatch_at(pass, bound, l as u32 * DYNAMIC_STRIDE as u32, b.layout.level_quad_groups(l));
        }
    }
}
