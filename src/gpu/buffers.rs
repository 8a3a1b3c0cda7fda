//! Every GPU buffer of one frame size, by name. Built once per size by
//! [`Buffers::new`] and reused for every frame of that size.

use super::footprint::{Sizes, rounded};
use super::kernel::DYNAMIC_STRIDE;
use super::kernel::init_buffer;
use super::layout::{FrameLayout, MAX_LEVELS, MAX_WINDOWS_PER_AXIS, TILE_ROW};
use crate::config::Config;
use crate::error::{Error, Result};
use crate::spec::angle::AngleBins;
use crate::spec::pattern::{Pattern, RotatedPatterns};
use crate::spec::windows::MAX_CELLS_PER_AXIS;
use bytemuck::{Pod, Zeroable};

/// One keypoint as the GPU stores it (48 bytes; `shaders/select.wgsl`'s `Kp`).
/// `x, y, size` are in input-image pixels, ready to draw; `px, py, level`
/// locate it in the pyramid; `m10, m01` are the exact intensity-centroid
/// moments from which the host derives `KeyPoint::angle` as the CPU does.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuKeypoint {
    /// Position in the input image, x.
    pub x: f32,
    /// Position in the input image, y.
    pub y: f32,
    /// Diameter, `31 s^level`.
    pub size: f32,
    /// Angle in degrees from the GPU's atan2 (approximate; the host recomputes it exactly).
    pub angle: f32,
    /// Harris response.
    pub response: f32,
    /// Pyramid level.
    pub level: u32,
    /// Column at that level.
    pub px: u32,
    /// Row at that level.
    pub py: u32,
    /// First-order moment along x.
    pub m10: i32,
    /// First-order moment along y.
    pub m01: i32,
    /// Orientation bin.
    pub bin: u32,
    /// The snapped corner's sub-pixel offset (src/cpu/snap.rs): x in bits 0-7 and y in
    /// bits 8-15, each an i8 in 1/16 of a level pixel ([`GpuKeypoint::sub_steps`]); 0 without snap.
    pub sub: u32,
}

impl GpuKeypoint {
    /// The sub-pixel offset as `Corner::sub` holds it, in 1/16 of a level pixel.
    ///
    /// ```
    /// let k = lfast::gpu::GpuKeypoint { sub: 0xfd04, ..Default::default() };
    /// assert_eq!(k.sub_steps(), [4, -3]);
    /// ```
    pub fn sub_steps(&self) -> [i8; 2] {
        [self.sub as u8 as i8, (self.sub >> 8) as u8 as i8]
    }
}

/// The label of the allocation `m` and `smooth` share.
pub(crate) const SHARED_PACKED: &str = "m = smooth";
/// The label of the allocation `labels`, `edge_list`, `resp` and `ranks` share.
pub(crate) const SHARED_ATLAS: &str = "labels = edge_list = resp = ranks";
/// The label of the allocation `classes` and `cand` share.
pub(crate) const SHARED_CLASSES: &str = "classes = cand";
/// The label of the allocation `cell_hist` and `corners` share.
pub(crate) const SHARED_CORNERS: &str = "cell_hist = corners";
/// The label of the allocation `cand_list` and `sel_members` share.
pub(crate) const SHARED_LIST: &str = "cand_list = sel_members";
/// Bytes of [`Buffers::mask`] until a mask is set.
pub(crate) const MASK_UNSET: u64 = 16;

/// u32 words per [`GpuKeypoint`].
pub const KP_WORDS: u64 = 12;
/// u32 words per descriptor.
pub const DESC_WORDS: u64 = 8;

/// Buckets of select's order keys (`BUCKETS` in shaders/select.wgsl).
pub const SELECT_BUCKETS: u64 = 4096;
/// Words of [`Buffers::sel_buckets`]: five per bucket.
pub const SELECT_BUCKET_WORDS: u64 = 5 * SELECT_BUCKETS;

