//! Where everything of one frame size lives: level sizes and atlas offsets,
//! the SPEC 5 window grids, the keypoint capacity, and the `Params` uniform
//! that carries it all to the shaders (mirrors shaders/common.wgsl).

use crate::config::{Config, DELTA_DEN, Mode};
use crate::spec::{WindowLayout, cell_cuts, level_quotas};
use bytemuck::{Pod, Zeroable};

/// Most pyramid levels the shaders handle (as `Config::validate` allows).
pub const MAX_LEVELS: usize = 32;
pub use crate::spec::windows::MAX_WINDOWS_PER_AXIS;
/// Most workgroups per row of the tile list (WebGPU's guaranteed per-dimension limit).
pub const TILE_ROW: u32 = 65535;
/// Side of the 2D workgroups of per-pixel passes (`TILE` in shaders/common.wgsl).
pub const TILE: u32 = 16;
/// Tiles per workgroup of a column pass (`COLUMN_TILES` in shaders/common.wgsl).
pub const COLUMN_TILES: u32 = 4;
/// Tiles per workgroup of a quad pass, four columns per invocation
/// (`QUAD_TILES` in shaders/common.wgsl).
pub const QUAD_TILES: u32 = 16;

/// The uniform every pass binds at 0. Field for field as in shaders/common.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct Params {
    /// Per level: width, height, atlas offset, index of its first window.
    pub levels: [[u32; 4]; MAX_LEVELS],
    /// Per level: windows along x, along y, grid offset, `a | b << 16`.
    pub grids: [[u32; 4]; MAX_LEVELS],
    /// Per level: `s^l`, `31 s^l`, 0, 0.
    pub scales: [[f32; 4]; MAX_LEVELS],
    /// Per-level quotas of `n_features`, four per row.
    pub quotas: [[u32; 4]; MAX_LEVELS / 4],
    /// Per level: first tile in the tile list, tiles along x, along y, and
    /// the level's word offset in a column-packed plane ([`FrameLayout::packed_offsets`]).
    pub tiles: [[u32; 4]; MAX_LEVELS],
    /// Number of levels.
    pub n_levels: u32,
    /// SPEC 1 delta numerator.
    pub delta_num: u32,
    /// SPEC 1 delta denominator.
    pub delta_den: u32,
    /// SPEC 5 alpha in hundredths.
    pub alpha_pct: u32,
    /// 0 = Paper, 1 = Branch.
    pub mode: u32,
    /// SPEC 8 support.
    pub support: u32,
    /// SPEC 8 straight_tol.
    pub straight_tol: u32,
    /// SPEC 8 border.
    pub border: u32,
    /// SPEC 9 corner NMS radius.
    pub nms_radius: u32,
    /// SPEC 9 cap, 0 = none.
    pub n_features: u32,
    /// 1 when the mask atlas is to be read.
    pub use_mask: u32,
    /// Keypoint slots.
    pub capacity: u32,
    /// Orientation bins, 0 = continuous.
    pub orientation_bins: u32,
    /// Pixels in the atlas.
    pub total_px: u32,
    /// Width of level 0.
    pub max_w: u32,
    /// Height of level 0.
    pub max_h: u32,
    /// 16x16 tiles of all levels.
    pub total_tiles: u32,
    /// Workgroups per row of the tile list: the device's per-dimension limit
    /// (at most [`TILE_ROW`]); set by `Buffers::new`.
    pub tile_row: u32,
    /// Word offset in the grid buffer of the SPEC 5 cells (see [`FrameLayout::grid_data`]).
    pub cells: u32,
    /// Corners move to the Harris maximum within this radius (`Config::snap`, 0 = off).
    pub snap_radius: u32,
    /// 1: a candidate whose Harris response is not above 0 does not survive
    /// corner NMS (`Config::reject_edges`).
    pub reject_edges: u32,
    /// Word offset in the grid buffer of the pyramid's taps (see [`FrameLayout::grid_data`]).
    pub taps: u32,
    /// Pads the struct to WGSL's 16-byte multiple.
    pub _pad: [u32; 2],
}

/// Appends the pyramid's taps to the grid buffer `g` and returns where they
/// start (`Params::taps`, a multiple of 4): a header of a word per level
/// (padded to a multiple of 4; level l >= 1 holds the offset of its table),
/// then per level l >= 1 the taps of its columns `0 .. packed_pitch(w_l)`
/// (those past the width repeat the last column's) and of its rows `0 ..
/// h_l`, padded to a multiple of 4, each `s | w << 16` for
/// [`cpu::pyramid::tap`](crate::cpu::pyramid::tap)'s source index `s` and
/// Q11 weight `w` (`s` < [`MAX_SIDE`](crate::image::MAX_SIDE), `w` <= 2048).
/// shaders/pyramid.wgsl reads a walk's four columns, and four rows, a load.
pub fn push_pyramid_taps(g: &mut Vec<u32>, sizes: &[(u32, u32)]) -> u32 {
    use crate::cpu::pyramid::tap;
    let pad = |g: &mut Vec<u32>| g.resize(g.len().next_multiple_of(4), 0);
    let word = |(s, w): (u32, i32)| s | (w as u32) << 16;
    pad(g);
    let at = g.len();
    g.resize(at + sizes.len().next_multiple_of(4), 0);
    for l in 1..sizes.len() {
        let ((sw, sh), (dw, dh)) = (sizes[l - 1], sizes[l]);
        g[at + l] = g.len() as u32;
        g.extend((0..packed_pitch(dw)).map(|x| word(tap(x.min(dw - 1), sw, dw))));
        g.extend((0..dh).map(|y| word(tap(y, sh, dh))));
        pad(g);
    }
    at as u32
}

