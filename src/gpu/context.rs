//! The device and queue lfast runs on: chosen from the environment
//! (`WGPU_BACKEND`, `WGPU_ADAPTER_NAME`, `WGPU_POWER_PREF`) or given by an
//! embedder who already has one.

use crate::error::{Error, Result};
use std::sync::{Arc, Mutex};

/// How to pick an adapter. `Default` reads the environment.
#[derive(Clone, Debug)]
pub struct GpuOptions {
    /// Backends to consider; `None` = `WGPU_BACKEND` if set, else the primary
    /// ones (Vulkan, Metal, DX12; GL only when asked for).
    pub backends: Option<wgpu::Backends>,
    /// Case-insensitive substring of the adapter name; `None` = `WGPU_ADAPTER_NAME` if set.
    /// A name is an explicit request: it may select a software adapter.
    pub adapter_name: Option<String>,
    /// Read `WGPU_BACKEND` / `WGPU_ADAPTER_NAME` / `WGPU_POWER_PREF` for what
    /// is left `None` above (default `true`).
    pub read_env: bool,
}

impl Default for GpuOptions {
    fn default() -> Self {
        Self { backends: None, adapter_name: None, read_env: true }
    }
}

impl GpuOptions {
    /// Options that ignore the environment: the primary backends, no adapter name.
    pub fn ignoring_env() -> Self {
        Self { read_env: false, ..Self::default() }
    }

    fn backends(&self) -> wgpu::Backends {
        let env = if self.read_env { wgpu::Backends::from_env() } else { None };
        self.backends.or(env).unwrap_or(wgpu::Backends::PRIMARY)
    }

    /// The adapter asked for by name (these options, else `WGPU_ADAPTER_NAME`).
    pub fn name(&self) -> Option<String> {
        let env = || if self.read_env { std::env::var("WGPU_ADAPTER_NAME").ok() } else { None };
        self.adapter_name.clone().or_else(env).filter(|s| !s.is_empty())
    }

    fn power(&self) -> wgpu::PowerPreference {
        let env = if self.read_env { wgpu::PowerPreference::from_env() } else { None };
        env.unwrap_or(wgpu::PowerPreference::HighPerformance)
    }
}

/// True for a software rasteriser (Mesa lavapipe/llvmpipe, WARP, SwiftShader):
/// wgpu reports `DeviceType::Cpu`; the names catch drivers that misreport it.
pub fn is_software(info: &wgpu::AdapterInfo) -> bool {
    let n = info.name.to_lowercase();
    info.device_type == wgpu::DeviceType::Cpu
        || ["llvmpipe", "lavapipe", "swiftshader", "microsoft basic render driver", "warp"]
            .iter()
            .any(|s| n.contains(s))
}

/// True for an adapter `Backend::Auto` may take on its own: a discrete,
/// integrated or virtual GPU, never a software rasteriser (the CPU path is
/// faster than any of them) nor an adapter of unknown type.
pub fn is_hardware(info: &wgpu::AdapterInfo) -> bool {
    matches!(
        info.device_type,
        wgpu::DeviceType::DiscreteGpu | wgpu::DeviceType::IntegratedGpu | wgpu::DeviceType::VirtualGpu
    ) && !is_software(info)
}

/// What `Backend::Auto` does on this machine with these options, and why.
#[derive(Clone, Debug)]
pub enum AutoChoice {
    /// The GPU path on this adapter: named by the options or the environment
    /// (`named`, software allowed), or the best hardware adapter.
    Gpu {
        /// The adapter.
        info: Box<wgpu::AdapterInfo>,
        /// True when it was chosen by name.
        named: bool,
    },
    /// The CPU path, for this reason.
    Cpu(String),
}

/// Ranks hardware adapters for `Backend::Auto`: by the power preference
/// (discrete first for high performance, integrated first for low power),
/// then virtual GPUs; ties keep the enumeration order.
fn rank(info: &wgpu::AdapterInfo, power: wgpu::PowerPreference) -> u8 {
    use wgpu::DeviceType::*;
    match (info.device_type, power) {
        (IntegratedGpu, wgpu::PowerPreference::LowPower) => 0,
        (DiscreteGpu, _) => 1,
        (IntegratedGpu, _) => 2,
        _ => 3,
    }
}

/// A device and queue with what lfast needs to know about them.
#[derive(Clone, Debug)]
pub struct GpuContext {
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// The adapter's description.
    pub info: wgpu::AdapterInfo,
    lost: Arc<Mutex<Option<String>>>,
    /// Opened by lfast ([`new`](Self::new), [`new_auto`](Self::new_auto)):
    /// nobody else submits to its queue, so a detector may (see
    /// [`owns_queue`](Self::owns_queue)).
    owned: bool,
}

