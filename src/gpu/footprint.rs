//! What a frame size costs on the GPU, without a device: the bytes of every
//! buffer [`Buffers`](super::Buffers) allocates, each allocation once. The one
//! definition of those sizes: `Buffers::build` allocates them, and
//! [`workspace_report`] (`lfast info --size`, examples/gpu_bench.rs) reports them.
//! Tests: tests/gpu_footprint.rs (the report == the sizes of a workspace's buffers).

use super::buffers::{
    Allocated, DESC_WORDS, KP_WORDS, MASK_UNSET, SELECT_BUCKET_WORDS, SHARED_ATLAS, SHARED_CLASSES, SHARED_CORNERS,
    SHARED_LIST, SHARED_PACKED, counter, indirect,
};
use super::layout::{FrameLayout, MAX_LEVELS, TILE};
use crate::config::Config;
use crate::error::{Error, Result};

/// Bytes of each kind of buffer for one [`FrameLayout`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Sizes {
    /// The 8-bit input of level 0, four pixels per word.
    pub input: u64,
    /// A column-packed plane: a byte per pixel of every level.
    pub packed: u64,
    /// A plane of a u32 per pixel of every level.
    pub atlas: u64,
    /// A tile-column plane (`ruled`, `edge_bits`): a word per column of every tile.
    pub tiles: u64,
    /// A word per 16x16 tile of every level (`blur_tiles`).
    pub tile_words: u64,
    /// The walk list.
    pub walks: u64,
    /// A bit per pixel of every level (`flags`).
    pub bits: u64,
    /// 256 bins per level.
    pub hist: u64,
    /// A word per level.
    pub otsu: u64,
    /// The window grids.
    pub grid: u64,
    /// Four words per window.
    pub windows: u64,
    /// Per SPEC 5 cell its bins and its invocations' extents, for the most
    /// cells a smaller frame can have ([`Allocated::cell_words`]).
    pub cell_hist: u64,
    /// A [`GpuKeypoint`](super::GpuKeypoint) per corner slot (`corners`).
    pub corners: u64,
    /// Four words per corner slot (`ranks`, `sel_members`).
    pub records: u64,
    /// A [`GpuKeypoint`](super::GpuKeypoint) per final keypoint slot: the
    /// corner slots, or `n_features` when that caps them.
    pub keypoints: u64,
    /// A descriptor per final keypoint slot.
    pub descriptors: u64,
    /// A u32 per pixel of every level: the mask, once one is set.
    pub mask: u64,
    /// The pattern tables.
    pub patterns: u64,
    /// The orientation sector bounds.
    pub angle_bounds: u64,
}

/// Final keypoint slots (`keypoints`, `descriptors`, the readback): the
/// corner slots, or `n_features` when that caps them (select never places a
/// keypoint at or past the cap).
pub(crate) fn final_slots(cfg: &Config, a: &Allocated) -> u64 {
    if cfg.n_features > 0 { a.keypoints.min(cfg.n_features as u64) } else { a.keypoints }
}

/// What `device.create_buffer` is asked for: at least 16 bytes, a multiple of 16.
pub(crate) fn rounded(bytes: u64) -> u64 {
    bytes.max(16).next_multiple_of(16)
}

impl Sizes {
    pub(crate) fn of(cfg: &Config, layout: &FrameLayout, a: &Allocated) -> Self {
        let cap = a.keypoints;
        let slots = final_slots(cfg, a);
        Self {
            input: a.input,
            packed: a.packed * 4,
            atlas: layout.total_px as u64 * 4,
            tiles: a.tiles * TILE as u64 * 4,
            tile_words: a.tiles * 4,
            walks: (a.tiles * 4 + 64) * 4,
            bits: (layout.total_px as u64).div_ceil(32) * 4,
            hist: 256 * 4 * a.levels,
            otsu: 4 * a.levels,
            grid: 4 * (a.grid as usize).max(layout.grid_data.len()).max(4) as u64,
            windows: 16 * a.windows,
            cell_hist: 4 * a.cell_words,
            corners: cap * KP_WORDS * 4,
            records: cap * 16,
            keypoints: slots * KP_WORDS * 4,
            descriptors: slots * DESC_WORDS * 4,
            mask: layout.total_px as u64 * 4,
            patterns: 4 * super::buffers::pattern_words_len(cfg) as u64,
            angle_bounds: 8 * cfg.orientation_bins.max(1) as u64,
        }
    }

