//! SPEC stage `local_threshold` on the GPU (not written yet).

use super::kernel::{Binding, PARAMS};

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/local_threshold.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] = &[PARAMS];
