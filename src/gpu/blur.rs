//! SPEC stage `blur` on the GPU (not written yet).

use super::kernel::{Binding, PARAMS};

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/blur.wgsl");
/// Its bindings.
pub const BINDINGS: &[Binding] = &[PARAMS];
