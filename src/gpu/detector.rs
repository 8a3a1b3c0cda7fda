//! [`GpuDetector`]: every stage's pipeline built once, chained into one
//! command encoder; [`GpuWorkspace`]: the buffers and bind groups of one
//! frame size, reused across frames, with a ring of staging buffers so
//! frame N+1 can run while frame N is read back.
//!
//! The embedding API ([`GpuDetector::encode`], [`GpuDetector::encode_readback`])
//! only records commands: it never submits and never polls.

use super::blur::BlurPass;
use super::buffers::{Buffers, DESC_WORDS, GpuKeypoint, KP_WORDS, counter};
use super::classify::ClassifyPass;
use super::context::{GpuContext, map_blocking};
use super::corner_nms::CornerNmsPass;
use super::gradient::GradientPass;
use super::histogram::HistogramPass;
use super::hysteresis::HysteresisPass;
use super::lfast::LfastPass;
use super::local_threshold::LocalThresholdPass;
use super::luma::LumaPass;
use super::median::MedianPass;
use super::nms::NmsPass;
use super::orb::OrbPass;
use super::orientation::OrientationPass;
use super::otsu::OtsuPass;
use super::pass::Pass;
use super::pyramid::PyramidPass;
use super::response::ResponsePass;
use super::rules::RulesPass;
use super::select::SelectPass;
use crate::config::Config;
use crate::cpu::{level_mask, orientation};
use crate::error::{Error, Result};
use crate::image::{GrayView, Plane};
use crate::keypoint::{Descriptor, KeyPoint};

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

/// The stages in the order they are recorded (one compute pass each).
pub const STAGES: [&str; 18] = [
    "luma",
    "pyramid",
    "median",
    "gradient",
    "nms",
    "histogram",
    "otsu",
    "local_threshold",
    "classify",
    "rules",
    "hysteresis",
    "lfast",
    "response",
    "corner_nms",
    "select",
    "blur",
    "orientation",
    "orb",
];

#[derive(Debug)]
struct Passes {
    luma: LumaPass,
    pyramid: PyramidPass,
    median: MedianPass,
    gradient: GradientPass,
    nms: NmsPass,
    histogram: HistogramPass,
    otsu: OtsuPass,
    local_threshold: LocalThresholdPass,
    classify: ClassifyPass,
    rules: RulesPass,
    hysteresis: HysteresisPass,
    lfast: LfastPass,
    response: ResponsePass,
    corner_nms: CornerNmsPass,
    select: SelectPass,
    blur: BlurPass,
    orientation: OrientationPass,
    orb: OrbPass,
}

/// The bind groups of every pass for one [`Buffers`].
struct Bound {
    luma: <LumaPass as Pass>::Bound,
    pyramid: <PyramidPass as Pass>::Bound,
    median: <MedianPass as Pass>::Bound,
    gradient: <GradientPass as Pass>::Bound,
    nms: <NmsPass as Pass>::Bound,
    histogram: <HistogramPass as Pass>::Bound,
    otsu: <OtsuPass as Pass>::Bound,
    local_threshold: <LocalThresholdPass as Pass>::Bound,
    classify: <ClassifyPass as Pass>::Bound,
    rules: <RulesPass as Pass>::Bound,
    hysteresis: <HysteresisPass as Pass>::Bound,
    lfast: <LfastPass as Pass>::Bound,
    response: <ResponsePass as Pass>::Bound,
    corner_nms: <CornerNmsPass as Pass>::Bound,
    select: <SelectPass as Pass>::Bound,
    blur: <BlurPass as Pass>::Bound,
    orientation: <OrientationPass as Pass>::Bound,
    orb: <OrbPass as Pass>::Bound,
}

