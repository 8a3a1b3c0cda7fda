//! The GPU path: every SPEC stage a WGSL compute pass (`shaders/<stage>.wgsl`),
//! mirrored by `src/cpu/<stage>.rs`, driven through wgpu.
//!
//! - [`GpuContext`]: the device, from the environment or an embedder's.
//! - [`Buffers`]: every buffer of one frame size, by name.
//! - one `*Pass` struct per stage, implementing [`Pass`]; [`stages`] lists
//!   them once, in recording order, and [`SHADERS`] follows from that list.
//! - [`GpuDetector`] chains them; [`readback`] brings a frame's results back.

pub mod blur;
pub mod buffers;
pub mod cand_list;
pub mod classify;
pub mod context;
pub mod corner_nms;
pub mod detector;
pub mod footprint;
pub mod gradient;
pub mod gradient_nms;
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
pub mod readback;
pub mod response;
pub mod rules;
pub mod select;
pub mod snap;
pub mod stages;

pub use buffers::{Buffers, GpuKeypoint, StagePlanes};
pub use context::{AutoChoice, GpuContext, GpuOptions, auto_choice, is_hardware, is_software, list_adapters};
pub use detector::{GpuDetector, GpuDetectorOptions, GpuInput, GpuWorkspace};
pub use footprint::{WorkspaceReport, workspace_report};
pub use layout::FrameLayout;
pub use pass::Pass;
pub use readback::{Finish, Frame, Ticket};
pub use stages::{SHADERS, STAGES, time_each_stage};

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
