//! [`GpuDetector`]: every stage's pipeline built once (the list is
//! [`super::stages`]), chained into one command encoder; [`GpuWorkspace`]: the
//! buffers and bind groups of one frame size, reused across frames, with a
//! ring of staging buffers ([`super::readback`]) so frame N+1 can run while
//! frame N is read back.
//!
//! The embedding API ([`GpuDetector::encode`], [`GpuDetector::encode_readback`])
//! only records commands: it never submits and never polls.

use super::buffers::Buffers;
use super::context::{GpuContext, map_blocking};
use super::readback::{Finish, Ring};
pub use super::readback::{Frame, Ticket, to_keypoint};
pub use super::stages::STAGES;
use super::stages::{Bound, Passes, Timestamps};
use crate::config::Config;
use crate::error::{Error, Result};
use crate::image::{GrayView, Plane};
use crate::spec::{self, level_mask};

/// Side of the frame whose workspace a detector warms its pipelines up on
/// (`Passes::new`): a few tiles a level, a small allocation.
const WARM_UP_SIDE: u32 = 64;

/// Where a frame comes from.
#[derive(Clone, Copy, Debug)]
pub enum GpuInput<'a> {
    /// The gray bytes were written with [`GpuWorkspace::write_gray`] (or the
    /// caller wrote `buffers.input` itself): 8-bit, 4 pixels per word, no padding.
    Written,
    /// A buffer of the caller's in the same packed 8-bit gray layout; copied in.
    GrayBuffer(&'a wgpu::Buffer),
    /// A texture of the frame's size (Rgba8Unorm, Bgra8Unorm or R8Unorm),
    /// converted with SPEC 0's integer BT.601 weights.
    Texture(&'a wgpu::TextureView, wgpu::TextureFormat),
}

/// The GPU side of one frame size: buffers, bind groups, the staging ring.
pub struct GpuWorkspace {
    /// Every buffer by name: `keypoints`, `descriptors`, `counters` and
    /// `indirect` are the outputs an embedder's next pass can use directly.
    pub buffers: Buffers,
    bound: Bound,
    textures: Option<(wgpu::TextureView, wgpu::TextureFormat, wgpu::BindGroup)>,
    ring: Ring,
    timestamps: Option<Timestamps>,
}

impl std::fmt::Debug for GpuWorkspace {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuWorkspace").field("size", &self.buffers.size()).field("ring", &self.ring.len()).finish()
    }
}

impl GpuWorkspace {
    /// Writes an 8-bit gray frame into `buffers.input` through the queue
    /// (staged for the next submit; no submit here). Its size must be the workspace's.
    pub fn write_gray(&self, queue: &wgpu::Queue, image: GrayView<'_>) -> Result<()> {
        image.check()?;
        let (w, h) = self.buffers.size();
        if (image.width(), image.height()) != (w, h) {
            return Err(Error::InvalidImage {
                width: image.width(),
                height: image.height(),
                reason: format!("the workspace is for {w}x{h} frames"),
            });
        }
        let mut bytes = Vec::with_capacity((w as usize * h as usize).next_multiple_of(4));
        for y in 0..h {
            bytes.extend_from_slice(image.row(y));
        }
        bytes.resize(bytes.len().next_multiple_of(4), 0);
        queue.write_buffer(&self.buffers.input, 0, &bytes);
        Ok(())
    }

    /// The number of staging buffers (frames that can be in flight).
    pub fn ring_len(&self) -> usize {
        self.ring.len()
    }
}

/// Options of a [`GpuDetector`].
#[derive(Clone, Debug)]
pub struct GpuDetectorOptions {
    /// Staging buffers per workspace (frames in flight), >= 1.
    pub ring: usize,
    /// Record per-pass timestamps when the adapter supports them.
    pub profile: bool,
    /// Keypoints the first frame of a workspace copies to host-visible memory
    /// (the copy's size is fixed when it is recorded, before the count is
    /// known); later frames copy a little more than the recent counts
    /// ([`readback`](super::readback)). A frame with more is completed from
    /// a device-side copy with one more, blocking, transfer. 0 = always the
    /// whole capacity.
    pub readback_hint: u32,
}

impl Default for GpuDetectorOptions {
    fn default() -> Self {
        // KITTI frames give ~1400 L-FAST keypoints over 8 levels; 4096 covers
        // nearly every frame for 330 KB instead of the ~6 MB of full capacity.
        Self { ring: 3, profile: false, readback_hint: 4096 }
    }
}

/// The L-FAST detector and ORB descriptor as WGSL compute passes.
///
/// Keypoints and descriptors equal [`CpuDetector`](crate::cpu::CpuDetector)'s
/// (see docs/algorithm.md for the one exception, `orientation_bins = 0`).
pub struct GpuDetector {
    ctx: GpuContext,
    cfg: Config,
    opts: GpuDetectorOptions,
    passes: Passes,
    mask_radius: u32,
}

