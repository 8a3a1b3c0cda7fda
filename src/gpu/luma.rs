//! SPEC 0 on the GPU: shaders/luma.wgsl, mirroring `lfast::image::luma_bt601`.
//! Level 0 of `gray` from the input, either the packed gray bytes of `input`
//! (the [`Pass`] path) or an 8-bit RGBA / BGRA / R texture
//! ([`LumaPass::bind_texture`], [`LumaPass::record_texture`]).

use super::buffers::Buffers;
use super::kernel::{Binding, Kernel, PARAMS, Slot, b};
use super::pass::Pass;
use crate::error::{Error, Result};

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/luma.wgsl");

const INPUT: Binding = b(1, "input", Slot::Read);
const GRAY: Binding = b(2, "gray", Slot::ReadWrite);
const TEX: Binding = b(3, "tex", Slot::Texture);
const TEX_KIND: Binding = b(4, "tex_kind", Slot::Uniform);

/// Every binding the shader declares (both entry points).
pub const BINDINGS: &[Binding] = &[PARAMS, INPUT, GRAY, TEX, TEX_KIND];
/// The bindings of `from_bytes`.
pub const BYTES_BINDINGS: &[Binding] = &[PARAMS, INPUT, GRAY];
/// The bindings of `from_texture`.
pub const TEXTURE_BINDINGS: &[Binding] = &[PARAMS, GRAY, TEX, TEX_KIND];

/// The texture formats [`LumaPass::bind_texture`] accepts.
pub const TEXTURE_FORMATS: &[wgpu::TextureFormat] =
    &[wgpu::TextureFormat::Rgba8Unorm, wgpu::TextureFormat::Bgra8Unorm, wgpu::TextureFormat::R8Unorm];

/// The luma pass: gray bytes or a texture -> level 0 of `gray`.
#[derive(Debug)]
pub struct LumaPass {
    bytes: Kernel,
    texture: Kernel,
    /// `tex_kind` records: `[0]` for three colour channels, `[1]` for one (gray).
    kinds: [wgpu::Buffer; 2],
}

impl LumaPass {
    /// Binds a texture view of level 0's size as the input. `format` is the
    /// view's format: Rgba8Unorm, Bgra8Unorm (BT.601 luma, alpha ignored) or
    /// R8Unorm (the red channel is the gray value). Others, sRGB ones included
    /// (their texels are decoded to linear), are [`Error::Unsupported`].
    pub fn bind_texture(
        &self,
        device: &wgpu::Device,
        b: &Buffers,
        view: &wgpu::TextureView,
        format: wgpu::TextureFormat,
    ) -> Result<wgpu::BindGroup> {
        if !TEXTURE_FORMATS.contains(&format) {
            return Err(Error::Unsupported {
                reason: format!(
                    "input texture format {format:?}: the GPU luma pass reads Rgba8Unorm, Bgra8Unorm or R8Unorm"
                ),
            });
        }
        let tex = view.texture();
        let (w, h) = b.size();
        if (tex.width(), tex.height()) != (w, h) {
            return Err(Error::InvalidImage {
                width: tex.width(),
                height: tex.height(),
                reason: format!("the input texture must be {w}x{h}, the size the GPU buffers were made for"),
            });
        }
        if !tex.usage().contains(wgpu::TextureUsages::TEXTURE_BINDING) {
            return Err(Error::Gpu { reason: "the input texture lacks TextureUsages::TEXTURE_BINDING".into() });
        }
        let kind = &self.kinds[(format == wgpu::TextureFormat::R8Unorm) as usize];
        self.texture.bind_with(device, &[("P", &b.params), ("gray", &b.gray), ("tex_kind", kind)], &[("tex", view)])
    }

    /// Records the texture path with a bind group from [`bind_texture`](Self::bind_texture).
    pub fn record_texture(&self, pass: &mut wgpu::ComputePass<'_>, bound: &wgpu::BindGroup, b: &Buffers) {
        self.texture.dispatch(pass, bound, b.layout.packed_level_groups(0));
    }
}

impl Pass for LumaPass {
    type Bound = wgpu::BindGroup;
    const NAME: &'static str = "luma";

    fn new(device: &wgpu::Device) -> Self {
        let module = super::kernel::compile(device, Self::NAME, SOURCE);
        let kind = |v: u32| {
            super::kernel::init_buffer(
                device,
                "luma tex_kind",
                bytemuck::cast_slice(&[v, 0u32, 0, 0]),
                wgpu::BufferUsages::UNIFORM,
            )
        };
        Self {
            bytes: Kernel::from_module(device, "luma from_bytes", &module, "from_bytes", BYTES_BINDINGS),
            texture: Kernel::from_module(device, "luma from_texture", &module, "from_texture", TEXTURE_BINDINGS),
            kinds: [kind(0), kind(1)],
        }
    }

    /// Binds the byte path: `input` (written by the host) -> `gray` level 0.
    fn bind(&self, device: &wgpu::Device, b: &Buffers) -> Result<wgpu::BindGroup> {
        self.bytes.bind(device, &[("P", &b.params), ("input", &b.input), ("gray", &b.gray)])
    }

    fn record(&self, pass: &mut wgpu::ComputePass<'_>, bound: &wgpu::BindGroup, b: &Buffers) {
        self.bytes.dispatch(pass, bound, b.layout.quad_level_words(0));
    }
}