/// Offsets in [`Buffers::indirect`]: dispatch args over the corner list,
/// over the final keypoints, and `draw` args (4 vertices per keypoint instance).
pub mod indirect {
    /// `dispatch_workgroups_indirect` over the unsorted corners (64 per group).
    pub const CORNERS: u64 = 0;
    /// `dispatch_workgroups_indirect` over the final keypoints (64 per group).
    pub const KEYPOINTS: u64 = 16;
    /// `draw_indirect` args: vertex_count 4, instance_count = keypoints.
    pub const DRAW: u64 = 32;
    /// `dispatch_workgroups_indirect` with one workgroup per final keypoint:
    /// `(min(n, 65535), ceil(n / 65535), 1)` (orientation, orb).
    pub const KEYPOINT_GROUPS: u64 = 48;
    /// `dispatch_workgroups_indirect` over the candidate list (64 per group):
    /// `(min(g, 65535), ceil(g / 65535), 1)`, g = ceil(candidates / 64)
    /// (response, corner NMS; written by the candidate-list pass).
    pub const CANDS: u64 = 64;
    /// `dispatch_workgroups_indirect` over the L-FAST edge list (64 per
    /// group), as [`CANDS`] (the L-FAST test; written by the lfast pass).
    pub const EDGES: u64 = 80;
    /// `dispatch_workgroups_indirect` over the walk list (64 per group), as
    /// [`CANDS`] (hysteresis; written by its `walk_args`).
    pub const WALKS: u64 = 96;
    /// Size of the buffer.
    pub const SIZE: u64 = 112;
}

/// Slots of [`Buffers::counters`]. The shaders see them as `C_CORNERS`,
/// `C_KEYPOINTS`, ... ([`counter::wgsl`]).
pub mod counter {
    /// Corners appended by corner NMS.
    pub const CORNERS: usize = 0;
    /// Final keypoints (after the cap).
    pub const KEYPOINTS: usize = 1;
    /// Corners taken by their level quota (select).
    pub const TAKEN: usize = 2;
    /// Entries of the candidate list (`cand_list`).
    pub const CANDS: usize = 3;
    /// Entries of the L-FAST edge list (`edge_list`).
    pub const EDGES: usize = 4;
    /// Entries of the walk list (`walks`, appended by rules).
    pub const WALKS: usize = 5;
    /// The largest response magnitude (`|r|` as bits) of the frame's corners (select).
    pub const MAG_MAX: usize = 6;
    /// The smallest response magnitude of the frame's corners (select).
    pub const MAG_MIN: usize = 7;
    /// Words in the buffer.
    pub const LEN: usize = 8;

    /// Every counter by its WGSL name.
    pub const ALL: [(&str, usize); 8] = [
        ("C_CORNERS", CORNERS),
        ("C_KEYPOINTS", KEYPOINTS),
        ("C_TAKEN", TAKEN),
        ("C_CANDS", CANDS),
        ("C_EDGES", EDGES),
        ("C_WALKS", WALKS),
        ("C_MAG_MAX", MAG_MAX),
        ("C_MAG_MIN", MAG_MIN),
    ];

    /// The counters as WGSL constants, part of every shader's prelude
    /// ([`full_source`](crate::gpu::kernel::full_source)): one definition.
    ///
    /// ```
    /// let w = lfast::gpu::buffers::counter::wgsl();
    /// assert!(w.contains("const C_CANDS: u32 = 3u;"));
    /// ```
    pub fn wgsl() -> String {
        ALL.iter().map(|(name, i)| format!("const {name}: u32 = {i}u;\n")).collect()
    }
}

/// How much the buffers were allocated for; a frame whose layout fits reuses them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Allocated {
    /// Pixels per atlas.
    pub px: u64,
    /// Words per column-packed plane.
    pub packed: u64,
    /// Keypoint slots.
    pub keypoints: u64,
    /// Windows.
    pub windows: u64,
    /// Words of local_threshold's `cell_hist`: the most SPEC 5 cells any
    /// level of at most its size can have, by
    /// [`cell_words`](super::local_threshold::cell_words).
    pub cell_words: u64,
    /// Words of the grid buffer.
    pub grid: u64,
    /// Bytes of the input buffer.
    pub input: u64,
    /// Levels (histograms, Otsu).
    pub levels: u64,
    /// 16x16 tiles of all levels (a word per tile column in `edge_bits`).
    pub tiles: u64,
}

