//! [`FrameStream`]: a batch of frames through one [`Detector`], the GPU not
//! waiting for the host. Frame n+1 is uploaded and submitted before frame n is
//! read back, up to the workspace's ring of staging buffers
//! ([`GpuDetectorOptions::ring`](crate::gpu::GpuDetectorOptions::ring)); one
//! frame at a time, the device idles through every readback and upload. On a
//! software adapter one frame is in flight ([`Detector::stream`] says why);
//! on the CPU a frame runs when it is pushed.
//!
//! Tests: tests/gpu_stream.rs (GPU == one CPU call per frame through size
//! changes, refused frames and overruns; the CPU stream).

use crate::detector::Detector;
use crate::error::Result;
use crate::image::Plane;
use crate::keypoint::{Descriptor, KeyPoint};

/// A frame's results, with the frame handed back.
#[derive(Debug)]
pub struct Done<T> {
    /// The tag the frame was pushed with.
    pub tag: T,
    /// The frame, unchanged.
    pub image: Plane<u8>,
    /// Its keypoints and descriptors (`desc[i]` belongs to `kps[i]`), or why not.
    pub result: Result<(Vec<KeyPoint>, Vec<Descriptor>)>,
}

/// Frames in flight through a [`Detector`]; see [`Detector::stream`].
///
/// ```
/// use lfast::{Backend, Config, Detector, Plane};
/// let det = Detector::new(Config::default(), Backend::Cpu).unwrap();
/// let mut stream = det.stream();
/// let mut done = Vec::new();
/// for i in 0..3 {
///     done.extend(stream.push(i, Plane::<u8>::new(64, 48)));
/// }
/// done.extend(stream.finish());
/// assert_eq!(done.iter().map(|d| d.tag).collect::<Vec<_>>(), [0, 1, 2]);
/// assert!(done.iter().all(|d| d.result.as_ref().is_ok_and(|(kps, _)| kps.is_empty())));
/// ```
pub struct FrameStream<'a, T> {
    det: &'a Detector,
    #[cfg(feature = "gpu")]
    gpu: Option<gpu::InFlight<'a, T>>,
    #[cfg(not(feature = "gpu"))]
    _tag: std::marker::PhantomData<T>,
}

impl<T> std::fmt::Debug for FrameStream<'_, T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FrameStream").field("in_flight", &self.in_flight()).finish()
    }
}

impl Detector {
    /// A stream of frames through this detector: [`FrameStream::push`] each
    /// frame, then [`FrameStream::finish`]. The results are those of
    /// [`detect_and_compute`](Self::detect_and_compute) (no mask), frame for
    /// frame; on the GPU several frames are in flight at once, and a frame
    /// the GPU fails in Auto mode runs on the CPU as with a single call.
    /// The stream holds the GPU workspace: other calls on this detector wait
    /// until it is dropped.
    ///
    /// Frames in flight: as many as the workspace's ring holds, but one on a
    /// software adapter (lavapipe), which runs each dispatch on all the CPU's
    /// cores, split evenly up front, so that host work overlapping it (the
    /// next frame's upload and recording) stalls the dispatch's other threads
    /// at its end (51 KITTI frames on two cores: 1.93-2.00 s one at a time,
    /// 2.17-2.40 s three in flight). [`stream_with`](Self::stream_with) sets it.
    pub fn stream<T>(&self) -> FrameStream<'_, T> {
        self.stream_with(0)
    }

    /// [`stream`](Self::stream) with at most `in_flight` frames on the GPU
    /// (at least one, at most the ring's; 0 = the default).
    pub fn stream_with<T>(&self, in_flight: usize) -> FrameStream<'_, T> {
        #[cfg(feature = "gpu")]
        return FrameStream { det: self, gpu: gpu::InFlight::new(self, in_flight) };
        #[cfg(not(feature = "gpu"))]
        {
            let _ = in_flight;
            FrameStream { det: self, _tag: std::marker::PhantomData }
        }
    }
}