/// The layout of one frame size under one config.
#[derive(Clone, Debug)]
pub struct FrameLayout {
    /// Level sizes (level 0 = the input).
    pub sizes: Vec<(u32, u32)>,
    /// Atlas offset of each level, in pixels.
    pub offsets: Vec<u32>,
    /// Pixels of all levels (saturated at `u32::MAX`; see [`total_px_exact`](Self::total_px_exact)).
    pub total_px: u32,
    /// Pixels of all levels, not saturated: the GPU path refuses layouts over `u32::MAX`.
    pub total_px_exact: u64,
    /// Word offset of each level in a *column-packed* 8-bit plane (`classes`,
    /// `edges`): word `(y / 4) * pitch + x` of level l holds rows `4 (y / 4)
    /// ..+ 4` of column x, row y in bits `8 (y % 4)..`, `pitch` =
    /// [`packed_pitch`]`(w)`; see [`pack_level`]. Each offset is a multiple of 4.
    pub packed_offsets: Vec<u32>,
    /// Words of a column-packed plane over all levels (`sum pitch * ceil(h / 4)`).
    pub total_packed: u32,
    /// Per level window grid.
    pub grids: Vec<WindowLayout>,
    /// Index of each level's first window in the window-statistics buffer.
    pub window_offsets: Vec<u32>,
    /// Windows of all levels.
    pub total_windows: u32,
    /// The grid buffer: per level `xs, ys, col_window, row_window` (the last
    /// column-packed, [`pack_level`] of a one-column plane: four rows a word;
    /// a window index is below [`MAX_WINDOWS_PER_AXIS`]); then, from
    /// `params.cells`, per level the header `[offset of cx, cells along x,
    /// offset of cy, cells along y]`, the levels in the order of
    /// local_threshold's `cells` dispatch ([`halves_order`]), the cells
    /// before each of them in that order (`n_levels + 1` words: 0, ...,
    /// [`total_cells`](Self::total_cells)), the words of a cell's bins
    /// ([`cell_bin_words`]), and each level's cell cuts `cx`,
    /// `cy` ([`cell_cuts`]), each followed by the cell range of each of its
    /// windows ([`covering`]); then, from `params.taps`, the pyramid's taps
    /// ([`push_pyramid_taps`]).
    pub grid_data: Vec<u32>,
    /// The cells of all levels: local_threshold's `cells` workgroups, one
    /// per cell.
    pub total_cells: u32,
    /// Keypoint slots: an upper bound on corners surviving corner NMS, so
    /// the list can never overflow (survivors are >= r+1 apart, see docs/algorithm.md).
    pub capacity: u32,
    /// The uniform.
    pub params: Params,
}

