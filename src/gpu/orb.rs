//! SPEC stage `orb` on the GPU (not written yet).

use super::kernel::{Binding, PARAMS};

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/orb.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] = &[PARAMS];