impl Passes {
    fn new(device: &wgpu::Device) -> Self {
        Self {
            luma: Pass::new(device),
            pyramid: Pass::new(device),
            median: Pass::new(device),
            gradient: Pass::new(device),
            nms: Pass::new(device),
            histogram: Pass::new(device),
            otsu: Pass::new(device),
            local_threshold: Pass::new(device),
            classify: Pass::new(device),
            rules: Pass::new(device),
            hysteresis: Pass::new(device),
            lfast: Pass::new(device),
            response: Pass::new(device),
            corner_nms: Pass::new(device),
            select: Pass::new(device),
            blur: Pass::new(device),
            orientation: Pass::new(device),
            orb: Pass::new(device),
        }
    }

    fn bind(&self, d: &wgpu::Device, b: &Buffers) -> Result<Bound> {
        Ok(Bound {
            luma: self.luma.bind(d, b)?,
            pyramid: self.pyramid.bind(d, b)?,
            median: self.median.bind(d, b)?,
            gradient: self.gradient.bind(d, b)?,
            nms: self.nms.bind(d, b)?,
            histogram: self.histogram.bind(d, b)?,
            otsu: self.otsu.bind(d, b)?,
            local_threshold: self.local_threshold.bind(d, b)?,
            classify: self.classify.bind(d, b)?,
            rules: self.rules.bind(d, b)?,
            hysteresis: self.hysteresis.bind(d, b)?,
            lfast: self.lfast.bind(d, b)?,
            response: self.response.bind(d, b)?,
            corner_nms: self.corner_nms.bind(d, b)?,
            select: self.select.bind(d, b)?,
            blur: self.blur.bind(d, b)?,
            orientation: self.orientation.bind(d, b)?,
            orb: self.orb.bind(d, b)?,
        })
    }
}

/// Per-pass GPU timestamps (when the adapter has `TIMESTAMP_QUERY`).
struct Timestamps {
    set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
}

/// State of one staging buffer of the readback ring.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum SlotState {
    Free,
    /// A copy was recorded; the caller must submit, then call `start_readback`.
    Recorded,
    /// `map_async` was called.
    Mapping,
}

struct Slot {
    staging: wgpu::Buffer,
    state: SlotState,
    mapped: std::sync::Arc<std::sync::Mutex<Option<std::result::Result<(), wgpu::BufferAsyncError>>>>,
    /// Keypoint slots copied into this staging buffer.
    copied: u64,
    /// All keypoint slots and descriptors of the frame, copied on the GPU
    /// (cheap, device-local) when the staging buffer holds fewer: the rest
    /// of a frame with more keypoints than the hint is read from here.
    spill: Option<wgpu::Buffer>,
    /// Frames recorded into this slot so far: a ticket names slot and generation.
    generation: u64,
}

/// A frame recorded into a staging slot; redeem it with
/// [`GpuDetector::start_readback`] after submitting, then `try_finish` / `finish_readback`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Ticket {
    slot: usize,
    generation: u64,
}

