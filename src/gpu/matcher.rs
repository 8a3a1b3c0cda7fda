//! The brute-force Hamming matcher on the GPU: shaders/matcher.wgsl,
//! mirroring src/cpu/matcher.rs (same definitions of nearest, ties, ratio
//! test and cross-check; the results are identical).
//!
//! Three entry points of one shader, recorded in one compute pass:
//! `forward` (one query per invocation, tiles of 64 train descriptors in
//! workgroup memory: best train, d1, d2), `backward` (the cross-check's scan,
//! one train per invocation over tiles of queries) and `combine` (the tests).
//!
//! The matcher is not a per-frame detector stage, so it does not implement
//! [`Pass`](super::Pass) over the frame [`Buffers`](super::Buffers): it owns
//! its buffers ([`MatcherBuffers`], grown on demand). [`GpuMatcher`] is the
//! blocking convenience; embedders can record [`MatcherPass`] themselves.

use super::context::GpuContext;
use super::kernel::{Binding, Kernel, PARAMS, Slot, b, init_buffer};
use crate::error::{Error, Result};
use crate::keypoint::Descriptor;
use crate::spec::matching::{Match, MatchOptions, NO_INDEX};
use std::sync::Mutex;

/// The shader source (without the common prelude).
pub const SOURCE: &str = include_str!("../../shaders/matcher.wgsl");
/// Its bindings (`P` is the prelude's uniform, bound but unused).
pub const BINDINGS: &[Binding] = &[
    PARAMS,
    b(1, "M", Slot::Uniform),
    b(2, "query", Slot::Read),
    b(3, "train", Slot::Read),
    b(4, "fwd", Slot::ReadWrite),
    b(5, "back", Slot::ReadWrite),
    b(6, "matches", Slot::ReadWrite),
];

/// Invocations per workgroup (= descriptors per tile).
pub const WORKGROUP: u32 = 64;

/// The `MatchParams` uniform of shaders/matcher.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MatchParams {
    /// Query descriptors.
    pub n_query: u32,
    /// Train descriptors.
    pub n_train: u32,
    /// [`MatchOptions::ratio_q16`] (0 = no ratio test).
    pub ratio_q16: u32,
    /// Largest distance kept.
    pub max_distance: u32,
    /// 1 = cross-check.
    pub cross_check: u32,
    /// Padding to 32 bytes.
    pub pad: [u32; 3],
}

impl MatchParams {
    /// The uniform for `n_query` x `n_train` descriptors under `opts` (validated).
    pub fn new(n_query: usize, n_train: usize, opts: &MatchOptions) -> Result<Self> {
        let n = |v: usize, what: &str| {
            u32::try_from(v).map_err(|_| Error::GpuLimits { reason: format!("{v} {what} descriptors exceed 2^32") })
        };
        Ok(Self {
            n_query: n(n_query, "query")?,
            n_train: n(n_train, "train")?,
            ratio_q16: opts.ratio_q16()?,
            max_distance: opts.max_distance,
            cross_check: opts.cross_check as u32,
            pad: [0; 3],
        })
    }
}

/// The matcher's buffers for up to `capacity` query and train descriptors.
#[derive(Debug)]
pub struct MatcherBuffers {
    /// `P`: a zeroed `Params` uniform (the prelude declares it; the matcher ignores it).
    pub prelude: wgpu::Buffer,
    /// `M`: [`MatchParams`].
    pub params: wgpu::Buffer,
    /// Query descriptors, 8 words each.
    pub query: wgpu::Buffer,
    /// Train descriptors, 8 words each.
    pub train: wgpu::Buffer,
    /// Per query: best, d1, d2, 0.
    pub fwd: wgpu::Buffer,
    /// Per train: its nearest query.
    pub back: wgpu::Buffer,
    /// Per query: train index (or `NO_INDEX`) and distance.
    pub matches: wgpu::Buffer,
    capacity: (u32, u32),
}

