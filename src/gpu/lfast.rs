//! SPEC 8 (the L-FAST corner test) on the GPU: shaders/lfast.wgsl, mirroring
//! src/cpu/lfast.rs. `edges` (+ `mask` when `Params::use_mask` is 1) ->
//! `cand` (1 = candidate), all levels at once, in two dispatches: `windows`
//! (each tile column's edges and 8 rows either side as the bits of a word,
//! `edge_bits`), then `main` (the test, a load per column of its stencil).

use super::buffers::Buffers;
use super::kernel::{Binding, Kernel, PARAMS, Slot, b};
use super::pass::Pass;
use crate::error::Result;

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/lfast.wgsl");
/// Its bindings (shared by both entry points).
pub const BINDINGS: &[Binding] = &[
    PARAMS,
    b(1, "edges", Slot::Read),
    b(2, "mask", Slot::Read),
    b(3, "cand", Slot::ReadWrite),
    b(4, "edge_bits", Slot::ReadWrite),
];

/// The L-FAST candidate pass: `windows`, then `main`.
#[derive(Debug)]
pub struct LfastPass {
    windows: Kernel,
    test: Kernel,
}

impl Pass for LfastPass {
    type Bound = wgpu::BindGroup;
    const NAME: &'static str = "lfast";

    fn new(device: &wgpu::Device) -> Self {
        let module = super::kernel::compile(device, Self::NAME, SOURCE);
        Self {
            windows: Kernel::from_module(device, "lfast windows", &module, "windows", BINDINGS),
            test: Kernel::from_module(device, "lfast main", &module, "main", BINDINGS),
        }
    }

    fn bind(&self, device: &wgpu::Device, b: &Buffers) -> Result<wgpu::BindGroup> {
        // Both kernels have the same layout entries, so one bind group serves both.
        self.test.bind(
            device,
            &[("P", &b.params), ("edges", &b.edges), ("mask", &b.mask), ("cand", &b.cand), ("edge_bits", &b.edge_bits)],
        )
    }

    fn record(&self, pass: &mut wgpu::ComputePass<'_>, bound: &wgpu::BindGroup, b: &Buffers) {
        // wgpu orders the dispatches of one compute pass (main sees the windows).
        self.windows.dispatch(pass, bound, b.layout.column_groups());
        self.test.dispatch(pass, bound, b.layout.column_groups());
    }
}
