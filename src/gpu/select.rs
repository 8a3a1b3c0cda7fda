//! SPEC stage `select` on the GPU (not written yet).

use super::kernel::{Binding, PARAMS};

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/select.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] = &[PARAMS];
