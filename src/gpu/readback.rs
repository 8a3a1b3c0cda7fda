//! The readback ring: staging buffers a frame's count, keypoints, descriptors
//! and timestamps are copied into, mapped while the next frame runs, and
//! turned into a [`Frame`]. [`GpuDetector`](super::GpuDetector)'s
//! `encode_readback`, `start_readback`, `try_finish_readback` and
//! `finish_readback` drive a workspace's `Ring`.
//!
//! What a frame costs the host, once its staging buffer is mapped: the count
//! from the first word, then the used part only (`count` keypoints and
//! descriptors) cast with bytemuck from the mapped range and copied once,
//! and the exact angle of each keypoint ([`to_keypoint`]). The copy on the
//! GPU is sized from the counts of the frames before (the count itself is
//! known only once the frame has run): the largest of the last few, plus an
//! eighth and 64, and each staging buffer grows to fit that, so a sequence
//! settles on copying little more than it uses. A frame with more keypoints
//! than were copied is completed from a device-side copy of the whole list
//! (the spill) with one more, blocking, transfer.

use super::buffers::{Buffers, DESC_WORDS, GpuKeypoint, KP_WORDS, counter};
use super::context::GpuContext;
use super::stages::{STAGES, Timestamps};
use crate::config::Config;
use crate::error::{Error, Result};
use crate::keypoint::{Descriptor, KeyPoint};
use crate::spec::{self, angle};

/// Bytes before the keypoints in a staging buffer: the keypoint count
/// (`counter::KEYPOINTS`) and the three words after it.
const HEADER: u64 = 16;
/// Bytes of one keypoint and its descriptor.
const SLOT_BYTES: u64 = (KP_WORDS + DESC_WORDS) * 4;
/// Copies are sized in whole multiples of this many keypoints.
const COPY_STEP: u64 = 256;
/// Frames whose counts size the next copy.
const HISTORY: usize = 4;

/// Converts a GPU keypoint as the CPU path builds its [`KeyPoint`]
/// ([`spec::keypoint_at`] from the level pixel, exact angle from the integer moments).
pub fn to_keypoint(cfg: &Config, k: &GpuKeypoint) -> KeyPoint {
    to_keypoint_at(k, cfg.level_scale(k.level))
}

/// [`to_keypoint`] with the level's scale already known.
fn to_keypoint_at(k: &GpuKeypoint, s: f64) -> KeyPoint {
    spec::keypoint_at_sub(
        k.level,
        [k.px, k.py],
        k.sub_steps(),
        s,
        spec::LFAST_CENTRE,
        angle::angle_deg(k.m10, k.m01),
        k.response,
    )
}

/// State of one staging buffer of the ring.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum SlotState {
    Free,
    /// A copy was recorded; the caller must submit, then start the readback.
    Recorded,
    /// `map_async` was called.
    Mapping,
}

type MapResult = std::sync::Arc<std::sync::Mutex<Option<std::result::Result<(), wgpu::BufferAsyncError>>>>;

struct Slot {
    staging: wgpu::Buffer,
    /// Keypoints the staging buffer can receive.
    held: u64,
    state: SlotState,
    mapped: MapResult,
    /// Keypoints copied by the frame recorded last.
    copied: u64,
    /// Whether that frame copied its timestamps.
    profiled: bool,
    /// Frames recorded into this slot so far: a ticket names slot and generation.
    generation: u64,
    /// The ring's number of the frame recorded last ([`Ring::recorded`]).
    frame: u64,
}

/// What a frame's readback found ([`GpuDetector::finish_frame`](super::GpuDetector::finish_frame)).
#[derive(Debug)]
pub enum Finish {
    /// The frame, complete.
    Done(Frame),
    /// Not mapped yet.
    Pending,
    /// The frame had more keypoints than its copy held, and a frame recorded
    /// after it has since overwritten the spill holding the rest: run it
    /// again (as the newest frame its spill stays whole).
    Overrun {
        /// Keypoints the frame had.
        count: u64,
        /// Keypoints its copy held.
        copied: u64,
    },
}

/// A frame recorded into a staging slot; redeem it with
/// [`GpuDetector::start_readback`](super::GpuDetector::start_readback) after
/// submitting, then `try_finish_readback` / `finish_readback`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Ticket {
    slot: usize,
    generation: u64,
}