impl FrameLayout {
    /// The layout of a `width x height` frame; `cfg` must be valid.
    pub fn new(cfg: &Config, width: u32, height: u32) -> Self {
        let sizes = cfg.level_sizes(width, height);
        let mut offsets = Vec::with_capacity(sizes.len());
        let mut packed_offsets = Vec::with_capacity(sizes.len());
        let mut total: u64 = 0;
        let mut total_packed: u64 = 0;
        for &(w, h) in &sizes {
            offsets.push(total.min(u32::MAX as u64) as u32);
            packed_offsets.push(total_packed.min(u32::MAX as u64) as u32);
            total += w as u64 * h as u64;
            total_packed += packed_pitch(w) as u64 * h.div_ceil(4) as u64;
        }
        let mut grids = Vec::new();
        let mut window_offsets = Vec::new();
        let mut grid_data = Vec::new();
        let mut p = Params::zeroed();
        let mut total_windows = 0u32;
        let (b, r) = (cfg.border, cfg.nms_radius);
        let mut capacity: u64 = 0;
        for (l, &(w, h)) in sizes.iter().enumerate() {
            let g = WindowLayout::new(w, h);
            let (a, bb) = (g.a, g.b);
            p.levels[l] = [w, h, offsets[l], total_windows];
            let (tx, ty) = (w.div_ceil(TILE), h.div_ceil(TILE));
            p.tiles[l] = [p.total_tiles, tx, ty, packed_offsets[l]];
            p.total_tiles = p.total_tiles.saturating_add(tx.saturating_mul(ty));
            debug_assert!(g.xs.len() <= MAX_WINDOWS_PER_AXIS && g.ys.len() <= MAX_WINDOWS_PER_AXIS);
            p.grids[l] = [g.xs.len() as u32, g.ys.len() as u32, grid_data.len() as u32, a | (bb << 16)];
            let s = cfg.level_scale(l as u32);
            p.scales[l] = [s as f32, (31.0 * s) as f32, 0.0, 0.0];
            window_offsets.push(total_windows);
            total_windows += (g.xs.len() * g.ys.len()) as u32;
            grid_data.extend_from_slice(&g.xs);
            grid_data.extend_from_slice(&g.ys);
            grid_data.extend_from_slice(&g.col_window);
            // row_window four rows a word (a one-column plane): classify reads
            // a word per four rows
            grid_data.extend(
                g.row_window
                    .chunks(4)
                    .map(|c| c.iter().enumerate().fold(0u32, |word, (r, &j)| word | ((j as u8 as u32) << (8 * r)))),
            );
            grids.push(g);
            if w > 2 * b && h > 2 * b {
                capacity += ((w - 2 * b) as u64).div_ceil(r as u64 + 1) * ((h - 2 * b) as u64).div_ceil(r as u64 + 1);
            }
        }
        let capacity = capacity.clamp(1, u32::MAX as u64 / 64) as u32;
        // The cells: per level a header (offset of the x cuts, cells along x,
        // offset of the y cuts, cells along y), then each level's cuts, each
        // axis's followed by the range of cells that make up each of its
        // windows (`covering`).
        p.cells = grid_data.len() as u32;
        let cells_data = 4 * grids.len();
        grid_data.resize(grid_data.len() + cells_data, 0);
        // after the headers, the levels in the order of local_threshold's
        // `cells` dispatch, then the cells before each (filled below)
        let px: Vec<u64> = sizes.iter().map(|&(w, h)| w as u64 * h as u64).collect();
        let order = halves_order(&px);
        grid_data.extend(&order);
        let before = grid_data.len();
        grid_data.resize(before + order.len() + 2, 0);
        grid_data[before + order.len() + 1] = cell_bin_words(width, height);
        let mut level_cells = Vec::with_capacity(sizes.len());
        for (l, (g, &(w, h))) in grids.iter().zip(&sizes).enumerate() {
            let (cx, cy) = (cell_cuts(&g.xs, g.a, w), cell_cuts(&g.ys, g.b, h));
            let (ncx, ncy) = (cx.len() as u32 - 1, cy.len() as u32 - 1);
            level_cells.push(ncx * ncy);
            let hdr = p.cells as usize + 4 * l;
            grid_data[hdr] = grid_data.len() as u32;
            grid_data[hdr + 1] = ncx;
            grid_data.extend_from_slice(&cx);
            grid_data.extend(g.xs.iter().map(|&o| covering(&cx, o, g.a)));
            grid_data[hdr + 2] = grid_data.len() as u32;
            grid_data[hdr + 3] = ncy;
            grid_data.extend_from_slice(&cy);
            grid_data.extend(g.ys.iter().map(|&o| covering(&cy, o, g.b)));
        }
        let mut total_cells = 0u32;
        for (z, &l) in order.iter().enumerate() {
            grid_data[before + z] = total_cells;
            total_cells += level_cells[l as usize];
        }
        grid_data[before + order.len()] = total_cells;
        p.taps = push_pyramid_taps(&mut grid_data, &sizes);
        for (l, q) in level_quotas(cfg.n_features, &sizes).into_iter().enumerate() {
            p.quotas[l / 4][l % 4] = q;
        }
        p.n_levels = sizes.len() as u32;
        p.delta_num = cfg.delta_num();
        p.delta_den = DELTA_DEN;
        p.alpha_pct = cfg.alpha_pct;
        p.mode = match cfg.mode {
            Mode::Paper => 0,
            Mode::Branch => 1,
        };
        p.support = cfg.support;
        p.straight_tol = cfg.straight_tol;
        p.border = cfg.border;
        p.nms_radius = cfg.nms_radius;
        p.n_features = cfg.n_features;
        p.capacity = capacity;
        p.orientation_bins = cfg.orientation_bins;
        p.snap_radius = cfg.snap();
        p.reject_edges = cfg.reject_edges as u32;
        p.total_px = total.min(u32::MAX as u64) as u32;
        p.tile_row = TILE_ROW;
        p.max_w = width;
        p.max_h = height;
        Self {
            sizes,
            offsets,
            total_px: total.min(u32::MAX as u64) as u32,
            total_px_exact: total,
            packed_offsets,
            total_packed: total_packed.min(u32::MAX as u64) as u32,
            grids,
            window_offsets,
            total_windows,
            grid_data,
            total_cells,
            capacity,
            params: p,
        }
    }

    /// Number of levels.
    pub fn n_levels(&self) -> u32 {
        self.sizes.len() as u32
    }