impl Allocated {
    pub(crate) fn of(layout: &FrameLayout) -> Self {
        let (w, h) = layout.sizes[0];
        let levels = layout.n_levels() as u64;
        // Windows, cells and grid sized for the most any level can have, so a
        // smaller frame (which may have more, smaller windows) still fits.
        let max_cells = |len: u32| (len as u64).min(MAX_CELLS_PER_AXIS as u64);
        let per_level = (MAX_WINDOWS_PER_AXIS * MAX_WINDOWS_PER_AXIS) as u64;
        let sides: u64 = layout.sizes.iter().map(|&(w, h)| w as u64 + h as u64).sum();
        Self {
            px: layout.total_px_exact,
            packed: layout.total_packed as u64,
            keypoints: layout.capacity as u64,
            windows: levels * per_level,
            cell_words: layout.sizes.iter().map(|&(w, h)| max_cells(w) * max_cells(h)).sum::<u64>()
                * super::local_threshold::cell_words(w, h),
            // xs, ys, then per level a cell header, at most 2 cuts per window
            // and 2 more per axis, and a cell range per window (fewer than
            // one per cell); the order and cells before each level, and the
            // words of a cell's bins; the
            // pyramid's taps, a word per column and row of a level past the
            // first, each level's and the header padded to 4 words
            grid: sides
                + levels * 2 * MAX_WINDOWS_PER_AXIS as u64
                + levels * (4 + 2 * (2 * MAX_WINDOWS_PER_AXIS as u64 + 2) + 2 * (2 * MAX_WINDOWS_PER_AXIS as u64 + 1))
                + sides
                + levels * 10
                + 7,
            input: (w as u64 * h as u64).next_multiple_of(4),
            levels: layout.n_levels() as u64,
            tiles: layout.params.total_tiles as u64,
        }
    }

    /// True when every buffer allocated for `self` is large enough for `other`.
    pub fn holds(&self, other: &Allocated) -> bool {
        self.px >= other.px
            && self.packed >= other.packed
            && self.keypoints >= other.keypoints
            && self.windows >= other.windows
            && self.cell_words >= other.cell_words
            && self.grid >= other.grid
            && self.input >= other.input
            && self.levels >= other.levels
            && self.tiles >= other.tiles
    }
}

/// The planes only the standalone `gradient` and `nms` passes use: the
/// pipeline's `gradient_nms` keeps gx2, gy2 and S in registers, so a detector's
/// buffers go without them (12 bytes per pixel of the atlas).
#[derive(Debug)]
pub struct StagePlanes {
    /// gx2 (i32).
    pub gx: wgpu::Buffer,
    /// gy2 (i32).
    pub gy: wgpu::Buffer,
    /// S.
    pub s: wgpu::Buffer,
}