/// A workspace's staging buffers and what sizes their copies.
pub(super) struct Ring {
    slots: Vec<Slot>,
    next: usize,
    /// Keypoints a frame can have: the capacity, or the cap when there is one.
    frame_slots: u64,
    /// All keypoints and descriptors of the frame, copied on the GPU (cheap,
    /// device-local) when a copy may hold fewer than `frame_slots`.
    spill: Option<wgpu::Buffer>,
    /// Counts of the last frames read back, newest last.
    recent: std::collections::VecDeque<u64>,
    /// The copy before any frame was read back (0 = all slots).
    hint: u64,
    /// Frames recorded so far; the spill holds the last one's keypoints.
    recorded: u64,
}

/// Bytes of a staging buffer for `n` keypoints (timestamps after them).
fn staging_bytes(n: u64) -> u64 {
    HEADER + n * SLOT_BYTES + 16 * STAGES.len() as u64
}

/// Keypoint slots a frame of `b` can fill under `cfg`: the capacity, or the cap.
pub(super) fn frame_slots(cfg: &Config, b: &Buffers) -> u64 {
    super::footprint::final_slots(cfg, &b.allocated)
}

/// The largest staging or spill buffer a ring for `b` may allocate.
pub(super) fn largest_buffer(cfg: &Config, b: &Buffers) -> u64 {
    staging_bytes(frame_slots(cfg, b))
}