/// The instance lfast opens its own adapters from: the options' backends,
/// with the Vulkan backend created for compute only where that matters (see
/// [`compute_only_vulkan`]).
fn instance(opts: &GpuOptions) -> wgpu::Instance {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
    desc.backends = opts.backends();
    if let Some(inst) = compute_only_vulkan(&desc) {
        return inst;
    }
    wgpu::Instance::new(desc)
}

/// The window-system surface extensions that wgpu enables on a Unix
/// desktop, which a compute-only instance leaves out.
#[cfg(all(unix, not(target_vendor = "apple"), not(target_os = "android")))]
const WINDOW_SYSTEM_EXTENSIONS: [&std::ffi::CStr; 3] =
    [c"VK_KHR_wayland_surface", c"VK_KHR_xcb_surface", c"VK_KHR_xlib_surface"];

/// A Vulkan-only instance without the window-system surface extensions, when
/// Vulkan is the only backend asked for on a Unix desktop (Linux, the BSDs),
/// else `None`.
///
/// Why: wgpu enables `VK_KHR_wayland_surface` (and xcb, xlib) on every
/// instance. Mesa's implicit device-selection layer
/// (`VK_LAYER_MESA_device_select`, installed with every Mesa Vulkan driver,
/// lavapipe included) sees the Wayland extension and, while the adapters are
/// enumerated, connects to the Wayland display to learn which GPU is the
/// default; on a headless machine libwayland then prints `error:
/// XDG_RUNTIME_DIR is invalid or not set in the environment.` on the host
/// process's stderr. lfast never presents, so it creates no surface and needs
/// none of these extensions; without them the layer does not connect, and the
/// host's environment is left alone. wgpu-hal documents that its extension
/// list should only grow, because it assumes an available extension is
/// enabled; in wgpu-hal 30 these three are read only by
/// `create_surface_from_{wayland,xcb,xlib}`, which check the instance's list
/// and return an error. lfast creates no surface on this instance and hands it
/// to nobody. `tests/first_run.rs`, python/tests/test_first_run.py and the C
/// and C++ tests check stderr with `XDG_RUNTIME_DIR` unset.
///
/// Other backend sets (GL, asked for with `WGPU_BACKEND`) take wgpu's
/// instance unchanged, as does a Vulkan loader that fails here (wgpu then
/// reports no Vulkan adapter, as it would).
#[cfg(all(unix, not(target_vendor = "apple"), not(target_os = "android")))]
fn compute_only_vulkan(desc: &wgpu::InstanceDescriptor) -> Option<wgpu::Instance> {
    use wgpu::hal;
    // the backends a Unix desktop build of wgpu has: Vulkan alone, or with GL
    if desc.backends & (wgpu::Backends::VULKAN | wgpu::Backends::GL) != wgpu::Backends::VULKAN {
        return None;
    }
    let hal_desc = hal::InstanceDescriptor {
        name: "lfast",
        flags: desc.flags,
        memory_budget_thresholds: desc.memory_budget_thresholds,
        backend_options: desc.backend_options.clone(),
        telemetry: None,
        display: None,
    };
    let leave_out_window_systems: Box<hal::vulkan::CreateInstanceCallback> = Box::new(|args| {
        args.extensions.retain(|e| !WINDOW_SYSTEM_EXTENSIONS.contains(e));
    });
    // SAFETY: `hal_desc` is a valid descriptor without a display handle. The
    // callback only removes the window-system surface extensions, which no
    // code path of this instance uses (see above): lfast creates no surface.
    let hal_instance = unsafe { hal::vulkan::Instance::init_with_callback(&hal_desc, Some(leave_out_window_systems)) };
    match hal_instance {
        // SAFETY: a Vulkan instance of this build's wgpu-hal, given to wgpu whole.
        Ok(inst) => Some(unsafe { wgpu::Instance::from_hal::<hal::api::Vulkan>(inst) }),
        Err(e) => {
            log::debug!("compute-only Vulkan instance: {e}; using wgpu's own");
            None
        }
    }
}

#[cfg(not(all(unix, not(target_vendor = "apple"), not(target_os = "android"))))]
fn compute_only_vulkan(_: &wgpu::InstanceDescriptor) -> Option<wgpu::Instance> {
    None
}

/// The first adapter whose name contains `name` (case-insensitive), else why not.
fn index_named(infos: &[wgpu::AdapterInfo], name: &str) -> std::result::Result<usize, String> {
    let want = name.to_lowercase();
    infos.iter().position(|i| i.name.to_lowercase().contains(&want)).ok_or_else(|| {
        let names: Vec<&str> = infos.iter().map(|i| i.name.as_str()).collect();
        format!("none named like `{name}` among {names:?}")
    })
}