impl MatcherBuffers {
    /// Allocates for `n_query` x `n_train` descriptors, checking the device limits.
    pub fn new(device: &wgpu::Device, n_query: u32, n_train: u32) -> Result<Self> {
        let lim = device.limits();
        let largest = n_query.max(n_train).max(1) as u64 * 32;
        let max_binding = lim.max_storage_buffer_binding_size.min(lim.max_buffer_size);
        if largest > max_binding {
            return Err(Error::GpuLimits {
                reason: format!("matching needs storage buffers of {largest} bytes, the device allows {max_binding}"),
            });
        }
        let groups = n_query.max(n_train).div_ceil(WORKGROUP);
        if groups > lim.max_compute_workgroups_per_dimension {
            return Err(Error::GpuLimits {
                reason: format!(
                    "matching {} descriptors needs {groups} workgroups, the device allows {}",
                    n_query.max(n_train),
                    lim.max_compute_workgroups_per_dimension
                ),
            });
        }
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
        let buf = |label: &str, bytes: u64| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: bytes.max(16),
                usage: storage,
                mapped_at_creation: false,
            })
        };
        let uniform = wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST;
        let (q, t) = (n_query.max(1) as u64, n_train.max(1) as u64);
        Ok(Self {
            prelude: init_buffer(
                device,
                "matcher P",
                &vec![0u8; std::mem::size_of::<super::layout::Params>()],
                uniform,
            ),
            params: init_buffer(device, "matcher M", bytemuck::bytes_of(&MatchParams::default()), uniform),
            query: buf("matcher query", q * 32),
            train: buf("matcher train", t * 32),
            fwd: buf("matcher fwd", q * 16),
            back: buf("matcher back", t * 4),
            matches: buf("matcher matches", q * 8),
            capacity: (n_query, n_train),
        })
    }

    /// (query, train) descriptors these buffers hold.
    pub fn capacity(&self) -> (u32, u32) {
        self.capacity
    }

    /// Uploads the descriptors and the parameters (nothing is submitted:
    /// `queue.write_buffer` lands before the next submission).
    pub fn write(
        &self,
        queue: &wgpu::Queue,
        query: &[Descriptor],
        train: &[Descriptor],
        p: &MatchParams,
    ) -> Result<()> {
        if p.n_query > self.capacity.0 || p.n_train > self.capacity.1 {
            return Err(Error::Gpu {
                reason: format!(
                    "matcher buffers hold {}x{} descriptors, {}x{} given",
                    self.capacity.0, self.capacity.1, p.n_query, p.n_train
                ),
            });
        }
        if !query.is_empty() {
            queue.write_buffer(&self.query, 0, query.as_flattened());
        }
        if !train.is_empty() {
            queue.write_buffer(&self.train, 0, train.as_flattened());
        }
        queue.write_buffer(&self.params, 0, bytemuck::bytes_of(p));
        Ok(())
    }
}

/// The three pipelines.
#[derive(Debug)]
pub struct MatcherPass {
    forward: Kernel,
    backward: Kernel,
    combine: Kernel,
}

/// Bind groups of a [`MatcherPass`] for one [`MatcherBuffers`].
#[derive(Debug)]
pub struct MatcherBound {
    forward: wgpu::BindGroup,
    backward: wgpu::BindGroup,
    combine: wgpu::BindGroup,
}

impl MatcherPass {
    /// The shader's file stem.
    pub const NAME: &'static str = "matcher";

    /// Compiles the module once, one pipeline per entry point.
    pub fn new(device: &wgpu::Device) -> Self {
        let module = super::kernel::compile(device, Self::NAME, SOURCE);
        let k = |entry: &str| Kernel::from_module(device, &format!("matcher {entry}"), &module, entry, BINDINGS);
        Self { forward: k("forward"), backward: k("backward"), combine: k("combine") }
    }

    /// Binds `b` by name.
    pub fn bind(&self, device: &wgpu::Device, b: &MatcherBuffers) -> Result<MatcherBound> {
        let named: [(&str, &wgpu::Buffer); 7] = [
            ("P", &b.prelude),
            ("M", &b.params),
            ("query", &b.query),
            ("train", &b.train),
            ("fwd", &b.fwd),
            ("back", &b.back),
            ("matches", &b.matches),
        ];
        Ok(MatcherBound {
            forward: self.forward.bind(device, &named)?,
            backward: self.backward.bind(device, &named)?,
            combine: self.combine.bind(device, &named)?,
        })
    }