impl std::fmt::Debug for GpuDetector {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuDetector").field("adapter", &self.ctx.info.name).field("cfg", &self.cfg).finish()
    }
}

impl GpuDetector {
    /// Builds every pipeline on `ctx`'s device. Fails on an invalid config
    /// or a combination the GPU path does not implement.
    pub fn new(ctx: GpuContext, cfg: Config) -> Result<Self> {
        Self::with_options(ctx, cfg, GpuDetectorOptions::default())
    }

    /// [`new`](Self::new) with options.
    pub fn with_options(ctx: GpuContext, cfg: Config, opts: GpuDetectorOptions) -> Result<Self> {
        cfg.validate()?;
        crate::config::gpu_supports(&cfg)?;
        if cfg.distribution {
            return Err(Error::Unsupported {
                reason: "`distribution` (ORB-SLAM quadtree) runs on the CPU backend only".into(),
            });
        }
        if opts.ring == 0 {
            return Err(Error::InvalidConfig { field: "ring", reason: "must be at least 1".into() });
        }
        ctx.check_lost_polled()?;
        let need = super::SHADERS
            .iter()
            .map(|s| {
                s.bindings
                    .iter()
                    .filter(|b| matches!(b.slot, super::kernel::Slot::Read | super::kernel::Slot::ReadWrite))
                    .count()
            })
            .max()
            .unwrap_or(0) as u32;
        let have = ctx.device.limits().max_storage_buffers_per_shader_stage;
        if have < need {
            return Err(Error::GpuLimits {
                reason: format!("the passes bind up to {need} storage buffers, {} allows {have}", ctx.info.name),
            });
        }
        // On lfast's own device, the pipelines are warmed up on a small
        // workspace as they are built (Passes::new); none on an embedder's.
        let small =
            if ctx.owns_queue() { Buffers::new(&ctx.device, &cfg, WARM_UP_SIDE, WARM_UP_SIDE).ok() } else { None };
        let passes = Passes::new(&ctx.device, small.as_ref().map(|b| (&ctx.queue, b)))?;
        Ok(Self { ctx, cfg, opts, passes, mask_radius: spec::mask_radius() })
    }

    /// The device this detector runs on.
    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// The configuration.
    pub fn config(&self) -> &Config {
        &self.cfg
    }

    /// A workspace for `width x height` frames.
    pub fn workspace(&self, width: u32, height: u32) -> Result<GpuWorkspace> {
        crate::image::check_size(width, height)?;
        self.ctx.check_lost_polled()?;
        let d = &self.ctx.device;
        let oom = d.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let val = d.push_error_scope(wgpu::ErrorFilter::Validation);
        let built = Buffers::new(d, &self.cfg, width, height).and_then(|buffers| {
            let staging = super::readback::largest_buffer(&self.cfg, &buffers);
            if staging > d.limits().max_buffer_size {
                return Err(Error::GpuLimits {
                    reason: format!(
                        "a {width}x{height} frame needs readback buffers of {staging} bytes, the device allows {}",
                        d.limits().max_buffer_size
                    ),
                });
            }
            let bound = self.passes.bind(d, &buffers)?;
            let ring = Ring::new(d, &self.cfg, &buffers, self.opts.ring, self.opts.readback_hint);
            Ok((buffers, bound, ring))
        });
        let val_err = pollster::block_on(val.pop());
        let oom_err = pollster::block_on(oom.pop());
        if let Some(e) = oom_err {
            return Err(Error::GpuOutOfMemory { reason: format!("workspace for {width}x{height}: {e}") });
        }
        if let Some(e) = val_err {
            return Err(Error::Gpu { reason: format!("workspace for {width}x{height}: {e}") });
        }
        let (buffers, bound, ring) = built?;
        let timestamps = (self.opts.profile && self.ctx.has_timestamps()).then(|| Timestamps::new(d));
        Ok(GpuWorkspace { buffers, bound, textures: None, ring, timestamps })
    }

    /// Makes `ws` fit `width x height`: kept when it already has that size,
    /// laid out anew in the same buffers when they are large enough, and
    /// reallocated only when the frame grew.
    pub fn prepare_workspace(&self, ws: &mut Option<GpuWorkspace>, width: u32, height: u32) -> Result<()> {
        if let Some(w) = ws.as_mut() {
            if w.buffers.size() == (width, height) {
                return Ok(());
            }
            crate::image::check_size(width, height)?;
            if w.buffers.relayout(&self.ctx.queue, &self.cfg, width, height) {
                w.textures = None;
                return Ok(());
            }
        }
        *ws = None; // free the old buffers before allocating larger ones
        *ws = Some(self.workspace(width, height)?);
        Ok(())
    }