    /// Workgroups of a per-pixel pass over all levels at once: the list of
    /// every level's 16x16 tiles, in rows of [`TILE_ROW`] workgroups
    /// (shaders/common.wgsl `tile_pixel` maps a workgroup to its tile).
    pub fn pixel_groups(&self) -> [u32; 3] {
        self.in_rows(self.params.total_tiles)
    }

    /// Workgroups of a column pass over all levels at once: [`COLUMN_TILES`]
    /// tiles of the tile list per 64-invocation workgroup (shaders/common.wgsl
    /// `tile_column`), in rows of at most `tile_row` workgroups.
    pub fn column_groups(&self) -> [u32; 3] {
        self.in_rows(self.params.total_tiles.div_ceil(COLUMN_TILES))
    }

    /// Workgroups of a quad pass over all levels at once: [`QUAD_TILES`] tiles
    /// of the tile list per 64-invocation workgroup, four columns per
    /// invocation (shaders/common.wgsl `quad_span`), in rows of at most
    /// `tile_row` workgroups.
    pub fn quad_groups(&self) -> [u32; 3] {
        self.in_rows(self.params.total_tiles.div_ceil(QUAD_TILES))
    }

    /// Workgroups of local_threshold's `cells`: one per cell of every level
    /// ([`total_cells`](Self::total_cells)), in rows of `tile_row`.
    pub fn cell_groups(&self) -> [u32; 3] {
        self.in_rows(self.total_cells)
    }

    /// `n` workgroups in rows of at most `tile_row` (the device's per-dimension limit).
    fn in_rows(&self, n: u32) -> [u32; 3] {
        let row = self.params.tile_row.max(1);
        if n <= row { [n, 1, 1] } else { [row, n.div_ceil(row), 1] }
    }

    /// Workgroups of a 16x16 pass over the packed words of level `l` alone: one
    /// invocation per word, four rows of a column (shaders/luma.wgsl).
    pub fn packed_level_groups(&self, l: usize) -> [u32; 3] {
        let (w, h) = self.sizes[l];
        [w.div_ceil(TILE), h.div_ceil(4).div_ceil(TILE), 1]
    }

    /// Workgroups of a 16x16 pass over the packed words of level `l` alone,
    /// four neighbouring words (columns) per invocation (shaders/luma.wgsl
    /// `from_bytes`).
    pub fn quad_level_words(&self, l: usize) -> [u32; 3] {
        let (w, h) = self.sizes[l];
        [w.div_ceil(4 * TILE), h.div_ceil(4).div_ceil(TILE), 1]
    }

    /// Workgroups of a quad pass over level `l` alone: four columns per
    /// invocation of the 64-invocation workgroup, [`TILE`] rows (shaders/pyramid.wgsl).
    pub fn level_quad_groups(&self, l: usize) -> [u32; 3] {
        let (w, h) = self.sizes[l];
        [w.div_ceil(4 * 64), h.div_ceil(TILE), 1]
    }

    /// Range of level `l` in a per-pixel atlas.
    pub fn level_range(&self, l: usize) -> std::ops::Range<usize> {
        let (w, h) = self.sizes[l];
        let o = self.offsets[l] as usize;
        o..o + (w * h) as usize
    }

    /// Range of level `l` in a tile-column plane (`ruled`, `edge_bits`: one
    /// word per column of every tile, tiles in tile-list order), in words.
    pub fn tile_range(&self, l: usize) -> std::ops::Range<usize> {
        let t = self.params.tiles[l];
        let o = t[0] as usize * TILE as usize;
        o..o + (t[1] * t[2] * TILE) as usize
    }

    /// Range of level `l` in a column-packed plane, in words.
    pub fn packed_range(&self, l: usize) -> std::ops::Range<usize> {
        let (w, h) = self.sizes[l];
        let o = self.packed_offsets[l] as usize;
        o..o + (packed_pitch(w) * h.div_ceil(4)) as usize
    }
}

/// Words of a cell's bins in local_threshold's `cell_hist` for a frame
/// whose level 0 is `w x h`: 128 (two 16-bit counts a word) when no cell of
/// any level can hold more than 65535 pixels, else 256. A cell lies between
/// consecutive cuts, which are at most a window stride `max(1, a/2)` apart
/// (the origins are, and each window edge is an origin plus `a`), and level
/// 0 has the largest strides; a smaller frame never needs more.
///
/// ```
/// use lfast::gpu::layout::cell_bin_words;
/// assert_eq!(cell_bin_words(1241, 376), 128); // cells of at most 124 x 37
/// assert_eq!(cell_bin_words(3840, 2160), 256); // 384 x 216 > 65535
/// ```
pub fn cell_bin_words(w: u32, h: u32) -> u32 {
    let stride = |len: u32| ((len / 5).max(1) / 2).max(1) as u64;
    if stride(w) * stride(h) <= u16::MAX as u64 { 128 } else { 256 }
}

