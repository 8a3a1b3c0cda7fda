//! The one declaration of the GPU pipeline: every stage, in the order it is
//! recorded, with its pass type. The stage list [`STAGES`] (compute-pass and
//! timestamp labels), every shader ([`super::SHADERS`]), the pipelines
//! (`Passes`), their bind groups (`Bound`) and the encode order
//! (`Passes::record_all`) all follow from it, so adding a pass is one edit
//! here (plus its `shaders/<stage>.wgsl`, `src/gpu/<stage>.rs`, `src/cpu/<stage>.rs`).

use super::ShaderInfo;
use super::buffers::Buffers;
use super::kernel::{Binding, Kernel};
use super::pass::Pass;
use crate::error::{Error, Result};
use std::thread::ScopedJoinHandle;

/// Declares the stages (`module: PassType`, in recording order) and the
/// shaders that are not a stage of the detector (`standalone: module`).
macro_rules! stages {
    ($($m:ident : $ty:ident),* $(,)? ; standalone: $($x:ident),* $(,)?) => {
        /// The stages in the order they are recorded (one compute pass each;
        /// the passes' labels and the profile's timestamp pairs).
        pub const STAGES: [&str; [$(stringify!($m)),*].len()] = [$(stringify!($m)),*];

        /// Every shader: the stages in pipeline order, then the standalone ones.
        pub const SHADERS: &[ShaderInfo] = &[
            $(ShaderInfo { name: stringify!($m), source: super::$m::SOURCE, bindings: super::$m::BINDINGS },)*
            $(ShaderInfo { name: stringify!($x), source: super::$x::SOURCE, bindings: super::$x::BINDINGS },)*
        ];

        /// Builds each stage's pipelines as a detector does, one stage after
        /// another on the calling thread, and calls `each(stage, seconds)`
        /// after each: what each stage adds to a detector's start
        /// (examples/compile_times.rs). Validation errors go to the device's
        /// error handler, as for any pipeline built outside an error scope.
        pub fn time_each_stage(device: &wgpu::Device, mut each: impl FnMut(&'static str, f64)) {
            $(
                let t = std::time::Instant::now();
                let built = <super::$m::$ty as Pass>::new(device);
                each(stringify!($m), t.elapsed().as_secs_f64());
                drop(built);
            )*
        }

        /// Every stage's pipelines, built once per device.
        #[derive(Debug)]
        pub(crate) struct Passes {
            $(pub(crate) $m: super::$m::$ty,)*
        }

        /// The bind groups of every stage for one [`Buffers`].
        pub(crate) struct Bound {
            $(pub(crate) $m: <super::$m::$ty as Pass>::Bound,)*
        }

        impl Passes {
            /// Compiles every stage's pipelines, each stage on its own scoped
            /// thread: shader translation and the driver's compile take most
            /// of a detector's start (~145 ms of lavapipe's ~180), and stages
            /// are independent; no more build at once than there are cores
            /// ([`Permits`]). Each thread builds inside its own error
            /// scopes ([`checked`]); a shader that does not compile or a
            /// pipeline that fails validation is an [`Error::Gpu`] naming
            /// every stage that failed.
            ///
            /// With `warm` (a queue nobody else submits to, and a small
            /// workspace), each thread then records its stage on the
            /// workspace with every dispatch empty and submits it
            /// ([`kernel::warm_up`](super::kernel::warm_up)): a driver that
            /// prepares pipelines at their first dispatch does it while the
            /// other stages still build, not one after another in the first
            /// frame.
            pub(crate) fn new(device: &wgpu::Device, warm: Option<(&wgpu::Queue, &Buffers)>) -> Result<Self> {
                let cores = Permits::new(std::thread::available_parallelism().map_or(1, |n| n.get()));
                std::thread::scope(|s| {
                    $(let $m = s.spawn(|| checked(device, stringify!($m), || {
                        let _core = cores.take();
                        let built = <super::$m::$ty as Pass>::new(device);
                        if let Some((queue, b)) = warm {
                            warm_up_stage(&built, device, queue, b);
                        }
                        built
                    }));)*
                    let mut errors = Vec::new();
                    $(let $m = joined($m, &mut errors);)*
                    match ($($m,)*) {
                        ($(Some($m),)*) => Ok(Self { $($m,)* }),
                        _ => Err(failed(&errors)),
                    }
                })
            }

            /// Binds every stage to `b`.
            pub(crate) fn bind(&self, d: &wgpu::Device, b: &Buffers) -> Result<Bound> {
                Ok(Bound { $($m: self.$m.bind(d, b)?,)* })
            }

            /// Records every stage in order: when profiling, each in its own
            /// compute pass (timed) after its `prepare` commands; otherwise all
            /// `prepare` commands, then all stages in one compute pass. `special(stage, pass)` may record a stage
            /// itself (returning true), as the texture input does for `luma`.
            pub(crate) fn record_all(
                &self,
                enc: &mut wgpu::CommandEncoder,
                b: &Buffers,
                bound: &Bound,
                ts: Option<&Timestamps>,
                mut special: impl FnMut(&'static str, &mut wgpu::ComputePass<'_>) -> bool,
            ) {
                if ts.is_none() {
                    // Not profiling: every stage's `prepare` first (each only
                    // clears accumulators that no earlier stage of the frame
                    // touches: counters, hist, flags), then every stage as
                    // dispatches of one compute pass. wgpu orders them and puts
                    // the barriers between them; a pass per stage would add its
                    // begin/end on the CPU and the GPU. The pass is split only
                    // where a stage's `clear_before` clears a buffer whose
                    // memory an earlier stage used.
                    $(self.$m.prepare(enc, b);)*
                    let desc = wgpu::ComputePassDescriptor { label: Some("lfast"), timestamp_writes: None };
                    let mut cp = enc.begin_compute_pass(&desc).forget_lifetime();
                    $(
                        if let Some(buf) = self.$m.clear_before(b) {
                            drop(cp);
                            enc.clear_buffer(buf, 0, None);
                            cp = enc.begin_compute_pass(&desc).forget_lifetime();
                        }
                        if !special(stringify!($m), &mut cp) {
                            self.$m.record(&mut cp, &bound.$m, b);
                        }
                    )*
                    return;
                }
                let mut stage = 0;
                $(
                    self.$m.prepare(enc, b);
                    if let Some(buf) = self.$m.clear_before(b) {
                        enc.clear_buffer(buf, 0, None);
                    }
                    {
                        let mut cp = begin_pass(enc, ts, stage);
                        if !special(stringify!($m), &mut cp) {
                            self.$m.record(&mut cp, &bound.$m, b);
                        }
                    }
                    stage += 1;
                )*
                debug_assert_eq!(stage, STAGES.len());
            }
        }
    };
}

stages! {
    luma: LumaPass,
    pyramid: PyramidPass,
    median: MedianPass,
    gradient_nms: GradientNmsPass,
    local_threshold: LocalThresholdPass,
    otsu: OtsuPass,
    classify: ClassifyPass,
    rules: RulesPass,
    hysteresis: HysteresisPass,
    lfast: LfastPass,
    response: ResponsePass,
    corner_nms: CornerNmsPass,
    snap: SnapPass,
    select: SelectPass,
    blur: BlurPass,
    orientation: OrientationPass,
    orb: OrbPass;
    standalone: matcher, gradient, nms, histogram, cand_list,
}

/// A counting semaphore: at most `n` holders of a [`Permit`] at a time. The
/// stage builders take one each, so no more build at once than there are
/// cores: with all seventeen building at once, two cores started lavapipe's
/// detector more slowly (one KITTI file through the CLI ~12-17 ms longer of
/// ~250; docs/gpu.md).
struct Permits {
    free: std::sync::Mutex<usize>,
    freed: std::sync::Condvar,
}

/// A held permit of [`Permits`], given back when dropped.
struct Permit<'a>(&'a Permits);