impl Ring {
    /// `len` staging buffers, each first sized for `hint` keypoints (0 = all).
    pub(super) fn new(device: &wgpu::Device, cfg: &Config, b: &Buffers, len: usize, hint: u32) -> Self {
        let frame_slots = frame_slots(cfg, b);
        let hint = hint as u64;
        let first = if hint == 0 { frame_slots } else { hint.min(frame_slots) };
        let spill = (first < frame_slots).then(|| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("lfast readback spill"),
                size: frame_slots * SLOT_BYTES,
                usage: wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        });
        let slots = (0..len)
            .map(|_| Slot {
                staging: staging(device, first),
                held: first,
                state: SlotState::Free,
                mapped: Default::default(),
                copied: 0,
                profiled: false,
                generation: 0,
                frame: 0,
            })
            .collect();
        Self { slots, next: 0, frame_slots, spill, recent: Default::default(), hint, recorded: 0 }
    }

    /// The number of staging buffers.
    pub(super) fn len(&self) -> usize {
        self.slots.len()
    }

    /// Keypoints the next frame copies: every slot without a spill, else the
    /// largest recent count plus a half and 64, in whole [`COPY_STEP`]s.
    fn want(&self) -> u64 {
        if self.spill.is_none() {
            return self.frame_slots;
        }
        let want = match self.recent.iter().max() {
            None if self.hint == 0 => self.frame_slots,
            None => self.hint,
            Some(&m) => (m + m / 2 + 64).next_multiple_of(COPY_STEP),
        };
        want.min(self.frame_slots)
    }

    /// Records the copy of this frame's outputs into the next free staging
    /// buffer (grown first when the copy needs more) and returns its ticket.
    pub(super) fn encode(
        &mut self,
        device: &wgpu::Device,
        enc: &mut wgpu::CommandEncoder,
        b: &Buffers,
        ts: Option<&Timestamps>,
    ) -> Result<Ticket> {
        let n = self.slots.len();
        let i =
            (0..n).map(|k| (self.next + k) % n).find(|&i| self.slots[i].state == SlotState::Free).ok_or_else(|| {
                Error::Gpu { reason: format!("all {n} readback buffers are in flight; finish one first") }
            })?;
        self.next = (i + 1) % n;
        let want = self.want();
        let frame_slots = self.frame_slots;
        let slot = &mut self.slots[i];
        if slot.held < want {
            let held = want.next_power_of_two().min(frame_slots);
            slot.staging = staging(device, held);
            slot.held = held;
        }
        let kp_bytes = want * KP_WORDS * 4;
        let desc_bytes = want * DESC_WORDS * 4;
        // the header: the keypoint count (and the three words after it)
        enc.copy_buffer_to_buffer(&b.counters, counter::KEYPOINTS as u64 * 4, &slot.staging, 0, HEADER);
        enc.copy_buffer_to_buffer(&b.keypoints, 0, &slot.staging, HEADER, kp_bytes);
        enc.copy_buffer_to_buffer(&b.descriptors, 0, &slot.staging, HEADER + kp_bytes, desc_bytes);
        if let Some(spill) = &self.spill {
            enc.copy_buffer_to_buffer(&b.keypoints, 0, spill, 0, frame_slots * KP_WORDS * 4);
            enc.copy_buffer_to_buffer(
                &b.descriptors,
                0,
                spill,
                frame_slots * KP_WORDS * 4,
                frame_slots * DESC_WORDS * 4,
            );
        }
        if let Some(t) = ts {
            let q = Timestamps::QUERIES;
            enc.resolve_query_set(&t.set, 0..q, &t.resolve, 0);
            enc.copy_buffer_to_buffer(&t.resolve, 0, &slot.staging, HEADER + kp_bytes + desc_bytes, q as u64 * 8);
        }
        slot.copied = want;
        slot.profiled = ts.is_some();
        slot.state = SlotState::Recorded;
        slot.generation += 1;
        self.recorded += 1;
        slot.frame = self.recorded;
        Ok(Ticket { slot: i, generation: slot.generation })
    }

    /// Starts mapping a recorded slot (after the submit that carries its copy).
    pub(super) fn start(&mut self, t: Ticket) -> Result<()> {
        let slot = self.slot(t)?;
        if slot.state != SlotState::Recorded {
            return Err(Error::Gpu { reason: format!("readback slot {} is {:?}, not recorded", t.slot, slot.state) });
        }
        let flag = slot.mapped.clone();
        if let Ok(mut g) = flag.lock() {
            *g = None;
        }
        // only what the frame copied: the rest of the buffer may be larger
        let end = staging_bytes(slot.copied).min(slot.staging.size());
        slot.staging.slice(..end).map_async(wgpu::MapMode::Read, move |r| {
            if let Ok(mut g) = flag.lock() {
                *g = Some(r);
            }
        });
        slot.state = SlotState::Mapping;
        Ok(())
    }

    /// The frame if its staging buffer is mapped (someone must poll the
    /// device), else `None`; an [`Finish::Overrun`] is an error naming it.
    pub(super) fn try_finish(&mut self, ctx: &GpuContext, cfg: &Config, t: Ticket) -> Result<Option<Frame>> {
        match self.finish(ctx, cfg, t)? {
            Finish::Done(f) => Ok(Some(f)),
            Finish::Pending => Ok(None),
            Finish::Overrun { count, copied } => Err(Error::Gpu {
                reason: format!(
                    "the frame had {count} keypoints, its readback copied {copied}, and a frame recorded after it \
                     has overwritten the rest: finish a frame before recording the next when the counts may jump, \
                     or raise GpuDetectorOptions::readback_hint"
                ),
            }),
        }
    }

    /// [`try_finish`](Self::try_finish), telling an overrun apart.
    pub(super) fn finish(&mut self, ctx: &GpuContext, cfg: &Config, t: Ticket) -> Result<Finish> {
        let recorded = self.recorded;
        let slot = self.slot(t)?;
        if slot.state != SlotState::Mapping {
            return Err(Error::Gpu { reason: format!("readback slot {} is {:?}, not mapping", t.slot, slot.state) });
        }
        let done = slot.mapped.lock().ok().and_then(|mut g| g.take());
        let Some(res) = done else { return Ok(Finish::Pending) };
        slot.state = SlotState::Free;
        if let Err(e) = res {
            ctx.check_lost_polled()?;
            return Err(Error::Gpu { reason: format!("map_async: {e}") });
        }
        let (copied, profiled, spill_whole) = (slot.copied, slot.profiled, slot.frame == recorded);
        let end = staging_bytes(copied).min(slot.staging.size());
        let frame = {
            let view = slot
                .staging
                .slice(..end)
                .get_mapped_range()
                .map_err(|e| Error::Gpu { reason: format!("mapped range: {e:?}") })?;
            parse_frame(cfg, &view, copied, profiled, ctx.queue.get_timestamp_period())
        };
        slot.staging.unmap();
        let mut frame = frame?;
        self.recent.push_back(frame.count);
        if self.recent.len() > HISTORY {
            self.recent.pop_front();
        }
        if frame.count > copied {
            if !spill_whole {
                return Ok(Finish::Overrun { count: frame.count, copied });
            }
            self.complete(ctx, cfg, &mut frame, copied)?;
        }
        Ok(Finish::Done(frame))
    }

    /// Reads keypoints `copied..count` from the spill (a frame with more
    /// keypoints than its copy held).
    fn complete(&self, ctx: &GpuContext, cfg: &Config, frame: &mut Frame, copied: u64) -> Result<()> {
        let spill = self.spill.as_ref().ok_or_else(|| Error::Gpu {
            reason: format!("GPU reported {} keypoints, only {copied} slots exist", frame.count),
        })?;
        let all = self.frame_slots;
        let (from, to) = (copied, frame.count.min(all));
        let kps = ctx.read_range(spill, from * KP_WORDS * 4, (to - from) * KP_WORDS * 4)?;
        let descs = ctx.read_range(spill, all * KP_WORDS * 4 + from * DESC_WORDS * 4, (to - from) * DESC_WORDS * 4)?;
        let raw: Vec<GpuKeypoint> = bytemuck::pod_collect_to_vec(&kps);
        frame.keypoints.extend(raw.iter().map(|k| to_keypoint(cfg, k)));
        frame.raw.extend(raw);
        frame.descriptors.extend_from_slice(bytemuck::cast_slice::<u8, Descriptor>(&descs));
        Ok(())
    }

    /// The slot a ticket names, if the ticket is current (not redeemed, not
    /// from another frame).
    fn slot(&mut self, t: Ticket) -> Result<&mut Slot> {
        match self.slots.get_mut(t.slot) {
            Some(s) if s.generation == t.generation => Ok(s),
            Some(_) => Err(Error::Gpu {
                reason: format!("stale readback ticket (slot {} was reused by a later frame)", t.slot),
            }),
            None => Err(Error::Gpu { reason: format!("unknown readback ticket (slot {})", t.slot) }),
        }
    }
}