/// The adapter `Backend::Auto` takes among `infos` and whether it was named
/// (see [`GpuContext::new_auto`]), else why it takes none.
fn auto_index(infos: &[wgpu::AdapterInfo], opts: &GpuOptions) -> std::result::Result<(usize, bool), String> {
    if let Some(name) = opts.name() {
        return index_named(infos, &name).map(|i| (i, true));
    }
    let power = opts.power();
    (0..infos.len())
        .filter(|&i| is_hardware(&infos[i]))
        .min_by_key(|&i| rank(&infos[i], power))
        .map(|i| (i, false))
        .ok_or_else(|| no_hardware_reason(infos))
}

/// Takes adapter `i` of `all` (an index into its infos).
fn take(all: Vec<wgpu::Adapter>, i: usize) -> Result<wgpu::Adapter> {
    all.into_iter().nth(i).ok_or_else(|| Error::NoAdapter { reason: "adapter list changed".into() })
}

fn no_hardware_reason(infos: &[wgpu::AdapterInfo]) -> String {
    let soft: Vec<String> =
        infos.iter().filter(|i| !is_hardware(i)).map(|i| format!("{} ({:?})", i.name, i.device_type)).collect();
    if soft.is_empty() {
        "no GPU adapter found".into()
    } else {
        format!(
            "no hardware GPU adapter; only {}, which the CPU path outruns (name one with --adapter or \
             WGPU_ADAPTER_NAME, or use --backend gpu, to run on it anyway)",
            soft.join(", ")
        )
    }
}

/// What `Backend::Auto` would do with these options (for `lfast info`); opens nothing.
pub fn auto_choice(opts: &GpuOptions) -> AutoChoice {
    let mut infos = list_adapters(opts);
    match auto_index(&infos, opts) {
        Ok((i, named)) => AutoChoice::Gpu { info: Box::new(infos.swap_remove(i)), named },
        Err(why) => AutoChoice::Cpu(why),
    }
}

/// Every adapter the options' backends expose (for `lfast info`).
pub fn list_adapters(opts: &GpuOptions) -> Vec<wgpu::AdapterInfo> {
    pollster::block_on(instance(opts).enumerate_adapters(opts.backends())).iter().map(|a| a.get_info()).collect()
}

impl GpuContext {
    /// Opens the adapter the options (or the environment) select, blocking.
    pub fn new(opts: &GpuOptions) -> Result<Self> {
        pollster::block_on(Self::new_async(opts))
    }

    /// Opens the adapter the options (or the environment) select: the named
    /// one, else wgpu's choice for the power preference, which may be a
    /// software adapter. This is the explicit request (`Backend::Gpu`); see
    /// [`new_auto`](Self::new_auto) for `Backend::Auto`.
    pub async fn new_async(opts: &GpuOptions) -> Result<Self> {
        super::kernel::parse_shaders_in_background();
        let inst = instance(opts);
        let adapter = match opts.name() {
            Some(name) => {
                let all = inst.enumerate_adapters(opts.backends()).await;
                let infos: Vec<_> = all.iter().map(|a| a.get_info()).collect();
                let i = index_named(&infos, &name).map_err(|reason| Error::NoAdapter { reason })?;
                take(all, i)?
            }
            None => inst
                .request_adapter(&wgpu::RequestAdapterOptions { power_preference: opts.power(), ..Default::default() })
                .await
                .map_err(|e| Error::NoAdapter { reason: e.to_string() })?,
        };
        Self::open(adapter).await
    }

    /// The context `Backend::Auto` runs on: the adapter named by the options
    /// or `WGPU_ADAPTER_NAME` (any type: naming one is asking for it), else
    /// the best hardware adapter. A software adapter is never taken unnamed:
    /// `Err(NoAdapter)` then, and the caller runs the CPU path.
    pub fn new_auto(opts: &GpuOptions) -> Result<Self> {
        super::kernel::parse_shaders_in_background();
        pollster::block_on(async {
            let inst = instance(opts);
            let all = inst.enumerate_adapters(opts.backends()).await;
            let infos: Vec<_> = all.iter().map(|a| a.get_info()).collect();
            let (i, _) = auto_index(&infos, opts).map_err(|reason| Error::NoAdapter { reason })?;
            Self::open(take(all, i)?).await
        })
    }