impl<T> FrameStream<'_, T> {
    /// Hands `image` over; returns the frames finished meanwhile, oldest
    /// first (on the CPU, this one; on the GPU, the oldest once the ring is
    /// full).
    pub fn push(&mut self, tag: T, image: Plane<u8>) -> Vec<Done<T>> {
        #[cfg(feature = "gpu")]
        let (tag, image) = match &mut self.gpu {
            Some(g) => match g.push(self.det, tag, image) {
                Ok(done) => return done,
                Err(back) => back,
            },
            None => (tag, image),
        };
        let mut image = image;
        let result = self.det.detect_and_compute_in(&mut image, None);
        vec![Done { tag, image, result }]
    }

    /// Waits for every frame still in flight; oldest first.
    pub fn finish(mut self) -> Vec<Done<T>> {
        #[cfg(feature = "gpu")]
        if let Some(g) = &mut self.gpu {
            return g.drain(self.det);
        }
        Vec::new()
    }

    /// Whether frames run on the GPU (several in flight); else each runs
    /// when pushed.
    pub fn on_gpu(&self) -> bool {
        #[cfg(feature = "gpu")]
        return self.gpu.is_some() && self.det.active_gpu().is_some();
        #[cfg(not(feature = "gpu"))]
        false
    }

    /// Frames pushed and not yet handed back.
    pub fn in_flight(&self) -> usize {
        #[cfg(feature = "gpu")]
        return self.gpu.as_ref().map_or(0, |g| g.pending.len());
        #[cfg(not(feature = "gpu"))]
        0
    }
}

#[cfg(feature = "gpu")]
mod gpu {
    use super::Done;
    use crate::config::DescriptorKind;
    use crate::detector::{Detector, Gpu};
    use crate::error::Error;
    use crate::gpu::detector::{GpuWorkspace, Ticket};
    use crate::gpu::readback::Finish;
    use crate::image::Plane;
    use std::collections::VecDeque;
    use std::sync::MutexGuard;

    /// A frame submitted and not yet read back.
    pub(super) struct Pending<T> {
        tag: T,
        image: Plane<u8>,
        ticket: Ticket,
        index: wgpu::SubmissionIndex,
    }