/// The cells (between consecutive `cuts`, sorted, as made by
/// [`cell_cuts`]) that make up the window `[origin, origin + size)`, as
/// `first | end << 16`: local_threshold's `stats` sums their counts. The
/// cuts hold every window edge, so the window is exactly cells `first ..
/// end`.
///
/// ```
/// use lfast::gpu::layout::covering;
/// // KITTI width 1241: windows of 248 at 0, 124, ..., 992, 993
/// let xs = lfast::spec::window_origins(1241, 248);
/// let cuts = lfast::spec::cell_cuts(&xs, 248, 1241);
/// assert_eq!(&cuts[..4], &[0, 124, 248, 372]);
/// assert_eq!(covering(&cuts, 124, 248), 1 | (3 << 16)); // cells 124..248, 248..372
/// assert_eq!(&cuts[8..], &[992, 993, 1116, 1240, 1241]);
/// assert_eq!(covering(&cuts, 992, 248), 8 | (11 << 16)); // 992..993, 993..1116, 1116..1240
/// ```
pub fn covering(cuts: &[u32], origin: u32, size: u32) -> u32 {
    let at = |c: u32| cuts.partition_point(|&x| x < c) as u32;
    at(origin) | (at(origin + size) << 16)
}

/// The levels in an order whose first half (`ceil(n / 2)` levels) and second
/// half hold about as many pixels (`px[l]`, level l's): the largest first,
/// each to the half with fewer pixels while it has room. Mesa's llvmpipe
/// splits a dispatch's workgroups into one contiguous share per thread, and
/// shaders/local_threshold.wgsl's `cells` takes the levels' cells in this
/// order: in level order the first of two threads had levels 0-3, 80% of the
/// pixels, and this way most levels' windows stay with one thread. 5.00-5.59
/// -> 4.32-4.69 ms per KITTI frame on two threads (`gpu_bench`, five
/// alternated rounds).
///
/// ```
/// use lfast::gpu::layout::halves_order;
/// // a KITTI frame's 8 levels (1241x376, scale 1.2): 32%, 22%, 16%, ... of the pixels
/// let px = [466_616, 323_642, 224_982, 156_524, 108_238, 75_349, 52_416, 36_330];
/// let order = halves_order(&px);
/// assert_eq!(order, [0, 3, 5, 7, 1, 2, 4, 6]);
/// let first: u64 = order[..4].iter().map(|&l| px[l as usize]).sum();
/// assert_eq!(first, 734_819); // of 1_444_097: 50.9%
/// assert_eq!(halves_order(&[5]), [0]);
/// assert_eq!(halves_order(&[1, 9, 4]), [0, 1, 2]); // 1 + 9 against 4: the first half holds two
/// ```
pub fn halves_order(px: &[u64]) -> Vec<u32> {
    let n = px.len();
    let room = [n.div_ceil(2), n / 2];
    let mut by_size: Vec<usize> = (0..n).collect();
    by_size.sort_by_key(|&l| (std::cmp::Reverse(px[l]), l));
    let mut halves: [Vec<u32>; 2] = [Vec::new(), Vec::new()];
    let mut sum = [0u64; 2];
    for l in by_size {
        let h = if halves[0].len() == room[0] {
            1
        } else if halves[1].len() == room[1] || sum[0] <= sum[1] {
            0
        } else {
            1
        };
        halves[h].push(l as u32);
        sum[h] += px[l];
    }
    halves.iter_mut().for_each(|v| v.sort_unstable());
    halves.concat()
}

/// Words from one row of words of a column-packed plane to the next: the
/// level's width rounded up to a multiple of 4, so that the four columns
/// `x0 .. x0 + 3` of a quad walk (`x0` a multiple of 4) are one aligned
/// `vec4<u32>` (shaders/common.wgsl `pk_pitch`). The words past the width
/// hold no pixel: a pass may store anything there, and none reads them as a
/// pixel (walks clamp their columns into the level).
///
/// ```
/// assert_eq!(lfast::gpu::layout::packed_pitch(1241), 1244);
/// assert_eq!(lfast::gpu::layout::packed_pitch(1032), 1032);
/// ```
pub fn packed_pitch(w: u32) -> u32 {
    w.next_multiple_of(4)
}

/// A `w x h` level of 8-bit values (row-major, `w * h` of them) as the
/// words of a column-packed plane ([`FrameLayout::packed_offsets`]): four rows
/// of a column per word, so a column walk reads a word per four rows; rows of
/// words [`packed_pitch`] apart. Rows past `h` in the last word, and the
/// words past `w`, are 0.
///
/// ```
/// use lfast::gpu::layout::{pack_level, unpack_level};
/// // 2 x 5: column 0 holds 1, 3, 5, 7, 9 and column 1 holds 2, 4, 6, 8, 10
/// let v: Vec<u8> = (1..=10).collect();
/// let words = pack_level(2, 5, &v);
/// assert_eq!(words, vec![0x0705_0301, 0x0806_0402, 0, 0, 0x09, 0x0a, 0, 0]);
/// assert_eq!(unpack_level(2, 5, &words), v);
/// ```
pub fn pack_level(w: u32, h: u32, v: &[u8]) -> Vec<u32> {
    let pitch = packed_pitch(w) as usize;
    let (w, h) = (w as usize, h as usize);
    let mut words = vec![0u32; pitch * h.div_ceil(4)];
    for (y, row) in v.chunks_exact(w.max(1)).take(h).enumerate() {
        for (x, &b) in row.iter().enumerate() {
            words[(y / 4) * pitch + x] |= (b as u32) << (8 * (y % 4));
        }
    }
    words
}

