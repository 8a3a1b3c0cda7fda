//! Corners snapped to the Harris maximum nearby (docs/quality.md) on the GPU:
//! shaders/snap.wgsl, compiled after shaders/response.wgsl so that the Harris
//! response has one definition, mirroring src/cpu/snap.rs bit for bit. Runs
//! between corner NMS and the cap, on the `corners` list in place; does
//! nothing when `snap_radius` is 0.

use super::buffers::{Buffers, indirect};
use super::kernel::{Binding, Kernel, PARAMS, Slot, b};
use super::pass::Pass;
use crate::error::Result;

/// The shader source (without the common prelude): the response shader, then the snap entry point.
pub const SOURCE: &str = concat!(include_str!("../../shaders/response.wgsl"), include_str!("../../shaders/snap.wgsl"));
/// Its bindings (those of the response shader it is compiled with, then its
/// own; `indirect` for `snap_args` only).
pub const BINDINGS: &[Binding] = &[
    PARAMS,
    b(1, "cand_list", Slot::Read),
    b(2, "counters", Slot::Read),
    b(3, "denoised", Slot::Read),
    b(4, "resp", Slot::ReadWrite),
    b(5, "corners", Slot::ReadWrite),
    b(6, "mask", Slot::Read),
    b(7, "indirect", Slot::ReadWrite),
];

/// The bindings of `snap` itself: all but `indirect` (the last), which its
/// dispatch reads its size from (a buffer may not be bound as storage while
/// it is the dispatch's indirect buffer).
const SNAP_BINDINGS: &[Binding] = BINDINGS.split_at(BINDINGS.len() - 1).0;

/// The snap pass: `snap_args` writes the dispatch size from the corner count
/// (`indirect::CORNERS`, which the select pass rewrites alike), then one
/// invocation per corner. Dispatched over every keypoint slot instead, its
/// idle workgroups had taken most of the pass on lavapipe (7.7 ms of a KITTI
/// frame, against ~0.7 ms for the ~40 groups that hold corners).
#[derive(Debug)]
pub struct SnapPass {
    args: Kernel,
    snap: Kernel,
}

/// [`SnapPass`]'s bind groups.
#[derive(Debug)]
pub struct SnapBound {
    /// For `snap_args` (with `indirect`).
    args: wgpu::BindGroup,
    /// For `snap` (without).
    snap: wgpu::BindGroup,
}

impl Pass for SnapPass {
    type Bound = SnapBound;
    const NAME: &'static str = "snap";

    fn new(device: &wgpu::Device) -> Self {
        let module = super::kernel::compile(device, Self::NAME, SOURCE);
        let k =
            |entry: &str, bindings| Kernel::from_module(device, &format!("snap::{entry}"), &module, entry, bindings);
        Self { args: k("snap_args", BINDINGS), snap: k("snap", SNAP_BINDINGS) }
    }

    fn bind(&self, device: &wgpu::Device, b: &Buffers) -> Result<SnapBound> {
        let all = [
            ("P", &b.params),
            ("cand_list", &b.cand_list),
            ("counters", &b.counters),
            ("denoised", &b.denoised),
            ("resp", &b.resp),
            ("corners", &b.corners),
            ("mask", &b.mask),
            ("indirect", &b.indirect),
        ];
        Ok(SnapBound { args: self.args.bind(device, &all)?, snap: self.snap.bind_from(device, &all)? })
    }

    fn record(&self, pass: &mut wgpu::ComputePass<'_>, bound: &SnapBound, b: &Buffers) {
        if b.layout.params.snap_radius > 0 {
            self.args.dispatch(pass, &bound.args, [1, 1, 1]);
            self.snap.dispatch_indirect(pass, &bound.snap, &b.indirect, indirect::CORNERS);
        }
    }
}
