//! The device and queue lfast runs on: chosen from the environment
//! (`WGPU_BACKEND`, `WGPU_ADAPTER_NAME`, `WGPU_POWER_PREF`) or given by an
//! embedder who already has one.

use crate::error::{Error, Result};
use std::sync::{Arc, Mutex};

/// How to pick an adapter. `Default` reads the environment.
#[derive(Clone, Debug, Default)]
pub struct GpuOptions {
    /// Backends to consider; `None` = `WGPU_BACKEND` if set, else the primary
    /// ones (Vulkan, Metal, DX12; GL only when asked for).
    pub backends: Option<wgpu::Backends>,
    /// Case-insensitive substring of the adapter name; `None` = `WGPU_ADAPTER_NAME` if set.
    pub adapter_name: Option<String>,
}

impl GpuOptions {
    fn backends(&self) -> wgpu::Backends {
        self.backends.unwrap_or_else(|| wgpu::Backends::from_env().unwrap_or(wgpu::Backends::PRIMARY))
    }

    fn name(&self) -> Option<String> {
        self.adapter_name.clone().or_else(|| std::env::var("WGPU_ADAPTER_NAME").ok()).filter(|s| !s.is_empty())
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
}

fn instance(opts: &GpuOptions) -> wgpu::Instance {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
    desc.backends = opts.backends();
    wgpu::Instance::new(desc)
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

    /// Opens the adapter the options (or the environment) select.
    pub async fn new_async(opts: &GpuOptions) -> Result<Self> {
        let inst = instance(opts);
        let adapter = match opts.name() {
            Some(name) => {
                let all = inst.enumerate_adapters(opts.backends()).await;
                let names: Vec<String> = all.iter().map(|a| a.get_info().name).collect();
                let want = name.to_lowercase();
                all.into_iter().find(|a| a.get_info().name.to_lowercase().contains(&want)).ok_or_else(|| {
                    Error::NoAdapter { reason: format!("none named like `{name}` among {names:?}") }
                })?
            }
            None => inst
                .request_adapter(&wgpu::RequestAdapterOptions {
                    power_preference: wgpu::PowerPreference::from_env().unwrap_or(wgpu::PowerPreference::HighPerformance),
                    ..Default::default()
                })
                .await
                .map_err(|e| Error::NoAdapter { reason: e.to_string() })?,
        };
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
        Ok(Self::from_device(device, queue, info))
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
        Self { device, queue, info, lost }
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

    /// Waits until all submitted work is done.
    pub fn wait(&self) -> Result<()> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
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