    /// Records the scans and the tests for the sizes and options in `p` (the
    /// same values written with [`MatcherBuffers::write`]).
    pub fn record(&self, pass: &mut wgpu::ComputePass<'_>, bound: &MatcherBound, p: &MatchParams) {
        let gq = p.n_query.div_ceil(WORKGROUP);
        let gt = p.n_train.div_ceil(WORKGROUP);
        self.forward.dispatch(pass, &bound.forward, [gq, 1, 1]);
        if p.cross_check != 0 {
            self.backward.dispatch(pass, &bound.backward, [gt, 1, 1]);
        }
        self.combine.dispatch(pass, &bound.combine, [gq, 1, 1]);
    }
}

/// Decodes the `matches` buffer (two words per query) into kept matches.
pub fn decode_matches(words: &[u32], n_query: usize) -> Vec<Match> {
    words
        .chunks_exact(2)
        .take(n_query)
        .enumerate()
        .filter(|(_, w)| w[0] != NO_INDEX)
        .map(|(i, w)| Match { query: i as u32, train: w[0], distance: w[1] })
        .collect()
}

/// A blocking GPU matcher: uploads, runs, reads back. Buffers are kept and
/// grown as needed, so matching frame after frame allocates rarely.
#[derive(Debug)]
pub struct GpuMatcher {
    ctx: GpuContext,
    pass: MatcherPass,
    state: Mutex<Option<(MatcherBuffers, MatcherBound)>>,
}

impl GpuMatcher {
    /// Builds the pipelines on `ctx`'s device.
    pub fn new(ctx: GpuContext) -> Result<Self> {
        ctx.check_lost_polled()?;
        let pass = super::stages::checked(&ctx.device, MatcherPass::NAME, || MatcherPass::new(&ctx.device))
            .map_err(|e| Error::Gpu { reason: format!("building the matcher pipelines: {e}") })?;
        Ok(Self { ctx, pass, state: Mutex::new(None) })
    }

    /// The device it runs on.
    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// Matches `query` against `train`: the same result as
    /// [`crate::cpu::matcher::match_descriptors`].
    pub fn match_descriptors(
        &self,
        query: &[Descriptor],
        train: &[Descriptor],
        opts: &MatchOptions,
    ) -> Result<Vec<Match>> {
        let p = MatchParams::new(query.len(), train.len(), opts)?;
        if query.is_empty() || train.is_empty() {
            return Ok(Vec::new());
        }
        self.ctx.check_lost_polled()?;
        let d = &self.ctx.device;
        let mut state = self.state.lock().map_err(|_| Error::Gpu { reason: "matcher lock poisoned".into() })?;
        let fits = state.as_ref().is_some_and(|(b, _)| b.capacity.0 >= p.n_query && b.capacity.1 >= p.n_train);
        if !fits {
            // grow geometrically so a sequence of similar frames settles quickly
            let (cq, ct) = state.as_ref().map_or((0, 0), |(b, _)| b.capacity);
            let grow = |have: u32, need: u32| if need > have { need.max(have.saturating_mul(3) / 2) } else { have };
            let oom = d.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
            let val = d.push_error_scope(wgpu::ErrorFilter::Validation);
            let built = MatcherBuffers::new(d, grow(cq, p.n_query), grow(ct, p.n_train))
                .or_else(|_| MatcherBuffers::new(d, p.n_query, p.n_train))
                .and_then(|b| self.pass.bind(d, &b).map(|bound| (b, bound)));
            let val_err = pollster::block_on(val.pop());
            if let Some(e) = pollster::block_on(oom.pop()) {
                return Err(Error::GpuOutOfMemory { reason: format!("matcher buffers: {e}") });
            }
            if let Some(e) = val_err {
                return Err(Error::Gpu { reason: format!("matcher buffers: {e}") });
            }
            *state = Some(built?);
        }
        let (bufs, bound) = state.as_ref().ok_or_else(|| Error::Gpu { reason: "no matcher buffers".into() })?;
        bufs.write(&self.ctx.queue, query, train, &p)?;
        let scope = d.push_error_scope(wgpu::ErrorFilter::Validation);
        let mut enc = d.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("matcher") });
        {
            let mut cp =
                enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("matcher"), timestamp_writes: None });
            self.pass.record(&mut cp, bound, &p);
        }
        self.ctx.queue.submit([enc.finish()]);
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(Error::Gpu { reason: format!("matcher: {e}") });
        }
        let bytes = self.ctx.read_range(&bufs.matches, 0, p.n_query as u64 * 8)?;
        let words: Vec<u32> = bytes.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
        Ok(decode_matches(&words, query.len()))
    }
}
