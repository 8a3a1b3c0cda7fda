//! SPEC 8 (the L-FAST corner test) on the GPU: shaders/lfast.wgsl, mirroring
//! src/cpu/lfast.rs. `edges` (+ `mask` when `Params::use_mask` is 1) ->
//! `cand` (1 = candidate), all levels at once, in three dispatches: `windows`
//! (each tile column's edges and 8 rows either side as the bits of a word,
//! `edge_bits`, and the tested edge pixels appended to `edge_list`), `args`
//! (the indirect args over the list), then `main` (the test, one invocation
//! per listed pixel, a load per column of its stencil).

use super::buffers::{Buffers, counter, indirect};
use super::kernel::{Binding, Kernel, PARAMS, Slot, b};
use super::pass::Pass;
use crate::error::Result;

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/lfast.wgsl");
/// Its bindings (shared by the entry points).
pub const BINDINGS: &[Binding] = &[
    PARAMS,
    b(1, "edges", Slot::Read),
    b(2, "mask", Slot::Read),
    b(3, "cand", Slot::ReadWrite),
    b(4, "edge_bits", Slot::ReadWrite),
    b(5, "edge_list", Slot::ReadWrite),
    b(6, "counters", Slot::ReadWrite),
    b(7, "indirect", Slot::ReadWrite),
];

/// The bindings of `main`, which is dispatched indirectly: all but
/// `indirect`, which that dispatch reads its size from (a buffer may not be
/// bound as storage while it is the dispatch's indirect buffer).
const TEST_BINDINGS: &[Binding] = BINDINGS.split_at(7).0;

/// [`LfastPass`]'s bind groups: `windows` and `args` (with `indirect`), `main`.
#[derive(Debug)]
pub struct LfastBound {
    lists: wgpu::BindGroup,
    test: wgpu::BindGroup,
}

/// The L-FAST candidate pass: `windows`, `args`, then `main`.
#[derive(Debug)]
pub struct LfastPass {
    windows: Kernel,
    args: Kernel,
    test: Kernel,
}

impl Pass for LfastPass {
    type Bound = LfastBound;
    const NAME: &'static str = "lfast";

    fn new(device: &wgpu::Device) -> Self {
        let module = super::kernel::compile(device, Self::NAME, SOURCE);
        Self {
            windows: Kernel::from_module(device, "lfast windows", &module, "windows", BINDINGS),
            args: Kernel::from_module(device, "lfast args", &module, "args", BINDINGS),
            test: Kernel::from_module(device, "lfast main", &module, "main", TEST_BINDINGS),
        }
    }

    fn bind(&self, device: &wgpu::Device, b: &Buffers) -> Result<LfastBound> {
        let buffers = [
            ("P", &b.params),
            ("edges", &b.edges),
            ("mask", &b.mask),
            ("cand", &b.cand),
            ("edge_bits", &b.edge_bits),
            ("edge_list", &b.edge_list),
            ("counters", &b.counters),
            ("indirect", &b.indirect),
        ];
        // `windows` and `args` have the same layout entries: one group serves both.
        Ok(LfastBound { lists: self.windows.bind(device, &buffers)?, test: self.test.bind(device, &buffers[..7])? })
    }

    fn record(&self, pass: &mut wgpu::ComputePass<'_>, bound: &LfastBound, b: &Buffers) {
        // wgpu orders the dispatches of one compute pass (each sees the one before).
        self.windows.dispatch(pass, &bound.lists, b.layout.column_groups());
        self.args.dispatch(pass, &bound.lists, [1, 1, 1]);
        self.test.dispatch_indirect(pass, &bound.test, &b.indirect, indirect::EDGES);
    }

    fn prepare(&self, encoder: &mut wgpu::CommandEncoder, b: &Buffers) {
        // `main` sets the corners' bytes of `cand` only, and the edge list's
        // cursor starts at 0 (its own counter: the others belong to later stages).
        encoder.clear_buffer(&b.cand, 0, None);
        encoder.clear_buffer(&b.counters, 4 * counter::EDGES as u64, Some(4));
    }
}