    /// Sets the mask for the following frames (`None` = no mask): nonzero =
    /// on, of the workspace's frame size. Level masks are built on the CPU
    /// and written through the queue.
    pub fn set_mask(&self, ws: &mut GpuWorkspace, mask: Option<GrayView<'_>>) -> Result<()> {
        let b = &mut ws.buffers;
        let (w, h) = b.size();
        let use_mask = match mask {
            None => 0,
            Some(m) => {
                m.check()?;
                if (m.width(), m.height()) != (w, h) {
                    return Err(Error::MaskSize {
                        mask_width: m.width(),
                        mask_height: m.height(),
                        width: w,
                        height: h,
                    });
                }
                let m = m.to_plane();
                let mut words = vec![0u32; b.layout.total_px as usize];
                for (l, &(lw, lh)) in b.layout.sizes.iter().enumerate() {
                    let lm = level_mask(&m, lw, lh, self.mask_radius);
                    let r = b.layout.level_range(l);
                    for (d, &v) in words[r].iter_mut().zip(&lm.data) {
                        *d = v as u32;
                    }
                }
                // allocated by the first mask; the stages that read it bound anew
                if b.allocate_mask(&self.ctx.device) {
                    ws.bound = self.passes.bind(&self.ctx.device, b)?;
                }
                if !words.is_empty() {
                    self.ctx.queue.write_buffer(&b.mask, 0, bytemuck::cast_slice(&words));
                }
                1
            }
        };
        if b.layout.params.use_mask != use_mask {
            b.layout.params.use_mask = use_mask;
            self.ctx.queue.write_buffer(&b.params, 0, bytemuck::bytes_of(&b.layout.params));
        }
        Ok(())
    }

    /// Records the whole pipeline for one frame into the caller's encoder.
    /// Never submits or polls. Afterwards `ws.buffers.keypoints` holds
    /// `counters[1]` keypoints in SPEC 9 order (see [`GpuKeypoint`](super::buffers::GpuKeypoint)),
    /// `ws.buffers.descriptors` their descriptors, and `ws.buffers.indirect`
    /// dispatch and draw arguments sized by the count.
    pub fn encode(&self, enc: &mut wgpu::CommandEncoder, input: GpuInput<'_>, ws: &mut GpuWorkspace) -> Result<()> {
        self.ctx.check_lost()?;
        let p = &self.passes;
        if let GpuInput::Texture(view, format) = input {
            let actual = view.texture().format();
            if actual.remove_srgb_suffix() != format.remove_srgb_suffix() {
                let (w, h) = ws.buffers.size();
                return Err(Error::InvalidImage {
                    width: w,
                    height: h,
                    reason: format!("the texture is {actual:?} but was passed as {format:?}"),
                });
            }
            let same = ws.textures.as_ref().is_some_and(|(v, f, _)| v == view && *f == format);
            if !same {
                let bg = p.luma.bind_texture(&self.ctx.device, &ws.buffers, view, format)?;
                ws.textures = Some((view.clone(), format, bg));
            }
        }
        if let GpuInput::GrayBuffer(src) = input {
            let (w, h) = ws.buffers.size();
            let len = (w as u64 * h as u64).next_multiple_of(4);
            if src.size() < len {
                return Err(Error::InvalidImage {
                    width: w,
                    height: h,
                    reason: format!("gray buffer has {} bytes, {len} needed", src.size()),
                });
            }
            enc.copy_buffer_to_buffer(src, 0, &ws.buffers.input, 0, len);
        }
        let texture = match (&input, &ws.textures) {
            (GpuInput::Texture(..), Some((_, _, bg))) => Some(bg),
            _ => None,
        };
        let b = &ws.buffers;
        p.record_all(enc, b, &ws.bound, ws.timestamps.as_ref(), |stage, cp| match texture {
            Some(bg) if stage == "luma" => {
                p.luma.record_texture(cp, bg, b);
                true
            }
            _ => false,
        });
        Ok(())
    }

    /// Blocking convenience: upload, run, read back one frame.
    pub fn detect_and_compute(
        &self,
        ws: &mut Option<GpuWorkspace>,
        image: GrayView<'_>,
        mask: Option<GrayView<'_>>,
    ) -> Result<Frame> {
        let (t, _) = self.submit(ws, image, mask)?;
        let ws = ws.as_mut().ok_or_else(|| Error::Gpu { reason: "no workspace".into() })?;
        self.finish_readback(ws, t)
    }

