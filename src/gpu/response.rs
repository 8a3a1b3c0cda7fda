//! SPEC stage `response` on the GPU (not written yet).

use super::kernel::{Binding, PARAMS};

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/response.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] = &[PARAMS];
