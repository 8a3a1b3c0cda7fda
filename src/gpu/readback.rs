//! The readback ring: staging buffers a frame's keypoints, descriptors and
//! timestamps are copied into, mapped while the next frame runs, and parsed
//! into a [`Frame`]. [`GpuDetector::encode_readback`] records the copy,
//! [`GpuDetector::start_readback`] maps after the submit, and
//! [`GpuDetector::try_finish_readback`] / [`GpuDetector::finish_readback`] parse.

use super::buffers::{Buffers, DESC_WORDS, GpuKeypoint, KP_WORDS, counter};
use super::detector::{GpuDetector, GpuWorkspace, to_keypoint};
use super::stages::{STAGES, Timestamps};
use crate::config::Config;
use crate::error::{Error, Result};
use crate::keypoint::{Descriptor, KeyPoint};

/// State of one staging buffer of the readback ring.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum SlotState {
    Free,
    /// A copy was recorded; the caller must submit, then call `start_readback`.
    Recorded,
    /// `map_async` was called.
    Mapping,
}

pub(super) struct Slot {
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

impl GpuDetector {
    /// Keypoint slots a frame can fill: the capacity, or the cap when there is one.
    pub(super) fn frame_slots(&self, b: &Buffers) -> u64 {
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

    pub(super) fn staging_size(&self, b: &Buffers) -> u64 {
        let n = self.readback_slots(b);
        16 + n * KP_WORDS * 4 + n * DESC_WORDS * 4 + 16 * STAGES.len() as u64
    }

    pub(super) fn slot(&self, b: &Buffers) -> Slot {
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
            let n = Timestamps::QUERIES;
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
            let view =
                slot.staging.slice(..).get_mapped_range().map_err(|e| Error::Gpu { reason: format!("{e:?}") })?;
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
            let descs =
                self.ctx.read_range(spill, all * KP_WORDS * 4 + from * DESC_WORDS * 4, (to - from) * DESC_WORDS * 4)?;
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
}

/// The slot a ticket names, if the ticket is current (not redeemed, not from another frame).
fn ticket_slot(ws: &mut GpuWorkspace, t: Ticket) -> Result<&mut Slot> {
    match ws.ring.get_mut(t.slot) {
        Some(s) if s.generation == t.generation => Ok(s),
        Some(_) => {
            Err(Error::Gpu { reason: format!("stale readback ticket (slot {} was reused by a later frame)", t.slot) })
        }
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
    let descriptors: Vec<Descriptor> =
        bytes[desc_off..desc_off + n * 32].chunks_exact(32).map(|c| c.try_into().unwrap_or([0; 32])).collect();
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