/// The GPU side of one frame size: buffers, bind groups, the staging ring.
pub struct GpuWorkspace {
    /// Every buffer by name: `keypoints`, `descriptors`, `counters` and
    /// `indirect` are the outputs an embedder's next pass can use directly.
    pub buffers: Buffers,
    bound: Bound,
    textures: Option<(wgpu::TextureView, wgpu::TextureFormat, wgpu::BindGroup)>,
    ring: Vec<Slot>,
    next: usize,
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
    /// Keypoints copied to host-visible memory per frame, before the count is
    /// known (the copy's size is fixed when it is recorded). A frame with more
    /// is completed from a device-side copy with one more, blocking, transfer.
    /// Smaller is less PCIe traffic per frame; 0 = the whole capacity.
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

/// Converts a GPU keypoint as the CPU path builds its [`KeyPoint`] (f64
/// position arithmetic, exact angle from the integer moments).
pub fn to_keypoint(cfg: &Config, k: &GpuKeypoint) -> KeyPoint {
    let s = cfg.level_scale(k.level);
    KeyPoint {
        pt: glam::Vec2::new(((k.px as f64 + 0.5) * s) as f32, ((k.py as f64 + 0.5) * s) as f32),
        size: (31.0 * s) as f32,
        angle: orientation::angle_deg(k.m10, k.m01),
        response: k.response,
        octave: k.level as i32,
        class_id: -1,
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
            .map(|s| s.bindings.iter().filter(|b| matches!(b.slot, super::kernel::Slot::Read | super::kernel::Slot::ReadWrite)).count())
            .max()
            .unwrap_or(0) as u32;
        let have = ctx.device.limits().max_storage_buffers_per_shader_stage;
        if have < need {
            return Err(Error::GpuLimits {
                reason: format!("the passes bind up to {need} storage buffers, {} allows {have}", ctx.info.name),
            });
        }
        let scope = ctx.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let passes = Passes::new(&ctx.device);
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(Error::Gpu { reason: format!("building the pipelines: {e}") });
        }
        let mask_radius = crate::cpu::CpuDetector::new(cfg.clone())?.mask_radius();
        Ok(Self { ctx, cfg, opts, passes, mask_radius })
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
            let spill = self.frame_slots(&buffers) * (KP_WORDS + DESC_WORDS) * 4;
            let staging = self.staging_size(&buffers).max(spill);
            if staging > d.limits().max_buffer_size {
                return Err(Error::GpuLimits {
                    reason: format!(
                        "a {width}x{height} frame needs readback buffers of {staging} bytes, the device allows {}",
                        d.limits().max_buffer_size
                    ),
                });
            }
            let bound = self.passes.bind(d, &buffers)?;
            let ring: Vec<Slot> = (0..self.opts.ring).map(|_| self.slot(&buffers)).collect();
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
        let timestamps = (self.opts.profile && self.ctx.has_timestamps()).then(|| {
            let n = 2 * STAGES.len() as u32;
            Timestamps {
                set: d.create_query_set(&wgpu::QuerySetDescriptor {
                    label: Some("lfast timestamps"),
                    ty: wgpu::QueryType::Timestamp,
                    count: n,
                }),
                resolve: d.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("lfast timestamps"),
                    size: n as u64 * 8,
                    usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                }),
            }
        });
        Ok(GpuWorkspace { buffers, bound, textures: None, ring, next: 0, timestamps })
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

    /// Keypoint slots a frame can fill: the capacity, or the cap when there is one.
    fn frame_slots(&self, b: &Buffers) -> u64 {
        let cap = b.allocated.keypoints;
        if self.cfg.n_features > 0 { cap.min(self.cfg.n_features as u64) } else { cap }
    }

    /// Keypoint slots the staging buffer receives (at most the hint).
    fn readback_slots(&self, b: &Buffers) -> u64 {
        let all = self.frame_slots(b);
        match self.opts.readback_hint {
            0 => all,
            h => all.min(h as u64),
        }
    }

    fn staging_size(&self, b: &Buffers) -> u64 {
        let n = self.readback_slots(b);
        16 + n * KP_WORDS * 4 + n * DESC_WORDS * 4 + 16 * STAGES.len() as u64
    }

    fn slot(&self, b: &Buffers) -> Slot {
        Slot {
            staging: self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("lfast readback"),
                size: self.staging_size(b),
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            state: SlotState::Free,
            mapped: Default::default(),
            copied: 0,
            spill: (self.readback_slots(b) < self.frame_slots(b)).then(|| {
                let n = self.frame_slots(b);
                self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("lfast readback spill"),
                    size: n * (KP_WORDS + DESC_WORDS) * 4,
                    usage: wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                })
            }),
            generation: 0,
        }
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
                    return Err(Error::MaskSize { mask_width: m.width(), mask_height: m.height(), width: w, height: h });
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

    fn compute_pass<'e>(
        enc: &'e mut wgpu::CommandEncoder,
        ts: Option<&Timestamps>,
        stage: usize,
    ) -> wgpu::ComputePass<'e> {
        let timestamp_writes = ts.map(|t| wgpu::ComputePassTimestampWrites {
            query_set: &t.set,
            beginning_of_pass_write_index: Some(2 * stage as u32),
            end_of_pass_write_index: Some(2 * stage as u32 + 1),
        });
        enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(STAGES[stage]), timestamp_writes })
    }

    /// Records the whole pipeline for one frame into the caller's encoder.
    /// Never submits or polls. Afterwards `ws.buffers.keypoints` holds
    /// `counters[1]` keypoints in SPEC 9 order (see [`GpuKeypoint`]),
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
        let b = &ws.buffers;
        let bd = &ws.bound;
        let ts = ws.timestamps.as_ref();
        macro_rules! stage {
            ($i:expr, $pass:expr, $bound:expr) => {{
                $pass.prepare(enc, b);
                let mut cp = Self::compute_pass(enc, ts, $i);
                $pass.record(&mut cp, $bound, b);
            }};
        }
        {
            let mut cp = Self::compute_pass(enc, ts, 0);
            match (&input, &ws.textures) {
                (GpuInput::Texture(..), Some((_, _, bg))) => p.luma.record_texture(&mut cp, bg, b),
                _ => p.luma.record(&mut cp, &bd.luma, b),
            }
        }
        stage!(1, p.pyramid, &bd.pyramid);
        stage!(2, p.median, &bd.median);
        stage!(3, p.gradient, &bd.gradient);
        stage!(4, p.nms, &bd.nms);
        stage!(5, p.histogram, &bd.histogram);
        stage!(6, p.otsu, &bd.otsu);
        stage!(7, p.local_threshold, &bd.local_threshold);
        stage!(8, p.classify, &bd.classify);
        stage!(9, p.rules, &bd.rules);
        stage!(10, p.hysteresis, &bd.hysteresis);
        stage!(11, p.lfast, &bd.lfast);
        stage!(12, p.response, &bd.response);
        stage!(13, p.corner_nms, &bd.corner_nms);
        stage!(14, p.select, &bd.select);
        stage!(15, p.blur, &bd.blur);
        stage!(16, p.orientation, &bd.orientation);
        stage!(17, p.orb, &bd.orb);
        Ok(())
    }

    /// Records the copy of this frame's outputs into the next free staging
    /// buffer of the ring and returns its ticket; `Err` when all are in flight.
    /// After submitting, call [`start_readback`](Self::start_readback).
    pub fn encode_readback(&self, enc: &mut wgpu::CommandEncoder, ws: &mut GpuWorkspace) -> Result<Ticket> {
        let n = ws.ring.len();
        let i = (0..n).map(|k| (ws.next + k) % n).find(|&i| ws.ring[i].state == SlotState::Free).ok_or_else(|| {
            Error::Gpu { reason: format!("all {n} readback buffers are in flight; finish one first") }
        })?;
        ws.next = (i + 1) % n;
        let b = &ws.buffers;
        let slots = self.readback_slots(b);
        let slot = &mut ws.ring[i];
        let kp_bytes = slots * KP_WORDS * 4;
        let desc_bytes = slots * DESC_WORDS * 4;
        enc.copy_buffer_to_buffer(&b.counters, 0, &slot.staging, 0, 16);
        enc.copy_buffer_to_buffer(&b.keypoints, 0, &slot.staging, 16, kp_bytes);
        enc.copy_buffer_to_buffer(&b.descriptors, 0, &slot.staging, 16 + kp_bytes, desc_bytes);
        if let Some(spill) = &slot.spill {
            let all = self.frame_slots(b);
            enc.copy_buffer_to_buffer(&b.keypoints, 0, spill, 0, all * KP_WORDS * 4);
            enc.copy_buffer_to_buffer(&b.descriptors, 0, spill, all * KP_WORDS * 4, all * DESC_WORDS * 4);
        }
        if let Some(t) = &ws.timestamps {
            let n = 2 * STAGES.len() as u32;
            enc.resolve_query_set(&t.set, 0..n, &t.resolve, 0);
            enc.copy_buffer_to_buffer(&t.resolve, 0, &slot.staging, 16 + kp_bytes + desc_bytes, n as u64 * 8);
        }
        slot.copied = slots;
        slot.state = SlotState::Recorded;
        slot.generation += 1;
        Ok(Ticket { slot: i, generation: slot.generation })
    }

    /// Starts mapping a recorded slot (call after the submit that carries it).
    pub fn start_readback(&self, ws: &mut GpuWorkspace, t: Ticket) -> Result<()> {
        let slot = ticket_slot(ws, t)?;
        if slot.state != SlotState::Recorded {
            return Err(Error::Gpu { reason: format!("readback slot {} is {:?}, not recorded", t.slot, slot.state) });
        }
        let flag = slot.mapped.clone();
        if let Ok(mut g) = flag.lock() {
            *g = None;
        }
        slot.staging.slice(..).map_async(wgpu::MapMode::Read, move |r| {
            if let Ok(mut g) = flag.lock() {
                *g = Some(r);
            }
        });
        slot.state = SlotState::Mapping;
        Ok(())
    }

    /// The frame's keypoints and descriptors if its staging buffer is mapped
    /// (someone must poll the device: [`finish_readback`](Self::finish_readback)
    /// does, or the caller's own `device.poll`), else `None`.
    pub fn try_finish_readback(&self, ws: &mut GpuWorkspace, t: Ticket) -> Result<Option<Frame>> {
        self.ctx.check_lost()?;
        let profiled = ws.timestamps.is_some();
        let slot = ticket_slot(ws, t)?;
        if slot.state != SlotState::Mapping {
            return Err(Error::Gpu { reason: format!("readback slot {} is {:?}, not mapping", t.slot, slot.state) });
        }
        let done = slot.mapped.lock().ok().and_then(|mut g| g.take());
        let Some(res) = done else { return Ok(None) };
        slot.state = SlotState::Free;
        if let Err(e) = res {
            self.ctx.check_lost_polled()?;
            return Err(Error::Gpu { reason: format!("map_async: {e}") });
        }
        let frame = {
            let view = slot.staging.slice(..).get_mapped_range().map_err(|e| Error::Gpu { reason: format!("{e:?}") })?;
            parse_frame(&self.cfg, &view, slot.copied, profiled, self.ctx.queue.get_timestamp_period())
        };
        slot.staging.unmap();
        let mut frame = frame?;
        if frame.count > slot.copied {
            // more keypoints than the hint: the rest from the device-side copy
            let spill = slot.spill.as_ref().ok_or_else(|| Error::Gpu {
                reason: format!("GPU reported {} keypoints, only {} slots exist", frame.count, slot.copied),
            })?;
            let all = spill.size() / ((KP_WORDS + DESC_WORDS) * 4);
            let (from, to) = (slot.copied, frame.count.min(all));
            let kps = self.ctx.read_range(spill, from * KP_WORDS * 4, (to - from) * KP_WORDS * 4)?;
            let descs = self.ctx.read_range(spill, all * KP_WORDS * 4 + from * DESC_WORDS * 4, (to - from) * DESC_WORDS * 4)?;
            let raw: Vec<GpuKeypoint> = bytemuck::pod_collect_to_vec(&kps);
            frame.keypoints.extend(raw.iter().map(|k| to_keypoint(&self.cfg, k)));
            frame.raw.extend(raw);
            frame.descriptors.extend(descs.chunks_exact(32).map(|c| c.try_into().unwrap_or([0; 32])));
        }
        Ok(Some(frame))
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

    /// Blocking convenience: upload, run, read back one frame.
    pub fn detect_and_compute(
        &self,
        ws: &mut Option<GpuWorkspace>,
        image: GrayView<'_>,
        mask: Option<GrayView<'_>>,
    ) -> Result<Frame> {
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
        self.ctx.queue.submit([enc.finish()]);
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(Error::Gpu { reason: e.to_string() });
        }
        self.start_readback(ws, t)?;
        self.finish_readback(ws, t)
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
        let words = self.ctx.read_range(&ws.buffers.edges, 0, w as u64 * h as u64 * 4)?;
        let data: Vec<u8> = bytemuck::cast_slice::<u8, u32>(&words).iter().map(|&v| v as u8).collect();
        Plane::from_vec(w, h, data)
    }

    /// Reads any buffer of the workspace back (blocking; for debugging and the
    /// stage-by-stage comparisons).
    pub fn read_buffer(&self, buf: &wgpu::Buffer) -> Result<Vec<u8>> {
        self.ctx.read_buffer(buf)
    }

    /// The blocking map used by tests.
    #[doc(hidden)]
    pub fn map_blocking(&self, staging: &wgpu::Buffer, len: u64) -> Result<Vec<u8>> {
        map_blocking(&self.ctx, staging, len)
    }
}