    async fn open(adapter: wgpu::Adapter) -> Result<Self> {
        let info = adapter.get_info();
        // Timestamps are optional: per-pass timings when the adapter has them.
        let features = adapter.features() & wgpu::Features::TIMESTAMP_QUERY;
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("lfast"),
                required_features: features,
                // The adapter's own limits: large frames need large storage buffers.
                required_limits: adapter.limits(),
                ..Default::default()
            })
            .await
            .map_err(|e| Error::Gpu { reason: format!("device request refused by {}: {e}", info.name) })?;
        Ok(Self { owned: true, ..Self::from_device(device, queue, info) })
    }

    /// Wraps an embedder's device. lfast installs a device-lost callback (so
    /// a loss becomes [`Error::DeviceLost`]) and an uncaptured-error handler
    /// that logs instead of panicking.
    pub fn from_device(device: wgpu::Device, queue: wgpu::Queue, info: wgpu::AdapterInfo) -> Self {
        let lost = Arc::new(Mutex::new(None));
        let l = lost.clone();
        device.set_device_lost_callback(move |reason, msg| {
            if let Ok(mut g) = l.lock() {
                *g = Some(format!("{reason:?}: {msg}"));
            }
        });
        device.on_uncaptured_error(Arc::new(|e| log::error!("uncaptured wgpu error: {e}")));
        Self { device, queue, info, lost, owned: false }
    }

    /// Whether lfast opened this device itself (not [`from_device`](Self::from_device)):
    /// then a detector built on it warms its pipelines up with empty
    /// dispatches while it builds them (`GpuDetector::new`). An embedder's
    /// queue gets no submission it did not ask for.
    pub fn owns_queue(&self) -> bool {
        self.owned
    }

    /// [`check_lost`](Self::check_lost) after a non-blocking poll, which runs
    /// a pending device-lost callback (for the blocking entry points only:
    /// the embedding API never polls).
    pub fn check_lost_polled(&self) -> Result<()> {
        let _ = self.device.poll(wgpu::PollType::Poll);
        self.check_lost()
    }

    /// `Err(DeviceLost)` once the device has been lost (as far as the callback has told).
    pub fn check_lost(&self) -> Result<()> {
        match self.lost.lock().ok().and_then(|g| g.clone()) {
            Some(reason) => Err(Error::DeviceLost { reason }),
            None => Ok(()),
        }
    }

    /// True when the device supports per-pass timestamps.
    pub fn has_timestamps(&self) -> bool {
        self.device.features().contains(wgpu::Features::TIMESTAMP_QUERY)
    }

    /// Blocks until submission `index` (and those before it) has run; later
    /// submissions may still be running.
    pub fn wait_for(&self, index: wgpu::SubmissionIndex) -> Result<()> {
        self.wait_until(Some(index))
    }

    /// Waits until all submitted work is done.
    pub fn wait(&self) -> Result<()> {
        self.wait_until(None)
    }

    /// Blocks until submission `index` (None: the latest) has run.
    fn wait_until(&self, index: Option<wgpu::SubmissionIndex>) -> Result<()> {
        self.device
            .poll(wgpu::PollType::Wait { submission_index: index, timeout: None })
            .map(|_| ())
            .map_err(|e| Error::Gpu { reason: format!("poll: {e}") })?;
        self.check_lost()
    }

    /// Copies a whole buffer to the host (blocking; for tests and debugging).
    pub fn read_buffer(&self, buf: &wgpu::Buffer) -> Result<Vec<u8>> {
        self.read_range(buf, 0, buf.size())
    }

    /// Copies `len` bytes at `offset` of a buffer to the host (blocking).
    pub fn read_range(&self, buf: &wgpu::Buffer, offset: u64, len: u64) -> Result<Vec<u8>> {
        let len = len.next_multiple_of(4);
        if len == 0 {
            return Ok(Vec::new());
        }
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("read_range"),
            size: len,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut enc = self.device.create_command_encoder(&Default::default());
        enc.copy_buffer_to_buffer(buf, offset, &staging, 0, len);
        self.queue.submit([enc.finish()]);
        map_blocking(self, &staging, len)
    }
}

/// Maps `staging` for reading, waits, and copies out its first `len` bytes.
pub(crate) fn map_blocking(ctx: &GpuContext, staging: &wgpu::Buffer, len: u64) -> Result<Vec<u8>> {
    let slice = staging.slice(..len);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    ctx.wait()?;
    let r = rx.recv().map_err(|_| Error::Gpu { reason: "map_async callback never ran".into() })?;
    if let Err(e) = r {
        ctx.check_lost_polled()?;
        return Err(Error::Gpu { reason: format!("map_async: {e}") });
    }
    let out = slice.get_mapped_range().map_err(|e| Error::Gpu { reason: format!("mapped range: {e:?}") })?.to_vec();
    staging.unmap();
    Ok(out)
}
