//! [`Detector`]: one front door over the GPU and CPU paths.

use crate::config::Config;
use crate::cpu::CpuDetector;
use crate::error::{Error, Result};
#[cfg(feature = "gpu")]
use crate::gpu::detector::{GpuDetector, GpuWorkspace};
#[cfg(feature = "gpu")]
use crate::gpu::{GpuContext, GpuOptions};
use crate::image::{GrayView, Plane};
use crate::keypoint::{Descriptor, KeyPoint};
#[cfg(feature = "gpu")]
use std::sync::Mutex;

/// Which path runs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Backend {
    /// A hardware GPU (discrete, integrated or virtual) when one opens, or the
    /// adapter named by `WGPU_ADAPTER_NAME` / [`GpuOptions::adapter_name`];
    /// else the CPU, with a logged warning. Never a software adapter
    /// (lavapipe, WARP, SwiftShader) unless named: the CPU path is faster.
    #[default]
    Auto,
    /// The GPU or an error: any adapter, software ones included.
    Gpu,
    /// The CPU reference path.
    Cpu,
}

impl std::str::FromStr for Backend {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s.to_ascii_lowercase().as_str() {
            "auto" => Ok(Backend::Auto),
            "gpu" => Ok(Backend::Gpu),
            "cpu" => Ok(Backend::Cpu),
            _ => Err(Error::InvalidConfig { field: "backend", reason: format!("must be auto, gpu or cpu, got `{s}`") }),
        }
    }
}

#[cfg(feature = "gpu")]
pub(crate) struct Gpu {
    pub(crate) det: GpuDetector,
    pub(crate) ws: Mutex<Option<GpuWorkspace>>,
}

/// Built without the `gpu` feature: there is never a GPU (an uninhabited type).
#[cfg(not(feature = "gpu"))]
pub(crate) enum Gpu {}

/// L-FAST on the GPU or the CPU, with the same results (see docs/algorithm.md).
///
/// ```
/// use lfast::{Backend, Config, Detector};
/// let det = Detector::new(Config::default(), Backend::Cpu).unwrap();
/// let img = lfast::Plane::<u8>::new(64, 48);
/// let (kps, _desc) = det.detect_and_compute(img.view(), None).unwrap();
/// assert!(kps.is_empty());
/// assert_eq!(det.backend_name(), "cpu");
/// ```
pub struct Detector {
    cpu: CpuDetector,
    gpu: Option<Gpu>,
    /// Auto mode: fall back to the CPU on GPU failures.
    #[cfg_attr(not(feature = "gpu"), allow(dead_code))]
    auto: bool,
    /// Set once the GPU failed in Auto mode; later frames go to the CPU.
    fell_back: std::sync::atomic::AtomicBool,
}

impl std::fmt::Debug for Detector {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Detector").field("backend", &self.backend_name()).finish()
    }
}

impl Detector {
    /// A detector on `backend`, choosing the adapter from the environment
    /// (`WGPU_BACKEND`, `WGPU_ADAPTER_NAME`).
    /// Without the `gpu` feature, `Backend::Gpu` is an [`Error::Unsupported`]
    /// and `Backend::Auto` is the CPU.
    pub fn new(cfg: Config, backend: Backend) -> Result<Self> {
        #[cfg(feature = "gpu")]
        return Self::with_gpu_options(cfg, backend, &GpuOptions::default());
        #[cfg(not(feature = "gpu"))]
        {
            let cpu = CpuDetector::new(cfg)?;
            if backend == Backend::Gpu {
                return Err(Error::Unsupported { reason: "lfast was built without its `gpu` feature".into() });
            }
            Ok(Self { cpu, gpu: None, auto: backend == Backend::Auto, fell_back: Default::default() })
        }
    }

    /// [`new`](Self::new) with explicit adapter options.
    #[cfg(feature = "gpu")]
    pub fn with_gpu_options(cfg: Config, backend: Backend, opts: &GpuOptions) -> Result<Self> {
        let cpu = CpuDetector::new(cfg.clone())?;
        let auto = backend == Backend::Auto;
        if backend == Backend::Gpu {
            // what the GPU path cannot do fails by its field's name, before a device is opened
            crate::config::gpu_supports(&gpu_config(cfg.clone()))?;
        }
        let gpu = match backend {
            Backend::Cpu => None,
            Backend::Gpu => Some(GpuContext::new(opts).and_then(|ctx| GpuDetector::new(ctx, gpu_config(cfg)))?),
            // the FAST fill is CPU-only (Backend::Gpu above refuses it by name)
            Backend::Auto if cfg.fills() => None,
            Backend::Auto => match GpuContext::new_auto(opts).and_then(|ctx| GpuDetector::new(ctx, gpu_config(cfg))) {
                Ok(d) => Some(d),
                Err(e) => {
                    log::warn!("GPU unavailable ({e}); using the CPU path");
                    None
                }
            },
        };
        Ok(Self { cpu, gpu: gpu.map(|det| Gpu { det, ws: Mutex::new(None) }), auto, fell_back: Default::default() })
    }