/// The slot a ticket names, if the ticket is current (not redeemed, not from another frame).
fn ticket_slot(ws: &mut GpuWorkspace, t: Ticket) -> Result<&mut Slot> {
    match ws.ring.get_mut(t.slot) {
        Some(s) if s.generation == t.generation => Ok(s),
        Some(_) => Err(Error::Gpu { reason: format!("stale readback ticket (slot {} was reused by a later frame)", t.slot) }),
        None => Err(Error::Gpu { reason: format!("unknown readback ticket (slot {})", t.slot) }),
    }
}

/// One frame's results, read back.
#[derive(Clone, Debug, Default)]
pub struct Frame {
    /// Keypoints in SPEC 9 order, as the CPU path reports them.
    pub keypoints: Vec<KeyPoint>,
    /// `descriptors[i]` belongs to `keypoints[i]`.
    pub descriptors: Vec<Descriptor>,
    /// The keypoints as the GPU stored them (level coordinates, moments, bin).
    pub raw: Vec<GpuKeypoint>,
    /// Per stage GPU time in milliseconds, when profiling.
    pub pass_ms: Vec<(&'static str, f64)>,
    /// The keypoint count the GPU wrote.
    pub count: u64,
}

fn parse_frame(cfg: &Config, bytes: &[u8], slots: u64, ts: bool, period_ns: f32) -> Result<Frame> {
    let word = |i: usize| u32::from_le_bytes([bytes[4 * i], bytes[4 * i + 1], bytes[4 * i + 2], bytes[4 * i + 3]]);
    let count = word(counter::KEYPOINTS) as u64;
    let n = count.min(slots) as usize;
    let kp_off = 16;
    let desc_off = kp_off + slots as usize * KP_WORDS as usize * 4;
    let raw: Vec<GpuKeypoint> = bytemuck::pod_collect_to_vec(&bytes[kp_off..kp_off + n * KP_WORDS as usize * 4]);
    let descriptors: Vec<Descriptor> = bytes[desc_off..desc_off + n * 32]
        .chunks_exact(32)
        .map(|c| c.try_into().unwrap_or([0; 32]))
        .collect();
    let keypoints = raw.iter().map(|k| to_keypoint(cfg, k)).collect();
    let mut pass_ms = Vec::new();
    if ts {
        let t_off = desc_off + slots as usize * DESC_WORDS as usize * 4;
        let stamps: Vec<u64> = bytemuck::pod_collect_to_vec(&bytes[t_off..t_off + 2 * STAGES.len() * 8]);
        for (i, name) in STAGES.iter().enumerate() {
            let (a, b) = (stamps[2 * i], stamps[2 * i + 1]);
            pass_ms.push((*name, b.saturating_sub(a) as f64 * period_ns as f64 / 1e6));
        }
    }
    Ok(Frame { keypoints, descriptors, raw, pass_ms, count })
}