/// Index, within its level's range of a tile-column plane (`ruled`,
/// `edge_bits`; [`FrameLayout::tile_range`]), of the word of column x for row
/// y, for a level `tx` tiles wide: common.wgsl `tile_word`.
pub fn tile_word(tx: u32, x: u32, y: u32) -> usize {
    (((y / TILE) * tx + x / TILE) * TILE + x % TILE) as usize
}

/// SPEC 7's ruled classes of a `w x h` level (NONE 0, WEAK 2, STRONG 4, in
/// row-major order) as the GPU's `ruled` plane holds them
/// (shaders/rules.wgsl): per 16x16 tile in row-major order, one word per
/// column, bit r = row 16 ty + r is active (WEAK or STRONG), bit 16 + r is
/// STRONG; columns and rows past the level clear.
///
/// ```
/// use lfast::gpu::layout::{pack_ruled, unpack_ruled};
/// // 17 x 17: four tiles; WEAK at (0, 1), STRONG at (16, 16)
/// let mut v = vec![0u8; 17 * 17];
/// v[17] = 2;
/// v[16 * 17 + 16] = 4;
/// let words = pack_ruled(17, 17, &v);
/// assert_eq!(words.len(), 4 * 16);
/// assert_eq!(words[0], 1 << 1); // tile (0, 0), column 0: row 1 active
/// assert_eq!(words[3 * 16], 1 | (1 << 16)); // tile (1, 1), column 16: row 16 active and STRONG
/// assert_eq!(words.iter().filter(|&&w| w != 0).count(), 2);
/// assert_eq!(unpack_ruled(17, 17, &words), v);
/// ```
pub fn pack_ruled(w: u32, h: u32, v: &[u8]) -> Vec<u32> {
    let (tx, ty) = (w.div_ceil(TILE), h.div_ceil(TILE));
    let mut words = vec![0u32; (tx * ty * TILE) as usize];
    for (i, &c) in v.iter().enumerate().take((w * h) as usize) {
        let (x, y) = (i as u32 % w, i as u32 / w);
        let r = y % TILE;
        words[tile_word(tx, x, y)] |= (u32::from(c != 0) << r) | (u32::from(c == 4) << (16 + r));
    }
    words
}

/// An edge map of a `w x h` level (255 = edge, row-major) as hysteresis'
/// `final_edges` leaves it in `edge_bits` for Paper mode's L-FAST test
/// (shaders/hysteresis.wgsl, shaders/lfast.wgsl `paper`): per 16x16 tile in
/// row-major order, one word per column, bit r = row 16 ty + r is an edge;
/// columns and rows past the level clear.
///
/// ```
/// use lfast::gpu::layout::pack_edge_tiles;
/// // 17 x 17: four tiles; edges at (1, 2) and (16, 16)
/// let mut e = vec![0u8; 17 * 17];
/// e[2 * 17 + 1] = 255;
/// e[16 * 17 + 16] = 255;
/// let words = pack_edge_tiles(17, 17, &e);
/// assert_eq!(words.len(), 4 * 16);
/// assert_eq!(words[1], 1 << 2); // tile 0, column 1
/// assert_eq!(words[3 * 16], 1); // tile 3, its column 0 (x = 16), row 16
/// assert_eq!(words.iter().filter(|&&w| w != 0).count(), 2);
/// ```
pub fn pack_edge_tiles(w: u32, h: u32, v: &[u8]) -> Vec<u32> {
    let (tx, ty) = (w.div_ceil(TILE), h.div_ceil(TILE));
    let mut words = vec![0u32; (tx * ty * TILE) as usize];
    for (i, &e) in v.iter().enumerate().take((w * h) as usize) {
        let (x, y) = (i as u32 % w, i as u32 / w);
        words[tile_word(tx, x, y)] |= u32::from(e == 255) << (y % TILE);
    }
    words
}

/// A quad walk (four columns x0 .. x0 + 3 from row y0 = 16 ty, up to 16 rows)
/// of level `l` as an entry of the walk list: `l | (x0 / 4) << 5 | (y0 / 16)
/// << 17` (common.wgsl `walk_entry`; sides are at most 16384, levels 32).
/// `rules` appends the walks that hold an active pixel and hysteresis runs
/// over them only.
///
/// ```
/// use lfast::gpu::layout::walk_entry;
/// assert_eq!(walk_entry(2, 8, 32), 2 | (2 << 5) | (2 << 17));
/// ```
pub fn walk_entry(l: u32, x0: u32, y0: u32) -> u32 {
    l | ((x0 / 4) << 5) | ((y0 / TILE) << 17)
}