fn staging(device: &wgpu::Device, n: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("lfast readback"),
        size: staging_bytes(n),
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
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

/// `n` values of `T` at `bytes[at..]`: cast in place when the mapped range is
/// aligned for `T` (it is: mapped ranges are 8-aligned and every offset here
/// is a multiple of 16), else read unaligned.
fn pod_vec<T: bytemuck::Pod>(bytes: &[u8], at: usize, n: usize) -> Vec<T> {
    let b = &bytes[at..at + n * std::mem::size_of::<T>()];
    match bytemuck::try_cast_slice::<u8, T>(b) {
        Ok(v) => v.to_vec(),
        Err(_) => bytemuck::pod_collect_to_vec(b),
    }
}

/// A mapped staging buffer (`slots` keypoints copied) as a [`Frame`].
fn parse_frame(cfg: &Config, bytes: &[u8], slots: u64, ts: bool, period_ns: f32) -> Result<Frame> {
    let short = || Error::Gpu { reason: format!("readback buffer of {} bytes is too short", bytes.len()) };
    if (bytes.len() as u64) < HEADER + slots * SLOT_BYTES {
        return Err(short());
    }
    let header: [u32; 4] = pod_vec::<u32>(bytes, 0, 4).try_into().map_err(|_| short())?;
    let count = header[0] as u64;
    let n = count.min(slots) as usize;
    let kp_off = HEADER as usize;
    let desc_off = kp_off + slots as usize * KP_WORDS as usize * 4;
    let raw: Vec<GpuKeypoint> = pod_vec(bytes, kp_off, n);
    let descriptors: Vec<Descriptor> = pod_vec(bytes, desc_off, n);
    let scales: Vec<f64> = (0..cfg.n_levels).map(|l| cfg.level_scale(l)).collect();
    let keypoints = raw
        .iter()
        .map(|k| to_keypoint_at(k, scales.get(k.level as usize).copied().unwrap_or_else(|| cfg.level_scale(k.level))))
        .collect();
    let mut pass_ms = Vec::new();
    if ts {
        let t_off = desc_off + slots as usize * DESC_WORDS as usize * 4;
        if bytes.len() < t_off + 2 * STAGES.len() * 8 {
            return Err(short());
        }
        let stamps: Vec<u64> = pod_vec(bytes, t_off, 2 * STAGES.len());
        for (i, name) in STAGES.iter().enumerate() {
            let (a, b) = (stamps[2 * i], stamps[2 * i + 1]);
            pass_ms.push((*name, b.saturating_sub(a) as f64 * period_ns as f64 / 1e6));
        }
    }
    Ok(Frame { keypoints, descriptors, raw, pass_ms, count })
}
