//! SPEC 8 (the L-FAST corner test) on the GPU: shaders/lfast.wgsl, mirroring
//! src/cpu/lfast.rs. `edges` (+ `mask` when `Params::use_mask` is 1) ->
//! `cand` (1 = candidate) and the candidate list (`cand_list`, its count
//! `counters[counter::CANDS]` and the args `indirect::CANDS` that
//! [`ResponsePass`](super::response::ResponsePass) and
//! [`CornerNmsPass`](super::corner_nms::CornerNmsPass) dispatch over), all
//! levels at once, then `cand_args`. In Paper mode the test is `paper`, a
//! quad pass on the edge rows of each tile column that hysteresis' final_edges
//! stores in `edge_bits` ([`pack_edge_tiles`](super::layout::pack_edge_tiles)):
//! the 16 rows of four columns at once as bit planes (SUP of the columns
//! around from a bit-sliced count of the neighbours, the circle's points as
//! shifts), the corners' `cand` words stored and their indices appended to
//! `cand_list`. In Branch mode `windows` makes each tile column's edges and 8
//! rows either side the bits of a word in `edge_bits` from `edges` and
//! appends the tested edge pixels to `edge_list`, `args` writes the indirect
//! args over it, and `main` tests one listed pixel per invocation (a load per
//! column of its stencil; a corner sets its `cand` byte and appends itself to
//! `cand_list`).

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
    b(7, "cand_list", Slot::ReadWrite),
    b(8, "indirect", Slot::ReadWrite),
    b(9, "edge_bits4", Slot::ReadWrite),
    b(10, "cand4", Slot::ReadWrite),
];

/// The bindings of `main`, which is dispatched indirectly: all but
/// `indirect`, which that dispatch reads its size from (a buffer may not be
/// bound as storage while it is the dispatch's indirect buffer).
const TEST_BINDINGS: &[Binding] = BINDINGS.split_at(8).0;

/// [`LfastPass`]'s bind groups: `windows`, `args`, `paper` and `cand_args`
/// (with `indirect`), `main`.
#[derive(Debug)]
pub struct LfastBound {
    lists: wgpu::BindGroup,
    test: wgpu::BindGroup,
}

/// The L-FAST candidate pass: `paper` (Paper mode) or `windows`, `args` and
/// `main` (Branch mode), then `cand_args`.
#[derive(Debug)]
pub struct LfastPass {
    windows: Kernel,
    args: Kernel,
    test: Kernel,
    paper: Kernel,
    cand_args: Kernel,
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
            paper: Kernel::from_module(device, "lfast paper", &module, "paper", BINDINGS),
            cand_args: Kernel::from_module(device, "lfast cand_args", &module, "cand_args", BINDINGS),
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
            ("cand_list", &b.cand_list),
            ("indirect", &b.indirect),
            ("edge_bits4", &b.edge_bits),
            ("cand4", &b.cand),
        ];
        // `windows`, `args`, `paper` and `cand_args` have the same layout entries: one group serves all four.
        Ok(LfastBound { lists: self.windows.bind(device, &buffers)?, test: self.test.bind_from(device, &buffers)? })
    }

    fn record(&self, pass: &mut wgpu::ComputePass<'_>, bound: &LfastBound, b: &Buffers) {
        // wgpu orders the dispatches of one compute pass (each sees the one before).
        if b.layout.params.mode == 0 {
            // Paper mode: the quads' pixels as bit planes, on hysteresis' tile words
            self.paper.dispatch(pass, &bound.lists, b.layout.quad_groups());
        } else {
            self.windows.dispatch(pass, &bound.lists, b.layout.quad_groups());
            self.args.dispatch(pass, &bound.lists, [1, 1, 1]);
            self.test.dispatch_indirect(pass, &bound.test, &b.indirect, indirect::EDGES);
        }
        self.cand_args.dispatch(pass, &bound.lists, [1, 1, 1]);
    }

    fn prepare(&self, encoder: &mut wgpu::CommandEncoder, b: &Buffers) {
        // The cursors of its two lists (counters EDGES and CANDS) and of the
        // stages after it (corner NMS's CORNERS, select's KEYPOINTS and TAKEN)
        // start at 0. (`cand` shares its memory with `classes`: clear_before.)
        const {
            assert!(
                counter::CANDS < counter::EDGES && counter::TAKEN < counter::EDGES && counter::WALKS > counter::EDGES
            )
        };
        encoder.clear_buffer(&b.counters, 0, Some(4 * (counter::EDGES as u64 + 1)));
    }

    fn clear_before<'b>(&self, b: &'b Buffers) -> Option<&'b wgpu::Buffer> {
        // `main` sets the corners' bytes of `cand`, whose memory `classes`
        // (classify to rules) used earlier in the frame. Zeroed by `windows`,
        // 16 stores per invocation, it cost ~0.35 ms of a KITTI frame on lavapipe.
        Some(&b.cand)
    }
}
