//! The GPU path: every SPEC stage a WGSL compute pass (`shaders/<stage>.wgsl`),
//! mirrored by `src/cpu/<stage>.rs`, driven through wgpu.
//!
//! - [`GpuContext`]: the device, from the environment or an embedder's.
//! - [`Buffers`]: every buffer of one frame size, by name.
//! - one `*Pass` struct per stage, implementing [`Pass`].

pub mod blur;
pub mod buffers;
pub mod classify;
pub mod context;
pub mod corner_nms;
pub mod detector;
pub mod gradient;
pub mod histogram;
pub mod hysteresis;
pub mod kernel;
pub mod layout;
pub mod lfast;
pub mod local_threshold;
pub mod luma;
pub mod matcher;
pub mod median;
pub mod nms;
pub mod orb;
pub mod orientation;
pub mod otsu;
pub mod pass;
pub mod pyramid;
pub mod response;
pub mod rules;
pub mod select;
#[doc(hidden)]
pub mod testing;

pub use buffers::{Buffers, GpuKeypoint};
pub use context::{AutoChoice, GpuContext, GpuOptions, auto_choice, is_hardware, is_software, list_adapters};
pub use detector::{Frame, GpuDetector, GpuDetectorOptions, GpuInput, GpuWorkspace};
pub use layout::FrameLayout;
pub use pass::Pass;

use kernel::Binding;

/// One shader: its stage name, source (without the prelude) and bindings.
#[derive(Clone, Copy, Debug)]
pub struct ShaderInfo {
    /// File stem in shaders/ and module name in src/gpu/ and src/cpu/.
    pub name: &'static str,
    /// WGSL source of the stage.
    pub source: &'static str,
    /// Every binding the shader declares.
    pub bindings: &'static [Binding],
}

macro_rules! shaders {
    ($($m:ident),* $(,)?) => {
        /// Every stage shader, in pipeline order.
        pub const SHADERS: &[ShaderInfo] = &[
            $(ShaderInfo { name: stringify!($m), source: $m::SOURCE, bindings: $m::BINDINGS }),*
        ];
    };
}

shaders!(
    luma, pyramid, median, gradient, nms, histogram, otsu, local_threshold, classify, rules, hysteresis, lfast, response,
    corner_nms, select, blur, orientation, orb, matcher,
);
