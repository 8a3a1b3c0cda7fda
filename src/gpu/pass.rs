//! The shape every stage's pass struct has.

use super::buffers::Buffers;
use crate::error::Result;

/// One stage of the pipeline on the GPU: pipelines built once per device,
/// bind groups once per frame size, dispatches recorded every frame.
pub trait Pass: Sized {
    /// The stage's bind groups for one [`Buffers`].
    type Bound;
    /// The stage's name (= its shader's file stem).
    const NAME: &'static str;
    /// Compiles the stage's pipelines.
    fn new(device: &wgpu::Device) -> Self;
    /// Binds the stage's buffers by name.
    fn bind(&self, device: &wgpu::Device, b: &Buffers) -> Result<Self::Bound>;
    /// Records the stage's dispatches (all levels) into `pass`.
    fn record(&self, pass: &mut wgpu::ComputePass<'_>, bound: &Self::Bound, b: &Buffers);
    /// Commands that must precede the compute pass (clearing counters), recorded on the encoder.
    fn prepare(&self, _encoder: &mut wgpu::CommandEncoder, _b: &Buffers) {}
    /// A buffer the stage needs zeroed that shares its memory with an
    /// earlier stage's (src/gpu/footprint.rs), so [`prepare`](Self::prepare),
    /// whose commands may all come before the frame's first stage, cannot
    /// clear it: it is cleared right before the stage's dispatches, between
    /// two compute passes (a fill of the buffer, where a shader's stores
    /// cost lavapipe a per-lane loop each).
    fn clear_before<'b>(&self, _b: &'b Buffers) -> Option<&'b wgpu::Buffer> {
        None
    }
}

/// How a `simple_pass!` stage is dispatched.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Groups {
    /// Fixed workgroup counts.
    Direct([u32; 3]),
    /// Counts read from `Buffers::indirect` at this offset (sized on the GPU).
    Indirect(u64),
}

/// A stage with one kernel (entry point `main`, the module's `SOURCE` and
/// `BINDINGS`) whose bindings are [`Buffers`] fields named in the macro:
/// `"wgsl_name" = field`. `dispatch |b| expr` gives its [`Groups`]; `clear
/// a, b` zeroes those buffers before the pass (atomic accumulators), or
/// `prepare |encoder, b| { ... }` records other commands there.
macro_rules! simple_pass {
    (
        $(#[$meta:meta])*
        $name:ident = $stage:literal { $($var:literal = $field:ident),* $(,)? }
        dispatch |$b:ident| $groups:expr
        $(; clear $($clear:ident),+)?
        $(; prepare |$pe:ident, $pb:ident| $prep:block)?
    ) => {
        $(#[$meta])*
        #[derive(Debug)]
        pub struct $name {
            kernel: $crate::gpu::kernel::Kernel,
        }

        impl $crate::gpu::pass::Pass for $name {
            type Bound = wgpu::BindGroup;
            const NAME: &'static str = $stage;

            fn new(device: &wgpu::Device) -> Self {
                Self { kernel: $crate::gpu::kernel::Kernel::new(device, Self::NAME, SOURCE, "main", BINDINGS) }
            }

            fn bind(&self, device: &wgpu::Device, b: &$crate::gpu::buffers::Buffers) -> $crate::error::Result<wgpu::BindGroup> {
                self.kernel.bind(device, &[("P", &b.params), $(($var, &b.$field)),*])
            }

            fn record(&self, pass: &mut wgpu::ComputePass<'_>, bound: &wgpu::BindGroup, $b: &$crate::gpu::buffers::Buffers) {
                match $groups {
                    $crate::gpu::pass::Groups::Direct(g) => self.kernel.dispatch(pass, bound, g),
                    $crate::gpu::pass::Groups::Indirect(off) => self.kernel.dispatch_indirect(pass, bound, &$b.indirect, off),
                }
            }

            $(
                fn prepare(&self, encoder: &mut wgpu::CommandEncoder, b: &$crate::gpu::buffers::Buffers) {
                    $(encoder.clear_buffer(&b.$clear, 0, None);)+
                }
            )?

            $(
                fn prepare(&self, $pe: &mut wgpu::CommandEncoder, $pb: &$crate::gpu::buffers::Buffers) $prep
            )?
        }
    };
}
pub(crate) use simple_pass;
