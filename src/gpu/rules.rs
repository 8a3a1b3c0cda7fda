//! SPEC 7 rules 1 and 2 on the GPU: shaders/rules.wgsl, mirroring
//! src/cpu/rules.rs. `classes` -> `ruled` (NONE, WEAK, STRONG as bits, see
//! `layout::pack_ruled`), all levels in one dispatch; the quad walks holding
//! an active pixel are appended to `walks` (`layout::walk_entry`), the list
//! hysteresis runs over.

use super::buffers::{Buffers, counter};
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
    b(3, "walks", Slot::ReadWrite),
    b(4, "counters", Slot::ReadWrite),
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
        Self { kernel: Kernel::new(device, Self::NAME, SOURCE, "main", BINDINGS) }
    }

    fn bind(&self, device: &wgpu::Device, b: &Buffers) -> Result<wgpu::BindGroup> {
        self.kernel.bind(
            device,
            &[
                ("P", &b.params),
                ("classes", &b.classes),
                ("ruled", &b.ruled),
                ("walks", &b.walks),
                ("counters", &b.counters),
            ],
        )
    }

    fn record(&self, pass: &mut wgpu::ComputePass<'_>, bound: &wgpu::BindGroup, b: &Buffers) {
        self.kernel.dispatch(pass, bound, b.layout.quad_groups());
    }

    fn prepare(&self, encoder: &mut wgpu::CommandEncoder, b: &Buffers) {
        // the walk list starts empty (its count only; other passes own the other slots)
        encoder.clear_buffer(&b.counters, counter::WALKS as u64 * 4, Some(4));
    }
}
