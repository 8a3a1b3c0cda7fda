//! SPEC 5 on the GPU: shaders/local_threshold.wgsl, mirroring
//! src/cpu/local_threshold.rs. `m` + `grid` -> `cell_hist` (each cell's counts
//! and its lanes' lowest and highest bins) -> `windows` (min, max, median, V3
//! of the cells that make up each window);
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
    b(4, "cell_hist", Slot::ReadWrite),
    b(5, "hist", Slot::ReadWrite),
    b(6, "cell_hist4", Slot::ReadWrite),
];

/// Words of `cell_hist` per cell of a frame whose level 0 is `w x h`: its
/// bins ([`cell_bin_words`](super::layout::cell_bin_words)), and a word per
/// `cells` invocation (shaders/local_threshold.wgsl CELL_INVOCATIONS) with
/// the lowest and highest non-empty bin of its share of the bins.
pub fn cell_words(w: u32, h: u32) -> u64 {
    super::layout::cell_bin_words(w, h) as u64 + 8
}

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
                ("cell_hist", &b.cell_hist),
                ("hist", &b.hist),
                ("cell_hist4", &b.cell_hist),
            ],
        )
    }

    fn record(&self, pass: &mut wgpu::ComputePass<'_>, bound: &wgpu::BindGroup, b: &Buffers) {
        self.cells.dispatch(pass, bound, b.layout.cell_groups());
        self.stats.dispatch(pass, bound, [b.layout.total_windows.div_ceil(64), 1, 1]);
    }

    fn prepare(&self, encoder: &mut wgpu::CommandEncoder, b: &Buffers) {
        // `cells` stores (or ORs in) each cell's non-empty bins only: the
        // frame's cells' bins start from zero (their invocations' words are
        // always stored).
        let (w, h) = b.layout.sizes[0];
        let bytes = 4 * super::layout::cell_bin_words(w, h) as u64 * b.layout.total_cells as u64;
        encoder.clear_buffer(&b.cell_hist, 0, Some(bytes.min(b.cell_hist.size())));
        // ... and into the levels' histograms
        encoder.clear_buffer(&b.hist, 0, None);
    }
}