    pub(super) struct InFlight<'a, T> {
        gpu: &'a Gpu,
        ws: MutexGuard<'a, Option<GpuWorkspace>>,
        pub(super) pending: VecDeque<Pending<T>>,
        /// Frames in flight at most: the ring's, or one on a software adapter.
        depth: usize,
    }

    impl<'a, T> InFlight<'a, T> {
        /// The GPU side of a stream, when frames run on the GPU.
        pub(super) fn new(det: &'a Detector, in_flight: usize) -> Option<Self> {
            // the opencv descriptor is described on the CPU (Detector::detect_and_compute)
            if det.config().descriptor == DescriptorKind::Opencv {
                return None;
            }
            let gpu = det.active_gpu()?;
            // a poisoned lock: the blocking calls report it, frame by frame
            let ws = gpu.ws.lock().ok()?;
            // Detector::stream says why one on a software adapter
            let depth = match in_flight {
                0 if det.on_software_gpu() => 1,
                0 => usize::MAX,
                n => n,
            };
            Some(Self { gpu, ws, pending: VecDeque::new(), depth })
        }

        /// Submits `image`, returning the frames finished meanwhile; the frame
        /// back when it is not the GPU's (an empty or invalid frame, or the
        /// GPU given up after a failure in Auto mode: the caller's path
        /// reports or runs it).
        #[allow(clippy::type_complexity)]
        pub(super) fn push(
            &mut self,
            det: &Detector,
            tag: T,
            image: Plane<u8>,
        ) -> Result<Vec<Done<T>>, (T, Plane<u8>)> {
            if image.width == 0 || image.height == 0 || image.view().check().is_err() || det.active_gpu().is_none() {
                return Err((tag, image));
            }
            let mut out = Vec::new();
            // a new size needs a new workspace: finish the frames of the old one
            let same = self.ws.as_ref().is_some_and(|ws| ws.buffers.size() == (image.width, image.height));
            let ring = self.ws.as_ref().map_or(1, |ws| ws.ring_len()).clamp(1, self.depth);
            if !same || self.pending.len() >= ring {
                let keep = if same { ring - 1 } else { 0 };
                while self.pending.len() > keep {
                    out.push(self.finish_oldest(det));
                }
            }
            match self.submit(&image) {
                Ok((ticket, index)) => self.pending.push_back(Pending { tag, image, ticket, index }),
                Err(e) => out.push(self.fall_back(det, tag, image, e)),
            }
            Ok(out)
        }

        /// Uploads, records and submits one frame; starts its readback.
        fn submit(&mut self, image: &Plane<u8>) -> crate::Result<(Ticket, wgpu::SubmissionIndex)> {
            self.gpu.det.submit(&mut self.ws, image.view(), None)
        }

        /// The oldest frame in flight, read back (or redone, or run on the CPU).
        fn finish_oldest(&mut self, det: &Detector) -> Done<T> {
            let Some(p) = self.pending.pop_front() else {
                unreachable!("finish_oldest is called with frames in flight")
            };
            match self.read(p.ticket, p.index) {
                Ok(Some(f)) => Done { tag: p.tag, image: p.image, result: Ok((f.keypoints, f.descriptors)) },
                // more keypoints than the copy held, the rest overwritten by a
                // later frame: once more on its own, as the newest frame
                Ok(None) => {
                    let again = self.gpu.det.detect_and_compute(&mut self.ws, p.image.view(), None);
                    match again {
                        Ok(f) => Done { tag: p.tag, image: p.image, result: Ok((f.keypoints, f.descriptors)) },
                        Err(e) => self.fall_back(det, p.tag, p.image, e),
                    }
                }
                Err(e) => self.fall_back(det, p.tag, p.image, e),
            }
        }

        /// The frame of `ticket` once submission `index` has run; `None` on an overrun.
        fn read(&mut self, ticket: Ticket, index: wgpu::SubmissionIndex) -> crate::Result<Option<crate::gpu::Frame>> {
            let g = &self.gpu.det;
            let ws = self.ws.as_mut().ok_or_else(|| Error::Gpu { reason: "no workspace".into() })?;
            let mut waited = false;
            loop {
                match g.finish_frame(ws, ticket)? {
                    Finish::Done(f) => return Ok(Some(f)),
                    Finish::Overrun { .. } => return Ok(None),
                    // the map callback runs in the poll after the submission is done
                    Finish::Pending if waited => g.context().wait()?,
                    Finish::Pending => {
                        g.context().wait_for(index.clone())?;
                        waited = true;
                    }
                }
            }
        }

        /// Frame `image` after GPU error `e`: on the CPU in Auto mode, else the error.
        fn fall_back(&self, det: &Detector, tag: T, mut image: Plane<u8>, e: Error) -> Done<T> {
            let result = det.fall_back(e).and_then(|()| det.cpu().detect_and_compute_in(&mut image, None));
            Done { tag, image, result }
        }

        /// Every frame still in flight, oldest first.
        pub(super) fn drain(&mut self, det: &Detector) -> Vec<Done<T>> {
            let mut out = Vec::with_capacity(self.pending.len());
            while !self.pending.is_empty() {
                out.push(self.finish_oldest(det));
            }
            out
        }
    }

    impl<T> Drop for InFlight<'_, T> {
        /// Frames still in flight are waited for (their readbacks redeemed),
        /// so the workspace's ring is free for the next call.
        fn drop(&mut self) {
            while let Some(p) = self.pending.pop_front() {
                let _ = self.read(p.ticket, p.index);
            }
        }
    }
}
