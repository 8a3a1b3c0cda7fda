//! SPEC 11 smoothing on the GPU: shaders/blur.wgsl, mirroring src/cpu/blur.rs.
//! `gray` -> `blur_tmp` (horizontal) -> `smooth` (vertical), all levels per dispatch.

use super::buffers::Buffers;
use super::kernel::{Binding, Kernel, PARAMS, Slot, b};
use super::pass::Pass;
use crate::error::Result;

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/blur.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] =
    &[PARAMS, b(1, "gray", Slot::Read), b(2, "blur_tmp", Slot::ReadWrite), b(3, "smoothed", Slot::ReadWrite)];

/// The 7x7 Gaussian blur pass.
#[derive(Debug)]
pub struct BlurPass {
    horizontal: Kernel,
    vertical: Kernel,
}

impl Pass for BlurPass {
    type Bound = wgpu::BindGroup;
    const NAME: &'static str = "blur";

    fn new(device: &wgpu::Device) -> Self {
        let module = super::kernel::compile(device, Self::NAME, SOURCE);
        Self {
            horizontal: Kernel::from_module(device, "blur horizontal", &module, "horizontal", BINDINGS),
            vertical: Kernel::from_module(device, "blur vertical", &module, "vertical", BINDINGS),
        }
    }

    fn bind(&self, device: &wgpu::Device, b: &Buffers) -> Result<wgpu::BindGroup> {
        // Both kernels have the same layout entries, so one bind group serves both.
        self.horizontal
            .bind(device, &[("P", &b.params), ("gray", &b.gray), ("blur_tmp", &b.blur_tmp), ("smoothed", &b.smooth)])
    }

    fn record(&self, pass: &mut wgpu::ComputePass<'_>, bound: &wgpu::BindGroup, b: &Buffers) {
        self.horizontal.dispatch(pass, bound, b.layout.column_groups());
        self.vertical.dispatch(pass, bound, b.layout.column_groups());
    }
}