/// The named buffers of one frame size.
#[derive(Debug)]
pub struct Buffers {
    /// What lies where.
    pub layout: FrameLayout,
    /// What the buffers can hold.
    pub allocated: Allocated,
    /// `Params` (binding 0 of every pass).
    pub params: wgpu::Buffer,
    /// `MAX_LEVELS` records of 256 bytes, record l = `[l, 0, 0, 0]`, for
    /// passes that run level by level (the pyramid) through a dynamic offset.
    pub level_index: wgpu::Buffer,
    /// 8-bit gray input of level 0, four pixels per word (see shaders/luma.wgsl).
    pub input: wgpu::Buffer,
    /// The pyramid (level 0 = the input's luma), column-packed as `classes`.
    pub gray: wgpu::Buffer,
    /// Level masks (nonzero = on, a u32 per pixel of every level), read when
    /// `Params::use_mask` is 1: 16 bytes until `GpuDetector::set_mask` sets a mask.
    pub mask: wgpu::Buffer,
    /// D (SPEC 1), column-packed as `classes`.
    pub denoised: wgpu::Buffer,
    /// gx2, gy2 and S: allocated only by [`Buffers::with_stage_planes`].
    pub stage: Option<StagePlanes>,
    /// M8 = min(M, 255), column-packed as `classes`: all that the histograms,
    /// the windows and classify need of M (docs/algorithm.md, stage 6).
    ///
    /// One allocation with `smooth` (their stages never overlap; [`footprint`](super::footprint)).
    pub m: wgpu::Buffer,
    /// NMS survivors (0/1), column-packed as `classes`.
    pub nms: wgpu::Buffer,
    /// 256 bins per level.
    pub hist: wgpu::Buffer,
    /// Per level T1 = k + 1, or 0 when the level has no edges.
    pub otsu: wgpu::Buffer,
    /// Window grids: per level xs, ys, col_window, row_window; the cells; the pyramid's taps (FrameLayout::grid_data).
    pub grid: wgpu::Buffer,
    /// Per window min, max, median, V3.
    pub windows: wgpu::Buffer,
    /// Per SPEC 5 cell its 256-bin histogram of M8 (16-bit counts, two a
    /// word, up to 6.5 megapixels: [`cell_bin_words`](super::layout::cell_bin_words)),
    /// then per cell each `cells` invocation's lowest and highest non-empty
    /// bin ([`cell_words`](super::local_threshold::cell_words) words a cell).
    ///
    /// One allocation with `corners` (their stages never overlap; [`footprint`](super::footprint)).
    pub cell_hist: wgpu::Buffer,
    /// SPEC 6 classes, column-packed (four rows of a column per word, see
    /// [`FrameLayout::packed_offsets`](super::FrameLayout::packed_offsets)).
    ///
    /// One allocation with `cand` (their stages never overlap; [`footprint`](super::footprint)).
    pub classes: wgpu::Buffer,
    /// Classes after rules 1 and 2 (only NONE, WEAK, STRONG remain) as bits:
    /// one word per column of every tile, bit r active and bit 16 + r STRONG
    /// for row 16 ty + r ([`pack_ruled`](super::layout::pack_ruled)).
    pub ruled: wgpu::Buffer,
    /// The quad walks holding an active pixel, appended by rules in no
    /// particular order ([`walk_entry`](super::layout::walk_entry)), counted in
    /// `counters[WALKS]`: hysteresis runs over them only (its `walk_args`
    /// pads the list to a whole workgroup: 4 entries per tile and 64 more).
    pub walks: wgpu::Buffer,
    /// Union-find labels (hysteresis).
    ///
    /// One allocation with `edge_list`, `resp` and `ranks` (their stages never overlap; [`footprint`](super::footprint)).
    pub labels: wgpu::Buffer,
    /// Per root, one bit (bit i % 32 of word i / 32 for atlas index i): set
    /// if its component holds a STRONG pixel (hysteresis).
    pub flags: wgpu::Buffer,
    /// E: 255 = edge, column-packed as `classes`.
    pub edges: wgpu::Buffer,
    /// E as bits for the L-FAST test: per column of each tile, its 16 rows
    /// and 8 more either side (shaders/lfast.wgsl; common.wgsl `tile_word`).
    pub edge_bits: wgpu::Buffer,
    /// Per 16x16 tile of every level (the tile list), non-zero iff a
    /// descriptor reads a pixel of it: written by select for each final
    /// keypoint, read by blur, which smooths the marked tiles only.
    pub blur_tiles: wgpu::Buffer,
    /// L-FAST candidates (0/1), column-packed as `classes`.
    ///
    /// One allocation with `classes` (their stages never overlap; [`footprint`](super::footprint)).
    pub cand: wgpu::Buffer,
    /// The atlas index of every L-FAST candidate, unordered
    /// (shaders/cand_list.wgsl); as many slots as pixels.
    ///
    /// One allocation with `sel_members` (their stages never overlap; [`footprint`](super::footprint)).
    pub cand_list: wgpu::Buffer,
    /// The atlas index of every edge pixel the L-FAST test takes, unordered
    /// (shaders/lfast.wgsl `windows`); as many slots as pixels.
    ///
    /// One allocation with `labels`, `resp` and `ranks` (their stages never overlap; [`footprint`](super::footprint)).
    pub edge_list: wgpu::Buffer,
    /// Harris response of candidates (f32 bits).
    ///
    /// One allocation with `labels`, `edge_list` and `ranks` (their stages never overlap; [`footprint`](super::footprint)).
    pub resp: wgpu::Buffer,
    /// Corners surviving corner NMS, unordered ([`GpuKeypoint`]s).
    ///
    /// One allocation with `cell_hist` (their stages never overlap; [`footprint`](super::footprint)).
    pub corners: wgpu::Buffer,
    /// Per corner its select record: order key, taken, level, `y << 16 | x`.
    ///
    /// One allocation with `labels`, `edge_list` and `resp` (their stages never overlap; [`footprint`](super::footprint)).
    pub ranks: wgpu::Buffer,
    /// select's bucket counts, prefix sums and cursors ([`SELECT_BUCKET_WORDS`]).
    pub sel_buckets: wgpu::Buffer,
    /// select's corner records grouped by bucket (4 words per keypoint slot).
    ///
    /// One allocation with `cand_list` (their stages never overlap; [`footprint`](super::footprint)).
    pub sel_members: wgpu::Buffer,
    /// The final keypoints in SPEC 9 order.
    pub keypoints: wgpu::Buffer,
    /// 32-byte descriptors, `descriptors[i]` for `keypoints[i]`.
    pub descriptors: wgpu::Buffer,
    /// See [`counter`].
    pub counters: wgpu::Buffer,
    /// See [`indirect`].
    pub indirect: wgpu::Buffer,
    /// 7x7-blurred levels (SPEC 11), column-packed as `classes`.
    ///
    /// One allocation with `m` (their stages never overlap; [`footprint`](super::footprint)).
    pub smooth: wgpu::Buffer,
    /// Rotated patterns: per bin 256 pairs, each one word of four i8 (x1, y1,
    /// x2, y2, lowest byte first).
    pub patterns: wgpu::Buffer,
    /// Orientation sector boundaries: per bin `(cos, sin)` in Q8 as two i32
    /// (`AngleBins::bounds`), `max(1, orientation_bins)` pairs.
    pub angle_bounds: wgpu::Buffer,
}