/// The walk list of level `l`'s ruled classes (0 = NONE, row-major, `w * h`),
/// in raster order of the walks: every quad walk with an active pixel, as
/// `rules` appends them (in no particular order).
///
/// ```
/// use lfast::gpu::layout::{walk_entry, walk_list};
/// // 9 x 20: WEAK at (5, 17), the walk of columns 4..8 in tile row 1
/// let mut v = vec![0u8; 9 * 20];
/// v[17 * 9 + 5] = 2;
/// assert_eq!(walk_list(1, 9, 20, &v), vec![walk_entry(1, 4, 16)]);
/// ```
pub fn walk_list(l: u32, w: u32, h: u32, v: &[u8]) -> Vec<u32> {
    let mut out = Vec::new();
    for y0 in (0..h).step_by(TILE as usize) {
        for x0 in (0..w).step_by(4) {
            let active = (y0..(y0 + TILE).min(h)).any(|y| (x0..(x0 + 4).min(w)).any(|x| v[(y * w + x) as usize] != 0));
            if active {
                out.push(walk_entry(l, x0, y0));
            }
        }
    }
    out
}

/// The inverse of [`pack_ruled`]: `w * h` classes (0, 2 or 4) in row-major order.
pub fn unpack_ruled(w: u32, h: u32, words: &[u32]) -> Vec<u8> {
    let tx = w.div_ceil(TILE);
    (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let word = words[tile_word(tx, x, y)];
            let r = y % TILE;
            match ((word >> r) & 1, (word >> (16 + r)) & 1) {
                (0, _) => 0,
                (_, 0) => 2,
                _ => 4,
            }
        })
        .collect()
}