impl Permits {
    fn new(n: usize) -> Self {
        Self { free: std::sync::Mutex::new(n.max(1)), freed: std::sync::Condvar::new() }
    }

    /// Waits for a free permit and takes it. (A panic elsewhere while the
    /// lock was held leaves the count as it was: the lock's poison is ignored.)
    fn take(&self) -> Permit<'_> {
        let mut free = self.free.lock().unwrap_or_else(|e| e.into_inner());
        while *free == 0 {
            free = self.freed.wait(free).unwrap_or_else(|e| e.into_inner());
        }
        *free -= 1;
        Permit(self)
    }
}

impl Drop for Permit<'_> {
    fn drop(&mut self) {
        *self.0.free.lock().unwrap_or_else(|e| e.into_inner()) += 1;
        self.0.freed.notify_one();
    }
}

/// Runs `build` (one stage's shader and pipeline creation) inside error
/// scopes for validation, out-of-memory and internal errors, pushed and
/// popped on the calling thread: wgpu's error scopes are per thread, so a
/// scope pushed by the thread that spawned the builders never sees their
/// errors (they would reach the uncaptured-error handler, which only logs).
/// The error names `stage`.
pub(crate) fn checked<T>(
    device: &wgpu::Device,
    stage: &str,
    build: impl FnOnce() -> T,
) -> std::result::Result<T, String> {
    let validation = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let oom = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
    let internal = device.push_error_scope(wgpu::ErrorFilter::Internal);
    let built = build();
    // popped innermost first, as pushed
    let errors = [internal.pop(), oom.pop(), validation.pop()].map(pollster::block_on);
    match errors.into_iter().flatten().next() {
        Some(e) => Err(format!("stage `{stage}`: {e}")),
        None => Ok(built),
    }
}