    /// Uploads `image`, records the whole pipeline and its readback, submits
    /// them and starts the readback: [`detect_and_compute`](Self::detect_and_compute)
    /// up to the wait, and each frame of [`Detector::stream`](crate::Detector::stream).
    pub(crate) fn submit(
        &self,
        ws: &mut Option<GpuWorkspace>,
        image: GrayView<'_>,
        mask: Option<GrayView<'_>>,
    ) -> Result<(Ticket, wgpu::SubmissionIndex)> {
        image.check()?;
        self.ctx.check_lost_polled()?;
        self.prepare_workspace(ws, image.width(), image.height())?;
        let ws = ws.as_mut().ok_or_else(|| Error::Gpu { reason: "no workspace".into() })?;
        self.set_mask(ws, mask)?;
        ws.write_gray(&self.ctx.queue, image)?;
        let scope = self.ctx.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let mut enc = self.ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("lfast") });
        self.encode(&mut enc, GpuInput::Written, ws)?;
        let t = self.encode_readback(&mut enc, ws)?;
        let index = self.ctx.queue.submit([enc.finish()]);
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(Error::Gpu { reason: e.to_string() });
        }
        self.start_readback(ws, t)?;
        Ok((t, index))
    }

    /// Runs SPEC 0-7 and reads back the edge map E of level 0 (255 = edge).
    pub fn edge_image(&self, ws: &mut Option<GpuWorkspace>, image: GrayView<'_>) -> Result<Plane<u8>> {
        image.check()?;
        self.ctx.check_lost_polled()?;
        self.prepare_workspace(ws, image.width(), image.height())?;
        let ws = ws.as_mut().ok_or_else(|| Error::Gpu { reason: "no workspace".into() })?;
        ws.write_gray(&self.ctx.queue, image)?;
        let mut enc = self.ctx.device.create_command_encoder(&Default::default());
        self.encode(&mut enc, GpuInput::Written, ws)?;
        self.ctx.queue.submit([enc.finish()]);
        let (w, h) = ws.buffers.size();
        // E is column-packed (level 0 first): a quarter of a u32 plane to read
        let words = ws.buffers.layout.packed_range(0).len() as u64;
        let bytes = self.ctx.read_range(&ws.buffers.edges, 0, words * 4)?;
        Plane::from_vec(w, h, super::layout::unpack_level(w, h, bytemuck::cast_slice(&bytes)))
    }

    /// Reads any buffer of the workspace back (blocking; for debugging and the
    /// stage-by-stage comparisons).
    pub fn read_buffer(&self, buf: &wgpu::Buffer) -> Result<Vec<u8>> {
        self.ctx.read_buffer(buf)
    }

    /// Records the copy of this frame's outputs into the next free staging
    /// buffer of the ring and returns its ticket; `Err` when all are in flight.
    /// After submitting, call [`start_readback`](Self::start_readback).
    pub fn encode_readback(&self, enc: &mut wgpu::CommandEncoder, ws: &mut GpuWorkspace) -> Result<Ticket> {
        ws.ring.encode(&self.ctx.device, enc, &ws.buffers, ws.timestamps.as_ref())
    }

    /// Starts mapping a recorded slot (call after the submit that carries it).
    pub fn start_readback(&self, ws: &mut GpuWorkspace, t: Ticket) -> Result<()> {
        ws.ring.start(t)
    }

    /// The frame's keypoints and descriptors if its staging buffer is mapped
    /// (someone must poll the device: [`finish_readback`](Self::finish_readback)
    /// does, or the caller's own `device.poll`), else `None`.
    pub fn try_finish_readback(&self, ws: &mut GpuWorkspace, t: Ticket) -> Result<Option<Frame>> {
        self.ctx.check_lost()?;
        ws.ring.try_finish(&self.ctx, &self.cfg, t)
    }

    /// [`try_finish_readback`](Self::try_finish_readback) telling an overrun
    /// apart: with frames in flight, a frame whose keypoints outgrew its
    /// copy, and whose rest a later frame has overwritten, is
    /// [`Finish::Overrun`]; run it again (`Detector::stream` does).
    pub fn finish_frame(&self, ws: &mut GpuWorkspace, t: Ticket) -> Result<Finish> {
        self.ctx.check_lost()?;
        ws.ring.finish(&self.ctx, &self.cfg, t)
    }

    /// Waits for a frame's readback and returns it.
    pub fn finish_readback(&self, ws: &mut GpuWorkspace, t: Ticket) -> Result<Frame> {
        loop {
            if let Some(f) = self.try_finish_readback(ws, t)? {
                return Ok(f);
            }
            self.ctx.wait()?;
        }
    }

    /// The blocking map used by tests.
    #[doc(hidden)]
    pub fn map_blocking(&self, staging: &wgpu::Buffer, len: u64) -> Result<Vec<u8>> {
        map_blocking(&self.ctx, staging, len)
    }
}