/// The inverse of [`pack_level`]: `w * h` values in row-major order.
pub fn unpack_level(w: u32, h: u32, words: &[u32]) -> Vec<u8> {
    let pitch = packed_pitch(w) as usize;
    let (w, h) = (w as usize, h as usize);
    (0..w * h).map(|i| (words[(i / w / 4) * pitch + i % w] >> (8 * (i / w % 4))) as u8).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atlas_offsets_and_capacity() {
        let cfg = Config::default();
        let l = FrameLayout::new(&cfg, 1241, 376);
        assert_eq!(l.offsets[0], 0);
        assert_eq!(l.offsets[1], 1241 * 376);
        assert_eq!(l.total_px as usize, l.sizes.iter().map(|&(w, h)| (w * h) as usize).sum::<usize>());
        // level 0 alone: ceil((1241-32)/4) * ceil((376-32)/4)
        assert!(l.capacity >= 303 * 86);
        let tiny = FrameLayout::new(&cfg, 20, 20);
        assert_eq!(tiny.capacity, 1, "no level has room for a corner; one slot is kept");
    }

    /// Reads the pyramid's taps as shaders/pyramid.wgsl does (a level's
    /// table from the header at `params.taps`, a walk's four columns and
    /// four rows a vec4 from 4-aligned offsets) and checks each against
    /// cpu::pyramid::tap; the grid buffer's allocation holds the whole data.
    #[test]
    fn the_pyramid_taps_are_the_cpus() {
        use crate::cpu::pyramid::tap;
        for (w, h, n_levels, scale_factor) in
            [(1241, 376, 8, 1.2), (37, 29, 4, 1.2), (3840, 2160, 12, 1.2), (97, 33, 3, 2.0), (5, 7, 3, 1.05)]
        {
            let cfg = Config { n_levels, scale_factor, ..Config::default() };
            let l = FrameLayout::new(&cfg, w, h);
            let g = &l.grid_data;
            let t = l.params.taps as usize;
            assert_eq!(t % 4, 0);
            assert!(crate::gpu::buffers::Allocated::of(&l).grid >= g.len() as u64, "{w}x{h}: grid bound");
            for lev in 1..l.sizes.len() {
                let ((sw, sh), (dw, dh)) = (l.sizes[lev - 1], l.sizes[lev]);
                let tc = g[t + lev] as usize;
                assert_eq!(tc % 4, 0, "{w}x{h} level {lev}");
                let rows = tc + packed_pitch(dw) as usize;
                let unpack = |v: u32| (v & 0xffff, (v >> 16) as i32);
                for x0 in (0..dw).step_by(4) {
                    let quad = &g[tc + x0 as usize..][..4];
                    for k in 0..4 {
                        assert_eq!(
                            unpack(quad[k]),
                            tap((x0 + k as u32).min(dw - 1), sw, dw),
                            "{w}x{h} level {lev} column {}",
                            x0 + k as u32
                        );
                    }
                }
                for y0 in (0..dh).step_by(4) {
                    let quad = &g[rows + y0 as usize..][..4];
                    for k in 0..4u32 {
                        if y0 + k < dh {
                            assert_eq!(
                                unpack(quad[k as usize]),
                                tap(y0 + k, sh, dh),
                                "{w}x{h} level {lev} row {}",
                                y0 + k
                            );
                        }
                    }
                }
            }
        }
    }

    /// Decodes workgroup index `t` of local_threshold's `cells` as the shader
    /// does: the last slot z of the levels' order whose first cell is <= t,
    /// then the cell's column and row in level `order[z]`.
    fn cell_of(l: &FrameLayout, t: u32) -> (u32, u32, u32) {
        let (g, n) = (&l.grid_data, l.n_levels() as usize);
        let order = l.params.cells as usize + 4 * n;
        let before = order + n;
        let z = (0..n).rfind(|&z| g[before + z] <= t).unwrap();
        let lev = g[order + z];
        let ncx = g[l.params.cells as usize + 4 * lev as usize + 1];
        let c = t - g[before + z];
        (lev, c % ncx, c / ncx)
    }

    #[test]
    fn sixteen_bit_cells_never_hold_more_than_65535_pixels() {
        let mut both = [false; 2];
        for (w, h) in
            [(1241, 376), (3840, 2160), (2560, 2560), (2600, 2600), (2570, 2570), (1, 1), (16384, 40), (29, 16384)]
        {
            let l = FrameLayout::new(&Config::default(), w, h);
            let narrow = cell_bin_words(w, h) == 128;
            both[narrow as usize] = true;
            let g = &l.grid_data;
            let mut largest = 0u64;
            for lev in 0..l.n_levels() as usize {
                let hdr = l.params.cells as usize + 4 * lev;
                let gaps =
                    |at: u32, n: u32| g[at as usize..=(at + n) as usize].windows(2).map(|c| c[1] - c[0]).max().unwrap();
                largest = largest.max(gaps(g[hdr], g[hdr + 1]) as u64 * gaps(g[hdr + 2], g[hdr + 3]) as u64);
            }
            assert!(!narrow || largest <= 65535, "{w}x{h}: a cell of {largest} pixels");
        }
        assert_eq!(both, [true, true]);
    }

    #[test]
    fn each_window_is_the_cells_its_range_names() {
        for (w, h, n_levels) in [(1241, 376, 8), (20, 20, 8), (1, 1, 1), (97, 33, 3), (3840, 2160, 12), (640, 480, 1)] {
            let cfg = Config { n_levels, ..Config::default() };
            let l = FrameLayout::new(&cfg, w, h);
            let g = &l.grid_data;
            for lev in 0..l.n_levels() as usize {
                let (lw, lh) = l.sizes[lev];
                let win = WindowLayout::new(lw, lh);
                let hdr = l.params.cells as usize + 4 * lev;
                for (axis, origins, size, len) in [(0, &win.xs, win.a, lw), (2, &win.ys, win.b, lh)] {
                    let (at, n) = (g[hdr + axis] as usize, g[hdr + axis + 1] as usize);
                    let cuts = &g[at..at + n + 1];
                    assert_eq!((cuts[0], cuts[n]), (0, len), "{w}x{h} level {lev}");
                    for (i, &o) in origins.iter().enumerate() {
                        let r = g[at + n + 1 + i];
                        let (first, end) = ((r & 0xffff) as usize, (r >> 16) as usize);
                        assert!(first < end && end <= n, "{w}x{h} level {lev} window {i}: {first}..{end} of {n}");
                        assert_eq!((cuts[first], cuts[end]), (o, o + size), "{w}x{h} level {lev} window {i}");
                    }
                }
            }
        }
    }

    #[test]
    fn the_cells_dispatch_takes_every_cell_once() {
        for (w, h, n_levels) in [(1241, 376, 8), (20, 20, 8), (1, 1, 1), (97, 33, 3), (3840, 2160, 12), (640, 480, 1)] {
            let cfg = Config { n_levels, ..Config::default() };
            let l = FrameLayout::new(&cfg, w, h);
            let mut seen = std::collections::HashSet::new();
            for t in 0..l.total_cells {
                assert!(seen.insert(cell_of(&l, t)), "{w}x{h}: workgroup {t} repeats a cell");
            }
            // every level's cells, each once
            let g = &l.grid_data;
            let all: u32 = (0..l.n_levels() as usize)
                .map(|lev| g[l.params.cells as usize + 4 * lev + 1] * g[l.params.cells as usize + 4 * lev + 3])
                .sum();
            assert_eq!(all, l.total_cells, "{w}x{h}");
            for &(lev, cx, cy) in &seen {
                let hdr = l.params.cells as usize + 4 * lev as usize;
                assert!(cx < g[hdr + 1] && cy < g[hdr + 3], "{w}x{h}: cell ({cx}, {cy}) outside level {lev}");
            }
            // in rows of tile_row: enough workgroups, and no row more than needed
            let mut small = l.clone();
            small.params.tile_row = 64;
            let [x, y, z] = small.cell_groups();
            assert!(x <= 64 && z == 1 && x * y >= l.total_cells && x * (y - 1) < l.total_cells, "{w}x{h}");
        }
    }
}
