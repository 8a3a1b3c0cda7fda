//! SPEC 5 on the GPU: shaders/local_threshold.wgsl, mirroring
//! src/cpu/local_threshold.rs. `m` + `grid` -> `window_hist` (per-cell counts
//! added to the windows holding each cell) -> `windows` (min, max, median, V3);
//! the cells' counts also make SPEC 4's per-level histogram `hist` (equal to
//! [`histogram`](super::histogram)'s), which is why this pass runs before Otsu.

use super::buffers::Buffers;
use super::kernel::{Binding, Kernel, PARAMS, Slot, b};
use super::pass::Pass;
use crate::error::Result;

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/local_threshold.wgsl");
/// Its bindings (shared by both entry points).
pub const BINDINGS: &[Binding] = &[
    PARAMS,
    b(1, "m", Slot::Read),
    b(2, "grid", Slot::Read),
    b(3, "windows", Slot::ReadWrite),
    b(4, "window_hist", Slot::ReadWrite),
    b(5, "hist", Slot::ReadWrite),
];

/// The window statistics pass: `cells`, then `stats`.
#[derive(Debug)]
pub struct LocalThresholdPass {
    cells: Kernel,
    stats: Kernel,
}

impl Pass for LocalThresholdPass {
    type Bound = wgpu::BindGroup;
    const NAME: &'static str = "local_threshold";

    fn new(device: &wgpu::Device) -> Self {
        let module = super::kernel::compile(device, Self::NAME, SOURCE);
        Self {
            cells: Kernel::from_module(device, "local_threshold cells", &module, "cells", BINDINGS),
            stats: Kernel::from_module(device, "local_threshold stats", &module, "stats", BINDINGS),
        }
    }

    fn bind(&self, device: &wgpu::Device, b: &Buffers) -> Result<wgpu::BindGroup> {
        // Both kernels have the same layout entries, so one bind group serves both.
        self.cells.bind(
            device,
            &[
                ("P", &b.params),
                ("m", &b.m),
                ("grid", &b.grid),
                ("windows", &b.windows),
                ("window_hist", &b.window_hist),
                ("hist", &b.hist),
            ],
        )
    }

    fn record(&self, pass: &mut wgpu::ComputePass<'_>, bound: &wgpu::BindGroup, b: &Buffers) {
        self.cells.dispatch(pass, bound, b.layout.cell_groups());
        self.stats.dispatch(pass, bound, [b.layout.total_windows.div_ceil(64), 1, 1]);
    }

    fn prepare(&self, encoder: &mut wgpu::CommandEncoder, b: &Buffers) {
        // `cells` adds into the window histograms: start from all zero (the
        // frame's windows only; the buffer holds the most any frame could have).
        let bytes = 1024 * b.layout.total_windows as u64;
        encoder.clear_buffer(&b.window_hist, 0, Some(bytes.min(b.window_hist.size())));
        // ... and into the levels' histograms
        encoder.clear_buffer(&b.hist, 0, None);
    }
}
