//! The candidate list on the GPU: shaders/cand_list.wgsl. `cand` -> the atlas
//! index of every candidate in `cand_list` (unordered), its count in
//! `counters[counter::CANDS]` and the indirect args `indirect::CANDS` that
//! [`ResponsePass`](super::response::ResponsePass) and
//! [`CornerNmsPass`](super::corner_nms::CornerNmsPass) dispatch over. Not a
//! pipeline stage: the pipeline's [`LfastPass`](super::lfast::LfastPass)
//! appends each candidate as it finds it (as the CPU's `cpu::lfast` does), and
//! this standalone pass builds the same list from a `cand` plane, for running
//! response and corner NMS alone on given candidates (tests/gpu_keypoints.rs).

use super::buffers::{Buffers, counter};
use super::kernel::{Binding, Kernel, PARAMS, Slot, b};
use super::pass::Pass;
use crate::error::Result;

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/cand_list.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] = &[
    PARAMS,
    b(1, "cand", Slot::Read),
    b(2, "cand_list", Slot::ReadWrite),
    b(3, "counters", Slot::ReadWrite),
    b(4, "indirect", Slot::ReadWrite),
];

/// The candidate-list pass: the list (a column pass), then its dispatch args.
#[derive(Debug)]
pub struct CandListPass {
    list: Kernel,
    args: Kernel,
}

impl Pass for CandListPass {
    type Bound = wgpu::BindGroup;
    const NAME: &'static str = "cand_list";

    fn new(device: &wgpu::Device) -> Self {
        let module = super::kernel::compile(device, Self::NAME, SOURCE);
        Self {
            list: Kernel::from_module(device, "cand_list main", &module, "main", BINDINGS),
            args: Kernel::from_module(device, "cand_list args", &module, "args", BINDINGS),
        }
    }

    fn bind(&self, device: &wgpu::Device, b: &Buffers) -> Result<wgpu::BindGroup> {
        // Both kernels have the same layout entries, so one bind group serves both.
        self.list.bind(
            device,
            &[
                ("P", &b.params),
                ("cand", &b.cand),
                ("cand_list", &b.cand_list),
                ("counters", &b.counters),
                ("indirect", &b.indirect),
            ],
        )
    }

    fn record(&self, pass: &mut wgpu::ComputePass<'_>, bound: &wgpu::BindGroup, b: &Buffers) {
        self.list.dispatch(pass, bound, b.layout.column_groups());
        self.args.dispatch(pass, bound, [1, 1, 1]);
    }

    fn prepare(&self, encoder: &mut wgpu::CommandEncoder, b: &Buffers) {
        // The list's cursor and the counters of the stages after it (corner
        // NMS's cursor, select's) start at 0; lfast clears its own.
        encoder.clear_buffer(&b.counters, 0, Some(4 * (counter::CANDS as u64 + 1)));
    }
}