    /// A detector on an embedder's device.
    #[cfg(feature = "gpu")]
    pub fn from_context(ctx: GpuContext, cfg: Config) -> Result<Self> {
        let cpu = CpuDetector::new(cfg.clone())?;
        let det = GpuDetector::new(ctx, gpu_config(cfg))?;
        Ok(Self { cpu, gpu: Some(Gpu { det, ws: Mutex::new(None) }), auto: false, fell_back: Default::default() })
    }

    /// A detector on an embedder's device that, like [`Backend::Auto`], runs a
    /// frame on the CPU (with a logged warning) when the GPU fails on it, and
    /// stays on the CPU after a device loss.
    #[cfg(feature = "gpu")]
    pub fn from_context_with_fallback(ctx: GpuContext, cfg: Config) -> Result<Self> {
        let mut d = Self::from_context(ctx, cfg)?;
        d.auto = true;
        Ok(d)
    }

    /// `"gpu"` or `"cpu"`: what the next frame runs on.
    pub fn backend_name(&self) -> &'static str {
        if self.active_gpu().is_some() { "gpu" } else { "cpu" }
    }

    /// The GPU adapter's name, when the GPU is in use.
    pub fn adapter_name(&self) -> Option<String> {
        #[cfg(feature = "gpu")]
        return self.active_gpu().map(|g| g.det.context().info.name.clone());
        #[cfg(not(feature = "gpu"))]
        self.active_gpu().map(|g| match *g {})
    }

    /// The configuration.
    pub fn config(&self) -> &Config {
        self.cpu.config()
    }

    /// Whether frames run on a software adapter (lavapipe, WARP,
    /// SwiftShader: [`is_software`](crate::gpu::is_software)), whose "GPU"
    /// is this CPU's own cores.
    pub(crate) fn on_software_gpu(&self) -> bool {
        #[cfg(feature = "gpu")]
        return self.active_gpu().is_some_and(|g| crate::gpu::is_software(&g.det.context().info));
        #[cfg(not(feature = "gpu"))]
        false
    }

    pub(crate) fn active_gpu(&self) -> Option<&Gpu> {
        self.gpu.as_ref().filter(|_| !self.fell_back.load(std::sync::atomic::Ordering::Relaxed))
    }

    /// Runs `f` on the GPU; in Auto mode a GPU failure (device lost, out of
    /// memory, a frame over the device's limits) is logged and the frame goes
    /// to the CPU — and so do later frames after a device loss.
    #[cfg(feature = "gpu")]
    fn run<T>(
        &self,
        on_gpu: impl FnOnce(&GpuDetector, &mut Option<GpuWorkspace>) -> Result<T>,
        on_cpu: impl FnOnce(&CpuDetector) -> Result<T>,
    ) -> Result<T> {
        let Some(g) = self.active_gpu() else { return on_cpu(&self.cpu) };
        let r = {
            let mut ws = g.ws.lock().map_err(|_| Error::Gpu { reason: "workspace lock poisoned".into() })?;
            on_gpu(&g.det, &mut ws)
        };
        match r {
            Ok(v) => Ok(v),
            Err(e) => {
                self.fall_back(e)?;
                on_cpu(&self.cpu)
            }
        }
    }

    /// After GPU error `e`: `Ok` when the frame goes to the CPU instead (Auto
    /// mode, logged; after a device loss later frames too), else `Err(e)`.
    #[cfg(feature = "gpu")]
    pub(crate) fn fall_back(&self, e: Error) -> Result<()> {
        match e {
            // bad input is the caller's error on either path
            Error::InvalidImage { .. } | Error::MaskSize { .. } | Error::InvalidConfig { .. } => Err(e),
            e if self.auto => {
                if matches!(e, Error::DeviceLost { .. } | Error::Gpu { .. }) {
                    self.fell_back.store(true, std::sync::atomic::Ordering::Relaxed);
                    log::warn!("GPU failed ({e}); this and later frames run on the CPU");
                } else {
                    log::warn!("GPU cannot take this frame ({e}); it runs on the CPU");
                }
                Ok(())
            }
            e => Err(e),
        }
    }

    /// The CPU path.
    #[cfg(feature = "gpu")]
    pub(crate) fn cpu(&self) -> &CpuDetector {
        &self.cpu
    }

    /// Keypoints and descriptors (SPEC 1-11); `desc[i]` belongs to `kps[i]`.
    pub fn detect_and_compute(
        &self,
        image: GrayView<'_>,
        mask: Option<GrayView<'_>>,
    ) -> Result<(Vec<KeyPoint>, Vec<Descriptor>)> {
        if self.config().descriptor == crate::config::DescriptorKind::Opencv {
            return self.opencv_descriptors(image, mask);
        }
        self.features(image, mask)
    }

    /// [`detect_and_compute`](Self::detect_and_compute) with `image` handed to
    /// the CPU path as the pyramid's level 0 instead of copied
    /// ([`CpuDetector::detect_and_compute_in`]; the GPU uploads it as
    /// before). `image` is handed back unchanged.
    pub fn detect_and_compute_in(
        &self,
        image: &mut Plane<u8>,
        mask: Option<GrayView<'_>>,
    ) -> Result<(Vec<KeyPoint>, Vec<Descriptor>)> {
        if self.config().descriptor == crate::config::DescriptorKind::Opencv || image.width == 0 || image.height == 0 {
            return self.detect_and_compute(image.view(), mask);
        }
        image.view().check()?;
        #[cfg(feature = "gpu")]
        {
            // each closure borrows the image in turn (the CPU's only after a GPU failure)
            let image = std::cell::RefCell::new(image);
            self.run(
                |g, ws| {
                    let img = image.borrow();
                    g.detect_and_compute(ws, img.view(), mask).map(|f| (f.keypoints, f.descriptors))
                },
                |c| c.detect_and_compute_in(&mut image.borrow_mut(), mask),
            )
        }
        #[cfg(not(feature = "gpu"))]
        self.cpu.detect_and_compute_in(image, mask)
    }

    /// Keypoints and lfast descriptors on the active backend.
    fn features(&self, image: GrayView<'_>, mask: Option<GrayView<'_>>) -> Result<(Vec<KeyPoint>, Vec<Descriptor>)> {
        image.check()?;
        if image.width() == 0 || image.height() == 0 {
            return self.cpu.detect_and_compute(image, mask);
        }
        #[cfg(feature = "gpu")]
        return self.run(
            |g, ws| g.detect_and_compute(ws, image, mask).map(|f| (f.keypoints, f.descriptors)),
            |c| c.detect_and_compute(image, mask),
        );
        #[cfg(not(feature = "gpu"))]
        self.cpu.detect_and_compute(image, mask)
    }

    /// `descriptor = "opencv"`: the CPU describes (OpenCV's blur sums in f32
    /// with fused multiply-adds, and its rotation uses f32 `cos`/`sin`, which
    /// WGSL does not round the same way; docs/algorithm.md). `Backend::Gpu`
    /// refuses; `Backend::Auto` runs the whole frame on the CPU.
    fn opencv_descriptors(
        &self,
        image: GrayView<'_>,
        mask: Option<GrayView<'_>>,
    ) -> Result<(Vec<KeyPoint>, Vec<Descriptor>)> {
        if self.active_gpu().is_some() && !self.auto {
            crate::config::gpu_supports(self.config())?;
        }
        self.cpu.detect_and_compute(image, mask)
    }

    /// Keypoints only (the same whichever `descriptor` the config names).
    pub fn detect(&self, image: GrayView<'_>, mask: Option<GrayView<'_>>) -> Result<Vec<KeyPoint>> {
        self.features(image, mask).map(|(k, _)| k)
    }

    /// The improved Canny edge map E (255 = edge).
    pub fn edge_image(&self, image: GrayView<'_>) -> Result<Plane<u8>> {
        image.check()?;
        #[cfg(feature = "gpu")]
        return self.run(|g, ws| g.edge_image(ws, image), |c| c.edge_image(image));
        #[cfg(not(feature = "gpu"))]
        self.cpu.edge_image(image)
    }
}

/// The GPU detector's config: the same, but with lfast's descriptor, as the
/// GPU only ever detects for a `descriptor = "opencv"` detector (the CPU
/// describes, [`Detector::detect_and_compute`]).
#[cfg(feature = "gpu")]
fn gpu_config(cfg: Config) -> Config {
    Config { descriptor: crate::config::DescriptorKind::Lfast, ..cfg }
}
