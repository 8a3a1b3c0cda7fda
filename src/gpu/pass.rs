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
}