impl Buffers {
    /// Allocates everything the pipeline uses for `width x height` under `cfg`
    /// (valid). Fails, naming the limit, when a buffer would exceed the device's limits.
    pub fn new(device: &wgpu::Device, cfg: &Config, width: u32, height: u32) -> Result<Self> {
        Self::build(device, cfg, width, height, false)
    }

    /// [`new`](Self::new) plus the [`StagePlanes`], for running the staged
    /// `gradient` and `nms` passes (the per-stage references of the tests).
    pub fn with_stage_planes(device: &wgpu::Device, cfg: &Config, width: u32, height: u32) -> Result<Self> {
        Self::build(device, cfg, width, height, true)
    }

    /// The [`StagePlanes`], or an error naming the constructor that allocates them.
    pub fn stage_planes(&self) -> Result<&StagePlanes> {
        self.stage.as_ref().ok_or_else(|| Error::Gpu {
            reason: "the gx, gy and S planes are not allocated: the staged gradient and nms passes need \
                     Buffers::with_stage_planes"
                .into(),
        })
    }

    fn build(device: &wgpu::Device, cfg: &Config, width: u32, height: u32, stage_planes: bool) -> Result<Self> {
        let limits = device.limits();
        let mut layout = FrameLayout::new(cfg, width, height);
        layout.params.tile_row = limits.max_compute_workgroups_per_dimension.clamp(1, TILE_ROW);
        let allocated = Allocated::of(&layout);
        if layout.total_px_exact > u32::MAX as u64 {
            return Err(Error::GpuLimits {
                reason: format!(
                    "a {width}x{height} frame's {} levels hold {} pixels, more than the 2^32 a GPU atlas addresses",
                    layout.n_levels(),
                    layout.total_px_exact
                ),
            });
        }
        let sizes = Sizes::of(cfg, &layout, &allocated);
        let report = sizes.report(width, height);
        report.fits(&limits)?;
        let [gx, gy, gz] = layout.pixel_groups();
        let lim = limits.max_compute_workgroups_per_dimension;
        // keypoint passes are dispatched indirectly with ceil(count / 64) groups
        let gk = layout.capacity.div_ceil(64);
        // luma (a word per invocation) and the pyramid (four columns of a
        // tile per invocation) dispatch over one level; level 0 is the largest
        let [px_, py_, _] = layout.packed_level_groups(0);
        let [cx, cy, _] = layout.level_quad_groups(0);
        let (lx, ly) = (px_.max(cx), py_.max(cy));
        // local_threshold's cells, in rows of tile_row
        let [kx, ky, _] = layout.cell_groups();
        if gx > lim || gy > lim || gz > lim || gk > lim || lx > lim || ly > lim || ky > lim {
            return Err(Error::GpuLimits {
                reason: format!(
                    "a {width}x{height} frame needs {lx}x{ly} workgroups per level-0 pass, {gx}x{gy}x{gz} per \
                     all-level pass, {kx}x{ky} for the local thresholds' cells and up to {gk} per keypoint pass; \
                     the device allows {lim} per dimension"
                ),
            });
        }
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
        let buf = |label: &str, bytes: u64| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: rounded(bytes),
                usage: storage,
                mapped_at_creation: false,
            })
        };
        let init =
            |label: &str, contents: &[u8], usage: wgpu::BufferUsages| init_buffer(device, label, contents, usage);
        let px = |label: &str| buf(label, sizes.atlas);
        let packed = |label: &str| buf(label, sizes.packed);
        // Buffers whose stages never overlap within a frame share one
        // allocation (footprint::Sizes::allocations lists them): M8
        // (gradient_nms to classify) and the smoothed levels (blur to orb); the union-find labels
        // (hysteresis), the L-FAST edge list (lfast), the responses (response
        // to corner NMS, which reads the candidates' words only, the words
        // the response pass writes) and select's records;
        // the candidate list (lfast to snap) and select's buckets' members;
        // the classes (classify to rules) and the L-FAST candidates (lfast to
        // corner NMS; cleared right before lfast, Pass::clear_before); the cells' histograms
        // (local_threshold, which zeroes them before the frame) and the corners
        // (corner NMS to select).
        let m_smooth = packed(SHARED_PACKED);
        let shared = buf(SHARED_ATLAS, sizes.lists());
        let list = buf(SHARED_LIST, sizes.lists());
        let cand = packed(SHARED_CLASSES);
        let hist_corners = buf(SHARED_CORNERS, sizes.shared_corners());
        let mut level_index = vec![0u8; MAX_LEVELS * DYNAMIC_STRIDE as usize];
        for l in 0..MAX_LEVELS {
            level_index[l * DYNAMIC_STRIDE as usize..][..4].copy_from_slice(&(l as u32).to_le_bytes());
        }
        let mut grid = layout.grid_data.clone();
        grid.resize((sizes.grid / 4) as usize, 0);
        let patterns = pattern_words(cfg);
        debug_assert_eq!(patterns.len(), pattern_words_len(cfg));
        let angle_bounds: Vec<i32> =
            AngleBins::new(cfg.orientation_bins.max(1)).bounds().iter().flat_map(|&(x, y)| [x, y]).collect();
        let mut indirect_init = [0u32; (indirect::SIZE / 4) as usize];
        indirect_init[1] = 1;
        indirect_init[2] = 1;
        indirect_init[5] = 1;
        indirect_init[6] = 1;
        indirect_init[8] = 4;
        indirect_init[14] = 1;
        indirect_init[18] = 1;
        indirect_init[22] = 1;
        indirect_init[25] = 1;
        indirect_init[26] = 1;
        let this = Self {
            params: init(
                "params",
                bytemuck::bytes_of(&layout.params),
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            ),
            level_index: init("level_index", &level_index, wgpu::BufferUsages::UNIFORM),
            input: buf("input", sizes.input),
            gray: packed("gray"),
            // allocated by the first mask (GpuDetector::set_mask)
            mask: buf("mask", MASK_UNSET),
            denoised: packed("denoised"),
            stage: stage_planes.then(|| StagePlanes { gx: px("gx"), gy: px("gy"), s: px("s") }),
            m: m_smooth.clone(),
            nms: packed("nms"),
            hist: buf("hist", sizes.hist),
            otsu: buf("otsu", sizes.otsu),
            grid: init("grid", bytemuck::cast_slice(&grid), storage),
            windows: buf("windows", sizes.windows),
            cell_hist: hist_corners.clone(),
            classes: cand.clone(),
            ruled: buf("ruled", sizes.tiles),
            walks: buf("walks", sizes.walks),
            labels: shared.clone(),
            flags: buf("flags", sizes.bits),
            edges: packed("edges"),
            edge_bits: buf("edge_bits", sizes.tiles),
            blur_tiles: buf("blur_tiles", sizes.tile_words),
            cand,
            cand_list: list.clone(),
            edge_list: shared.clone(),
            resp: shared.clone(),
            corners: hist_corners,
            ranks: shared.clone(),
            sel_buckets: buf("sel_buckets", SELECT_BUCKET_WORDS * 4),
            sel_members: list,
            keypoints: buf("keypoints", sizes.keypoints),
            descriptors: buf("descriptors", sizes.descriptors),
            counters: buf("counters", counter::LEN as u64 * 4),
            indirect: init("indirect", bytemuck::cast_slice(&indirect_init), storage | wgpu::BufferUsages::INDIRECT),
            smooth: m_smooth,
            patterns: init("patterns", bytemuck::cast_slice(&patterns), storage),
            angle_bounds: init("angle_bounds", bytemuck::cast_slice(&angle_bounds), storage),
            allocated,
            layout,
        };
        Ok(this)
    }

    /// Lays a `width x height` frame out in the existing buffers when they are
    /// large enough (writing the new `Params` and grid through `queue`), and
    /// returns false, changing nothing, when they are not.
    pub fn relayout(&mut self, queue: &wgpu::Queue, cfg: &Config, width: u32, height: u32) -> bool {
        let mut layout = FrameLayout::new(cfg, width, height);
        layout.params.tile_row = self.layout.params.tile_row;
        if !self.allocated.holds(&Allocated::of(&layout)) || layout.pixel_groups()[1] > layout.params.tile_row {
            return false;
        }
        // A mask belongs to its frame size: the new size starts without one.
        let p = layout.params;
        queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&p));
        if !layout.grid_data.is_empty() {
            queue.write_buffer(&self.grid, 0, bytemuck::cast_slice(&layout.grid_data));
        }
        self.layout = layout;
        true
    }

    /// Allocates the mask plane for the current layout when it is smaller
    /// (it is 16 bytes until the first mask: frames without one never pay its 4
    /// bytes per pixel of every level). True when it was allocated: bind
    /// groups made before hold the old buffer and must be made anew.
    pub fn allocate_mask(&mut self, device: &wgpu::Device) -> bool {
        let bytes = rounded(self.layout.total_px as u64 * 4);
        if self.mask.size() >= bytes {
            return false;
        }
        self.mask = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("mask"),
            size: bytes,
            usage: self.mask.usage(),
            mapped_at_creation: false,
        });
        true
    }

    /// Width and height of level 0.
    pub fn size(&self) -> (u32, u32) {
        self.layout.sizes[0]
    }
}

