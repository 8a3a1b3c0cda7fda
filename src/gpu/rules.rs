//! SPEC 7 rules 1 and 2 on the GPU: shaders/rules.wgsl, mirroring
//! src/cpu/rules.rs. `classes` -> `ruled` (NONE, WEAK, STRONG as bits, see
//! `layout::pack_ruled`), all levels in one dispatch; the quad walks holding
//! an active pixel are appended to `walks` (`layout::walk_entry`), the list
//! hysteresis runs over.

use super::buffers::counter;
use super::kernel::{Binding, PARAMS, Slot, b};
use super::pass::{Groups, simple_pass};

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/rules.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] = &[
    PARAMS,
    b(1, "classes", Slot::Read),
    b(2, "ruled", Slot::ReadWrite),
    b(3, "walks", Slot::ReadWrite),
    b(4, "counters", Slot::ReadWrite),
    b(5, "classes4", Slot::Read),
];

simple_pass! {
    /// The isolated-edge suppression pass (rules 1 and 2).
    RulesPass = "rules" {
        "classes" = classes,
        "classes4" = classes,
        "ruled" = ruled,
        "walks" = walks,
        "counters" = counters,
    }
    dispatch |b| Groups::Direct(b.layout.quad_groups());
    // the walk list starts empty (its count only: other passes own the other slots)
    prepare |encoder, b| { encoder.clear_buffer(&b.counters, counter::WALKS as u64 * 4, Some(4)); }
}
