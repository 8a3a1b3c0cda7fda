//! SPEC 7 rule 3 (hysteresis) on the GPU: shaders/hysteresis.wgsl, mirroring
//! src/cpu/hysteresis.rs. `ruled` -> `edges` (255 / 0) and, in Paper mode,
//! `edge_bits` (each tile column's edge rows as the bits of a word, what
//! Paper mode's L-FAST test reads:
//! [`pack_edge_tiles`](super::layout::pack_edge_tiles)), all levels at once, by
//! union-find connected-component labelling in three dispatches (merge,
//! compress (with the STRONG flags), final_edges) after clearing the labels
//! and flags: exact after a fixed number of dispatches, with no read-back and
//! no iteration cap (the shader argues why).

use super::buffers::{Buffers, indirect};
use super::kernel::{Binding, Kernel, PARAMS, Slot, b};
use super::pass::Pass;
use crate::error::Result;

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/hysteresis.wgsl");
/// Its bindings (every entry point's).
pub const BINDINGS: &[Binding] = &[
    PARAMS,
    b(1, "ruled", Slot::Read),
    b(2, "labels", Slot::ReadWrite),
    b(3, "flags", Slot::ReadWrite),
    b(4, "edges", Slot::ReadWrite),
    b(5, "walks", Slot::ReadWrite),
    b(6, "counters", Slot::ReadWrite),
    b(7, "indirect", Slot::ReadWrite),
    b(8, "ruled4", Slot::Read),
    b(9, "edge_tiles", Slot::ReadWrite),
];
/// `walk_args`'s: it writes the args the three steps are dispatched by, so
/// those must not bind `indirect` (a buffer is either indirect args or
/// storage within one dispatch).
const ARGS_BINDINGS: &[Binding] = &[PARAMS, BINDINGS[5], BINDINGS[6], BINDINGS[7]];
/// The three steps'.
const STEP_BINDINGS: &[Binding] =
    &[BINDINGS[0], BINDINGS[1], BINDINGS[2], BINDINGS[3], BINDINGS[4], BINDINGS[5], BINDINGS[8], BINDINGS[9]];

/// The entry points in dispatch order, with their bindings: the walk list's
/// dispatch args, then the three steps over the list.
pub const ENTRIES: [(&str, &[Binding]); 4] = [
    ("walk_args", ARGS_BINDINGS),
    ("merge", STEP_BINDINGS),
    ("compress", STEP_BINDINGS),
    ("final_edges", STEP_BINDINGS),
];

/// The hysteresis pass.
#[derive(Debug)]
pub struct HysteresisPass {
    /// One kernel per entry of [`ENTRIES`], same order.
    kernels: Vec<Kernel>,
}

/// One bind group per kernel (each has its own layout object).
#[derive(Debug)]
pub struct HysteresisBound {
    groups: Vec<wgpu::BindGroup>,
}

impl Pass for HysteresisPass {
    type Bound = HysteresisBound;
    const NAME: &'static str = "hysteresis";

    fn new(device: &wgpu::Device) -> Self {
        let module = super::kernel::compile(device, Self::NAME, SOURCE);
        let kernels = ENTRIES
            .iter()
            .map(|(e, bindings)| Kernel::from_module(device, &format!("{}::{e}", Self::NAME), &module, e, bindings))
            .collect();
        Self { kernels }
    }

    fn bind(&self, device: &wgpu::Device, b: &Buffers) -> Result<HysteresisBound> {
        let buffers = [
            ("P", &b.params),
            ("ruled", &b.ruled),
            ("ruled4", &b.ruled),
            ("labels", &b.labels),
            ("flags", &b.flags),
            ("edges", &b.edges),
            ("walks", &b.walks),
            ("counters", &b.counters),
            ("indirect", &b.indirect),
            ("edge_tiles", &b.edge_bits),
        ];
        let groups = self.kernels.iter().map(|k| k.bind_from(device, &buffers)).collect::<Result<Vec<_>>>()?;
        Ok(HysteresisBound { groups })
    }

    fn record(&self, pass: &mut wgpu::ComputePass<'_>, bound: &HysteresisBound, b: &Buffers) {
        // wgpu orders the dispatches of one compute pass (each sees the
        // storage writes of the previous one).
        // the args over the walk list (rules appended it), then the three
        // steps, four columns of a listed walk per invocation
        self.kernels[0].dispatch(pass, &bound.groups[0], [1, 1, 1]);
        for (k, g) in self.kernels.iter().zip(&bound.groups).skip(1) {
            k.dispatch_indirect(pass, g, &b.indirect, indirect::WALKS);
        }
    }

    fn prepare(&self, encoder: &mut wgpu::CommandEncoder, b: &Buffers) {
        // All zero labels: every pixel a root (the shader stores parents
        // complemented). `compress` only ever sets roots' bits of flags.
        encoder.clear_buffer(&b.labels, 0, None);
        encoder.clear_buffer(&b.flags, 0, None);
        // final_edges writes the listed walks only: the others stay 0
        encoder.clear_buffer(&b.edges, 0, None);
        // and their tile words for Paper mode's L-FAST test (in Branch mode
        // lfast's `windows` writes `edge_bits` whole)
        if b.layout.params.mode == 0 {
            encoder.clear_buffer(&b.edge_bits, 0, None);
        }
    }
}