    /// Every allocation, by name, with the bytes it is created with.
    pub(crate) fn allocations(&self) -> Vec<(&'static str, u64)> {
        let s = self;
        let list = [
            ("params", std::mem::size_of::<super::layout::Params>() as u64),
            ("level_index", MAX_LEVELS as u64 * super::kernel::DYNAMIC_STRIDE),
            ("input", s.input),
            ("gray", s.packed),
            ("mask", MASK_UNSET),
            ("denoised", s.packed),
            (SHARED_PACKED, s.packed),
            ("nms", s.packed),
            ("hist", s.hist),
            ("otsu", s.otsu),
            ("grid", s.grid),
            ("windows", s.windows),
            (SHARED_CLASSES, s.packed),
            ("ruled", s.tiles),
            ("walks", s.walks),
            (SHARED_ATLAS, s.lists()),
            ("flags", s.bits),
            ("edges", s.packed),
            ("edge_bits", s.tiles),
            ("blur_tiles", s.tile_words),
            (SHARED_LIST, s.lists()),
            (SHARED_CORNERS, s.shared_corners()),
            ("sel_buckets", SELECT_BUCKET_WORDS * 4),
            ("keypoints", s.keypoints),
            ("descriptors", s.descriptors),
            ("counters", counter::LEN as u64 * 4),
            ("indirect", indirect::SIZE),
            ("patterns", s.patterns),
            ("angle_bounds", s.angle_bounds),
        ];
        // `init_buffer`'s (written at creation) are a multiple of 4 bytes, the others of 16
        const INIT: [&str; 6] = ["params", "level_index", "grid", "indirect", "patterns", "angle_bounds"];
        list.into_iter()
            .map(|(n, b)| (n, if INIT.contains(&n) { b.next_multiple_of(4).max(4) } else { rounded(b) }))
            .collect()
    }

    /// The allocations `labels = edge_list = resp = ranks` and `cand_list =
    /// sel_members`: a u32 per pixel of every level, or select's records when
    /// they take more (tiny frames).
    pub(crate) fn lists(&self) -> u64 {
        self.atlas.max(self.records)
    }

    /// The allocation `cell_hist` and `corners` share.
    pub(crate) fn shared_corners(&self) -> u64 {
        self.cell_hist.max(self.corners)
    }

    /// The report of a `width x height` frame laid out into these sizes.
    pub(crate) fn report(&self, width: u32, height: u32) -> WorkspaceReport {
        WorkspaceReport {
            width,
            height,
            buffers: self.allocations(),
            largest_storage: self.largest_storage(),
            mask_bytes: rounded(self.mask),
        }
    }

    /// The largest buffer bound as storage: what `max_storage_buffer_binding_size` and
    /// `max_buffer_size` must allow.
    pub(crate) fn largest_storage(&self) -> u64 {
        self.atlas.max(self.corners).max(self.cell_hist)
    }
}

/// The GPU workspace of one frame size: every buffer of [`Buffers`](super::Buffers),
/// each allocation once (planes that share one are listed as `a = b`), without a
/// mask (see [`mask_bytes`](Self::mask_bytes)) and the readback ring's staging
/// buffers (80 bytes per final keypoint slot each).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct WorkspaceReport {
    /// Frame width.
    pub width: u32,
    /// Frame height.
    pub height: u32,
    /// Every allocation and its bytes.
    pub buffers: Vec<(&'static str, u64)>,
    /// The largest buffer bound as storage, in bytes (the limits it must fit).
    pub largest_storage: u64,
    /// Bytes a mask adds once one is set (`GpuDetector::set_mask`).
    pub mask_bytes: u64,
}

impl WorkspaceReport {
    /// Bytes of all buffers.
    pub fn total(&self) -> u64 {
        self.buffers.iter().map(|b| b.1).sum()
    }

    /// Bytes per pixel of the frame.
    pub fn bytes_per_pixel(&self) -> f64 {
        self.total() as f64 / (self.width as f64 * self.height as f64)
    }

    /// The largest allocation: its name and bytes.
    pub fn largest(&self) -> (&'static str, u64) {
        self.buffers.iter().copied().max_by_key(|b| b.1).unwrap_or(("none", 0))
    }

    /// Ok when the frame's buffers fit `limits`; else [`Error::GpuLimits`]
    /// naming the frame size, the bytes needed and the limit.
    ///
    /// ```
    /// let cfg = lfast::Config::default();
    /// let r = lfast::gpu::workspace_report(&cfg, 3840, 2160).unwrap();
    /// assert!(r.fits(&lfast::wgpu::Limits::default()).is_ok());
    /// let e = lfast::gpu::workspace_report(&cfg, 8000, 6000).unwrap().fits(&lfast::wgpu::Limits::default());
    /// assert!(e.unwrap_err().to_string().contains("8000x6000"));
    /// ```
    pub fn fits(&self, limits: &wgpu::Limits) -> Result<()> {
        let allowed = limits.max_storage_buffer_binding_size.min(limits.max_buffer_size);
        if self.largest_storage > allowed {
            return Err(Error::GpuLimits {
                reason: format!(
                    "a {}x{} frame needs storage buffers of {} bytes, the device allows {allowed} \
                     (max_storage_buffer_binding_size {}, max_buffer_size {})",
                    self.width,
                    self.height,
                    self.largest_storage,
                    limits.max_storage_buffer_binding_size,
                    limits.max_buffer_size
                ),
            });
        }
        Ok(())
    }
}

/// What a `width x height` frame's workspace allocates under `cfg`, computed
/// without a device.
///
/// ```
/// let r = lfast::gpu::workspace_report(&lfast::Config::default(), 1241, 376).unwrap();
/// assert!(r.bytes_per_pixel() > 1.0 && r.largest().1 <= r.total());
/// ```
pub fn workspace_report(cfg: &Config, width: u32, height: u32) -> Result<WorkspaceReport> {
    crate::image::check_size(width, height)?;
    cfg.validate()?;
    let layout = FrameLayout::new(cfg, width, height);
    let allocated = Allocated::of(&layout);
    let sizes = Sizes::of(cfg, &layout, &allocated);
    Ok(sizes.report(width, height))
}