/// Records `pass` on `b` with every dispatch empty and submits it (see
/// [`Passes::new`]). A workspace the stage cannot bind is left alone: the
/// first frame reports it.
fn warm_up_stage<P: Pass>(pass: &P, device: &wgpu::Device, queue: &wgpu::Queue, b: &Buffers) {
    let Ok(bound) = pass.bind(device, b) else { return };
    let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("lfast warm-up") });
    {
        let mut cp = enc
            .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("lfast warm-up"), timestamp_writes: None });
        super::kernel::warm_up(|| pass.record(&mut cp, &bound, b));
    }
    queue.submit([enc.finish()]);
}

/// The result of a [`checked`] builder thread: `Some` when it built, else
/// `None` with its error appended to `errors`. A panic on the thread goes on
/// unwinding here.
fn joined<T>(handle: ScopedJoinHandle<'_, std::result::Result<T, String>>, errors: &mut Vec<String>) -> Option<T> {
    match handle.join().unwrap_or_else(|e| std::panic::resume_unwind(e)) {
        Ok(built) => Some(built),
        Err(e) => {
            errors.push(e);
            None
        }
    }
}

/// The error for the stages that failed to build.
fn failed(errors: &[String]) -> Error {
    Error::Gpu { reason: format!("building the pipelines: {}", errors.join("; ")) }
}

/// Builds one kernel (entry point `main`) for each `(name, stage source,
/// bindings)` exactly as [`Passes`] builds the stages: each on its own scoped
/// thread inside [`checked`], the results gathered by [`joined`]. Lets the
/// tests prove that a shader that does not compile, or a pipeline that fails
/// validation, comes back as an error naming it.
#[doc(hidden)]
pub fn build_kernels(device: &wgpu::Device, kernels: &[(&str, &str, &'static [Binding])]) -> Result<()> {
    std::thread::scope(|s| {
        let handles: Vec<_> = kernels
            .iter()
            .map(|&(name, source, bindings)| {
                s.spawn(move || checked(device, name, || Kernel::new(device, name, source, "main", bindings)))
            })
            .collect();
        let mut errors = Vec::new();
        let built = handles.into_iter().filter_map(|h| joined(h, &mut errors)).count();
        if errors.is_empty() && built == kernels.len() { Ok(()) } else { Err(failed(&errors)) }
    })
}

/// Per-stage GPU timestamps (when the adapter has `TIMESTAMP_QUERY`): a
/// begin and an end query per stage.
pub(crate) struct Timestamps {
    pub(crate) set: wgpu::QuerySet,
    pub(crate) resolve: wgpu::Buffer,
}

impl Timestamps {
    /// Queries written per frame.
    pub(crate) const QUERIES: u32 = 2 * STAGES.len() as u32;

    pub(crate) fn new(d: &wgpu::Device) -> Self {
        Self {
            set: d.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("lfast timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count: Self::QUERIES,
            }),
            resolve: d.create_buffer(&wgpu::BufferDescriptor {
                label: Some("lfast timestamps"),
                size: Self::QUERIES as u64 * 8,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
        }
    }
}

/// Opens the compute pass of stage `stage`, labelled with its name and timed when profiling.
fn begin_pass<'e>(enc: &'e mut wgpu::CommandEncoder, ts: Option<&Timestamps>, stage: usize) -> wgpu::ComputePass<'e> {
    let timestamp_writes = ts.map(|t| wgpu::ComputePassTimestampWrites {
        query_set: &t.set,
        beginning_of_pass_write_index: Some(2 * stage as u32),
        end_of_pass_write_index: Some(2 * stage as u32 + 1),
    });
    enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(STAGES[stage]), timestamp_writes })
}