/// The length of [`pattern_words`] without building the tables: the one
/// table of 256 pairs, or per bin 256 pairs of one word and 256 of two.
pub(crate) fn pattern_words_len(cfg: &Config) -> usize {
    let pairs = Pattern::orb().pairs.len();
    if cfg.orientation_bins == 0 { pairs } else { 3 * pairs * cfg.orientation_bins as usize }
}

/// The rotated pattern tables as i32 words: bin-major, 256 pairs of 4.
/// With `orientation_bins = 0` the one unrotated table (the shader rotates).
/// With bins, the tables in 1/16 px follow (`RotatedPatterns::fine`, read
/// by orb.wgsl `fine_word`): bin-major, two words a pair.
fn pattern_words(cfg: &Config) -> Vec<u32> {
    if cfg.orientation_bins == 0 {
        return Pattern::orb().pairs.iter().map(|p| u32::from_le_bytes(p.map(|c| c as u8))).collect();
    }
    let r = RotatedPatterns::new(Pattern::orb(), cfg.orientation_bins);
    // one word per pair: x1, y1, x2, y2 as its bytes, lowest first
    let coarse = r.tables.iter().flatten().map(|p| u32::from_le_bytes(p.map(|c| c as u8)));
    // two words per pair: x | y << 16 for each point, i16 each
    let point = |x: i16, y: i16| (x as u16 as u32) | (y as u16 as u32) << 16;
    let fine = r.fine.iter().flatten().flat_map(|p| [point(p[0], p[1]), point(p[2], p[3])]);
    coarse.chain(fine).collect()
}
