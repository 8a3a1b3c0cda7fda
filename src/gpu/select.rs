//! SPEC 9 (the `n_features` cap and the output order) on the GPU:
//! shaders/select.wgsl, mirroring `cpu::select::select` with
//! `distribution = false` (the quadtree distribution is not done on the GPU).
//! `corners` + `counters[counter::CORNERS]` -> `keypoints` in SPEC 9 order,
//! `counters[counter::KEYPOINTS]`, and the `indirect` args over corners,
//! keypoints and the keypoint draw. `ranks` is scratch. `place` also marks
//! in `blur_tiles` (cleared by the pass first) the tiles the keypoints'
//! descriptors read, which the blur pass smooths.

use super::buffers::{Buffers, indirect};
use super::kernel::{Binding, Kernel, PARAMS, Slot, b};
use super::pass::Pass;
use crate::error::Result;

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/select.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] = &[
    PARAMS,
    b(1, "corners", Slot::Read),
    b(2, "counters", Slot::ReadWrite),
    b(3, "ranks", Slot::ReadWrite),
    b(4, "keypoints", Slot::ReadWrite),
    b(5, "indirect", Slot::ReadWrite),
    b(6, "buckets", Slot::ReadWrite),
    b(7, "members", Slot::ReadWrite),
    b(8, "blur_tiles", Slot::ReadWrite),
];

pub use super::buffers::{SELECT_BUCKET_WORDS as BUCKET_WORDS, SELECT_BUCKETS as BUCKETS};

/// The bindings of the indirectly dispatched entry points: all but
/// `indirect`, which those dispatches read their sizes from (a buffer may not
/// be bound as storage while it is the dispatch's indirect buffer).
const RANK_BINDINGS: &[Binding] = &[
    PARAMS,
    b(1, "corners", Slot::Read),
    b(2, "counters", Slot::ReadWrite),
    b(3, "ranks", Slot::ReadWrite),
    b(4, "keypoints", Slot::ReadWrite),
    b(6, "buckets", Slot::ReadWrite),
    b(7, "members", Slot::ReadWrite),
    b(8, "blur_tiles", Slot::ReadWrite),
];

/// The select pass: seven entry points of one shader, in recording order.
#[derive(Debug)]
pub struct SelectPass {
    args: Kernel,
    rank_level: Kernel,
    count: Kernel,
    scan: Kernel,
    scatter: Kernel,
    place: Kernel,
    finish: Kernel,
}

/// [`SelectPass`]'s bind groups.
#[derive(Debug)]
pub struct SelectBound {
    /// For `args` and `finish` (with `indirect`).
    full: wgpu::BindGroup,
    /// For the other entry points (without `indirect`).
    rank: wgpu::BindGroup,
}

impl Pass for SelectPass {
    type Bound = SelectBound;
    const NAME: &'static str = "select";

    fn new(device: &wgpu::Device) -> Self {
        let module = super::kernel::compile(device, Self::NAME, SOURCE);
        let k =
            |entry: &str, bindings| Kernel::from_module(device, &format!("select::{entry}"), &module, entry, bindings);
        Self {
            args: k("args", BINDINGS),
            rank_level: k("rank_level", RANK_BINDINGS),
            count: k("count", RANK_BINDINGS),
            scan: k("scan", RANK_BINDINGS),
            scatter: k("scatter", RANK_BINDINGS),
            place: k("place", RANK_BINDINGS),
            finish: k("finish", BINDINGS),
        }
    }

    fn bind(&self, device: &wgpu::Device, b: &Buffers) -> Result<SelectBound> {
        let common = [
            ("P", &b.params),
            ("corners", &b.corners),
            ("counters", &b.counters),
            ("ranks", &b.ranks),
            ("keypoints", &b.keypoints),
            ("buckets", &b.sel_buckets),
            ("members", &b.sel_members),
            ("blur_tiles", &b.blur_tiles),
        ];
        let mut full = common.to_vec();
        full.push(("indirect", &b.indirect));
        Ok(SelectBound { full: self.args.bind(device, &full)?, rank: self.rank_level.bind(device, &common)? })
    }

    fn record(&self, pass: &mut wgpu::ComputePass<'_>, bound: &SelectBound, b: &Buffers) {
        self.args.dispatch(pass, &bound.full, [1, 1, 1]);
        self.rank_level.dispatch_indirect(pass, &bound.rank, &b.indirect, indirect::CORNERS);
        self.count.dispatch_indirect(pass, &bound.rank, &b.indirect, indirect::CORNERS);
        self.scan.dispatch(pass, &bound.rank, [1, 1, 1]);
        self.scatter.dispatch_indirect(pass, &bound.rank, &b.indirect, indirect::CORNERS);
        self.place.dispatch_indirect(pass, &bound.rank, &b.indirect, indirect::CORNERS);
        self.finish.dispatch(pass, &bound.full, [1, 1, 1]);
    }

    fn prepare(&self, encoder: &mut wgpu::CommandEncoder, b: &Buffers) {
        // count and scatter add into the bucket counts and cursors; place
        // marks the tiles blur smooths.
        encoder.clear_buffer(&b.sel_buckets, 0, None);
        encoder.clear_buffer(&b.blur_tiles, 0, None);
    }
}
