// Prepended to every stage shader (see src/gpu/kernel.rs). Mirrors
// `Params` in src/gpu/layout.rs field for field. After it comes the slots of
// the `counters` buffer, C_CORNERS, C_KEYPOINTS, ... (counter::wgsl in
// src/gpu/buffers.rs).
//
// Every per-pixel buffer is an atlas: level l occupies
// [levels[l].z, levels[l].z + w*h) in row-major order, one u32 per pixel.

const MAX_LEVELS: u32 = 32u;
// Side of the square tiles of per-pixel passes (TILE in src/gpu/layout.rs).
const TILE: u32 = 16u;

struct Params {
    // w, h, pixel offset of the level in the atlas, index of its first window
    levels: array<vec4<u32>, 32>,
    // windows along x and y, offset of the level's grid in `grid`, a | (b << 16)
    grids: array<vec4<u32>, 32>,
    // scale s^l (x = y), 31 * s^l, 0, 0
    scales: array<vec4<f32>, 32>,
    // per-level quotas of n_features, four per vec4
    quotas: array<vec4<u32>, 8>,
    // per level: index of its first 16x16 tile in the tile list, tiles along x,
    // along y, word offset of the level in a column-packed plane (pk_word)
    tiles: array<vec4<u32>, 32>,
    n_levels: u32,
    delta_num: u32,
    delta_den: u32,
    alpha_pct: u32,
    mode: u32,          // 0 = Paper, 1 = Branch
    support: u32,
    straight_tol: u32,
    border: u32,
    nms_radius: u32,
    n_features: u32,    // 0 = no cap
    use_mask: u32,
    capacity: u32,      // keypoint slots
    orientation_bins: u32,
    total_px: u32,
    max_w: u32,
    max_h: u32,
    total_tiles: u32,
    tile_row: u32,      // workgroups per row of the tile list (the device's limit)
    cells: u32,         // offset in `grid` of the SPEC 5 cells (FrameLayout::grid_data)
    snap_radius: u32,   // corners move to the Harris maximum within this radius (snap.wgsl)
    reject_edges: u32,  // 1: a response not above 0 does not survive corner NMS (corner_nms.wgsl)
    taps: u32,          // offset in `grid` of the pyramid's taps (FrameLayout::grid_data)
}

@group(0) @binding(0) var<uniform> P: Params;

fn lw(l: u32) -> u32 { return P.levels[l].x; }
fn lh(l: u32) -> u32 { return P.levels[l].y; }
fn loff(l: u32) -> u32 { return P.levels[l].z; }

// Atlas index of (x, y) at level l, coordinates clamped into the level
// (SPEC's replicate border).
fn clamped(l: u32, x: i32, y: i32) -> u32 {
    let c = clamped_xy(l, x, y);
    return loff(l) + c.y * lw(l) + c.x;
}

// (x, y) clamped into level l.
fn clamped_xy(l: u32, x: i32, y: i32) -> vec2<u32> {
    return vec2<u32>(u32(clamp(x, 0, i32(lw(l)) - 1)), u32(clamp(y, 0, i32(lh(l)) - 1)));
}

fn quota(l: u32) -> u32 { return P.quotas[l / 4u][l % 4u]; }

// n / d (d > 0) without an integer division, which a SIMD software rasteriser
// does lane by lane: the f32 quotient, then one exact correction either way.
// Exact whenever the f32 quotient is within one of n / d: for n < 2^24 (n
// exact in f32), and for the larger n of the pyramid's taps (n < 2^29 with
// d > n / 2^23; tests/gpu_levels.rs, and every tap of 69 random and extreme
// sizes checked against the integer form).
fn udiv(n: u32, d: u32) -> u32 {
    var q = u32(f32(n) / f32(d));
    q = select(q, q - 1u, q * d > n);
    return select(q, q + 1u, (q + 1u) * d <= n);
}

// The level holding tile t (`tiles`) or atlas index t (else): the last level
// whose first tile (P.tiles[l].x) or first pixel (P.levels[l].z) is <= t.
// Selects with constant indices for the usual levels, a loop only past 8 (a
// loop costs a SIMD software rasteriser its masks); `tiles` is a constant at
// every call, so the select between the fields folds away.
fn level_holding(t: u32, tiles: bool) -> u32 {
    var l = 0u;
    l = select(l, 1u, 1u < P.n_levels && t >= select(P.levels[1].z, P.tiles[1].x, tiles));
    l = select(l, 2u, 2u < P.n_levels && t >= select(P.levels[2].z, P.tiles[2].x, tiles));
    l = select(l, 3u, 3u < P.n_levels && t >= select(P.levels[3].z, P.tiles[3].x, tiles));
    l = select(l, 4u, 4u < P.n_levels && t >= select(P.levels[4].z, P.tiles[4].x, tiles));
    l = select(l, 5u, 5u < P.n_levels && t >= select(P.levels[5].z, P.tiles[5].x, tiles));
    l = select(l, 6u, 6u < P.n_levels && t >= select(P.levels[6].z, P.tiles[6].x, tiles));
    l = select(l, 7u, 7u < P.n_levels && t >= select(P.levels[7].z, P.tiles[7].x, tiles));
    for (var k = 8u; k < P.n_levels; k++) {
        if (t >= select(P.levels[k].z, P.tiles[k].x, tiles)) { l = k; }
    }
    return l;
}

// The indirect dispatch args (x, y, 1) over a list of n entries, 64 per
// workgroup (list_index), x <= 65535.
fn list_args(n: u32) -> vec3<u32> {
    let groups = (n + 63u) / 64u;
    return vec3<u32>(min(groups, 65535u), (groups + 65534u) / 65535u, 1u);
}

// Per-pixel passes are dispatched over the list of the 16x16 tiles of every
// level (FrameLayout::pixel_groups), so no workgroup falls outside its level.
// (x0, y0, level) of tile t's top-left pixel; NO_TILE (outside every level)
// for t past the last tile (the padding workgroups of the last row).
const NO_TILE: u32 = 0xffffffffu;
fn tile_origin(t: u32) -> vec3<u32> {
    if (t >= P.total_tiles) { return vec3<u32>(NO_TILE, NO_TILE, 0u); }
    let l = level_holding(t, true);
    // (r % tx, r / tx): r < 2^24 (udiv)
    let r = t - P.tiles[l].x;
    let tx = P.tiles[l].y;
    let q = udiv(r, tx);
    return vec3<u32>((r - q * tx) * TILE, q * TILE, l);
}

// (x, y, level) of this invocation of a 16x16 workgroup, one per tile;
// NO_TILE, uniform per workgroup, past the last tile.
fn tile_pixel(wg: vec3<u32>, li: vec3<u32>) -> vec3<u32> {
    let o = tile_origin(wg.x + wg.y * P.tile_row);
    if (o.x == NO_TILE) { return o; }
    return vec3<u32>(o.x + li.x, o.y + li.y, o.z);
}

// tile_origin of tile k (< COLUMN_TILES) of a column pass's workgroup wg (and
// of blur's horizontal pass, which takes 4x4 blocks of the tile).
fn workgroup_tile(wg: vec3<u32>, k: u32) -> vec3<u32> {
    return tile_origin((wg.x + wg.y * P.tile_row) * COLUMN_TILES + k);
}

// Column passes (workgroup_size(64, 1, 1), FrameLayout::column_groups): a
// workgroup serves COLUMN_TILES consecutive tiles of the list, one invocation
// per column of a tile, and each invocation walks its column's TILE rows with
// its stencil in registers, so a pixel is read once per row of the stencil
// instead of once per tap. Returns (x, top row, level) of this invocation, or
// NO_TILE past the last tile.
const COLUMN_TILES: u32 = 4u;
fn tile_column(wg: vec3<u32>, li: vec3<u32>) -> vec3<u32> {
    let o = workgroup_tile(wg, li.x / TILE);
    if (o.x == NO_TILE) { return o; }
    return vec3<u32>(o.x + li.x % TILE, o.y, o.z);
}

// The rows [y0, end) of this invocation's column in a column pass, as
// (x, y0, end, level); no rows (end = y0) past the last tile or the level's
// right edge.
fn column_span(wg: vec3<u32>, li: vec3<u32>) -> vec4<u32> {
    let id = tile_column(wg, li);
    if (id.x == NO_TILE || id.x >= lw(id.z)) { return vec4<u32>(0u); }
    return vec4<u32>(id.x, id.y, min(id.y + TILE, lh(id.z)), id.z);
}

// Quad passes (workgroup_size(64, 1, 1), FrameLayout::quad_groups): a
// workgroup serves QUAD_TILES consecutive tiles of the list, four invocations
// per tile, and each invocation walks four neighbouring columns x0 .. x0 + 3
// (x0 a multiple of 4) down the tile's rows. A 3-column stencil then reads
// six columns' words per word of rows for four outputs, where a column walk
// reads three for one: storage reads are what a SIMD software rasteriser
// pays for (docs/gpu.md). Returns (x0, top row, end row, level); no rows
// (end = top) past the last tile or the level's right edge.
const QUAD_TILES: u32 = 16u;
// The index in the tile list of this invocation's tile in a quad pass.
fn quad_tile(wg: vec3<u32>, li: vec3<u32>) -> u32 { return (wg.x + wg.y * P.tile_row) * QUAD_TILES + li.x / 4u; }
fn quad_span(wg: vec3<u32>, li: vec3<u32>) -> vec4<u32> {
    let o = tile_origin(quad_tile(wg, li));
    if (o.x == NO_TILE) { return vec4<u32>(0u); }
    let x0 = o.x + 4u * (li.x % 4u);
    if (x0 >= lw(o.z)) { return vec4<u32>(0u); }
    return vec4<u32>(x0, o.y, min(o.y + TILE, lh(o.z)), o.z);
}

// A quad walk as an entry of the walk list (gpu::layout::walk_entry):
// level, x0 / 4, top row / 16. rules.wgsl appends the walks that hold an
// active pixel; hysteresis.wgsl runs over them.
fn walk_entry(l: u32, x0: u32, y0: u32) -> u32 { return l | ((x0 >> 2u) << 5u) | ((y0 / TILE) << 17u); }

// The span of walk entry e, as quad_span: (x0, top row, end row, level).
fn walk_span(e: u32) -> vec4<u32> {
    let l = e & 31u;
    let y0 = (e >> 17u) * TILE;
    return vec4<u32>(((e >> 5u) & 4095u) * 4u, y0, min(y0 + TILE, lh(l)), l);
}

// Six neighbouring columns' words, bytes or indices in a quad walk: columns
// x0 - 1 .. x0 + 2 in `a`, x0 + 3 and x0 + 4 in `b`.
struct Six {
    a: vec4<u32>,
    b: vec2<u32>,
}

// Columns x0 - 1 .. x0 + 4 clamped into a level of width w.
fn six_columns(x0: u32, w: u32) -> Six {
    let wm = w - 1u;
    return Six(
        min(vec4<u32>(max(x0, 1u) - 1u, x0, x0 + 1u, x0 + 2u), vec4<u32>(wm)),
        min(vec2<u32>(x0 + 3u, x0 + 4u), vec2<u32>(wm)),
    );
}

// Which of columns x0 - 1 .. x0 + 4 lie in a level of width w: all ones for
// those that do, 0 for the others (a mask for their words, or a flag).
fn six_inside(x0: u32, w: u32) -> Six {
    let c = vec4<u32>(x0) + vec4<u32>(0u, 1u, 2u, 3u);
    return Six(
        select(vec4<u32>(0u), vec4<u32>(0xffffffffu), (c >= vec4<u32>(1u)) & (c <= vec4<u32>(w))),
        select(vec2<u32>(0u), vec2<u32>(0xffffffffu), vec2<u32>(x0 + 3u, x0 + 4u) < vec2<u32>(w)),
    );
}

// Columns x0 + k - 1, x0 + k, x0 + k + 1 of a Six: output column k's
// neighbourhood (k constant at every call, so the switch folds away).
fn tri(s: Six, k: u32) -> vec3<u32> {
    switch k {
        case 0u: { return s.a.xyz; }
        case 1u: { return s.a.yzw; }
        case 2u: { return vec3<u32>(s.a.zw, s.b.x); }
        default: { return vec3<u32>(s.a.w, s.b); }
    }
}

// Row y's bytes of six columns' words (pk_byte of each).
fn six_bytes(s: Six, y: u32) -> Six {
    let sh = (y & 3u) * 8u;
    return Six((s.a >> vec4<u32>(sh)) & vec4<u32>(0xffu), (s.b >> vec2<u32>(sh)) & vec2<u32>(0xffu));
}

// `yes ? a : b` for each column.
fn six_select(b: Six, a: Six, yes: bool) -> Six {
    return Six(select(b.a, a.a, yes), select(b.b, a.b, yes));
}

// Column-packed 8-bit planes (`classes`, `ruled`; FrameLayout::packed_offsets,
// gpu::layout::pack_level): word (y / 4) * pk_pitch(l) + x of level l holds rows
// 4 (y / 4) .. + 4 of column x, row y in bits 8 (y % 4) .. + 8. A column walk
// reads or writes a word per four rows (a tile's 16 rows are 4 whole words, so
// no two invocations write one word). Rows past the level's last are 0.
fn pk_word(l: u32, x: u32, y: u32) -> u32 { return P.tiles[l].w + (y >> 2u) * pk_pitch(l) + x; }
// Words from a row of words of level l to the next: its width rounded up to
// a multiple of 4 (gpu::layout::packed_pitch), so that a quad walk's four
// columns x0 .. x0 + 3 are one aligned vec4 (level offsets are multiples of
// 4 too). The words past the width hold no pixel: a pass may store anything
// there, and walks clamp the columns they read into the level.
fn pk_pitch(l: u32) -> u32 { return (lw(l) + 3u) & ~3u; }
fn pk_byte(word: u32, y: u32) -> u32 { return (word >> ((y & 3u) * 8u)) & 0xffu; }
// Row y's value v in its place of a word being built (OR the four rows together).
fn pk_place(v: u32, y: u32) -> u32 { return v << ((y & 3u) * 8u); }
// pk_byte of the words of four neighbouring columns, at row y.
fn pk_byte4(words: vec4<u32>, y: u32) -> vec4<u32> { return (words >> vec4<u32>((y & 3u) * 8u)) & vec4<u32>(0xffu); }
// All four rows of a word: row 4k + r in component r.
fn pk_rows(word: u32) -> vec4<u32> { return (vec4<u32>(word) >> vec4<u32>(0u, 8u, 16u, 24u)) & vec4<u32>(0xffu); }
// Bit r = component r: four rows' tests (e.g. on pk_rows) as row bits.
fn bits4(b: vec4<bool>) -> u32 { return u32(b.x) | (u32(b.y) << 1u) | (u32(b.z) << 2u) | (u32(b.w) << 3u); }
// The word of four rows whose bytes are bits 0..3 of q (0 or 1 each; times
// 255 gives 0 / 255 bytes).
fn pk_from_bits(q: u32) -> u32 { return (q & 1u) | ((q & 2u) << 7u) | ((q & 4u) << 14u) | ((q & 8u) << 21u); }
// Whether row y completes the word being built by a walk that ends before row
// `end`: the last of its four rows, or the walk's last row.
fn pk_complete(y: u32, end: u32) -> bool { return (y & 3u) == 3u || y + 1u == end; }

// Tile-column planes (lfast's `edge_bits`, rules' `ruled`): one word per
// column of every tile, in tile-list order (FrameLayout::tile_range,
// gpu::layout::tile_word): the word of column x of tile row ty of level l.
fn tile_word(l: u32, x: u32, ty: u32) -> u32 {
    return (P.tiles[l].x + ty * P.tiles[l].y + x / TILE) * TILE + x % TILE;
}

// (x, y, level) of atlas index i (a pixel of some level): the level by
// level_holding, the row by udiv (exact: the row is below 2^14 and w > (w h) / 2^23).
fn atlas_pixel(i: u32) -> vec3<u32> {
    let l = level_holding(i, false);
    let r = i - loff(l);
    let y = udiv(r, lw(l));
    return vec3<u32>(r - y * lw(l), y, l);
}

// Entry k of an indirect dispatch over a list, 64 per workgroup, workgroups
// (x, y) as written by the list's args (x <= 65535).
fn list_index(wg: vec3<u32>, li: vec3<u32>) -> u32 {
    return (wg.y * 65535u + wg.x) * 64u + li.x;
}

// list_index with the workgroups' runs of 64 entries interleaved (n =
// num_workgroups): the first half of the workgroups takes the even runs, the
// second half the odd ones (a bijection; which workgroup takes which run
// changes no output). Mesa's llvmpipe hands each of its threads one
// contiguous share of a dispatch's workgroups, and a list in position order
// costs more in some parts than in others: corner NMS, which only reads and
// appends, 2.06-2.16 -> 1.74-1.79 ms per KITTI frame on two threads. Passes
// that write next to their neighbours' words (hysteresis' labels, response's
// `resp`) got slower interleaved (the two cores then share those cache
// lines), and lfast, snap and orientation did not change: they keep list_index.
fn list_index_spread(wg: vec3<u32>, li: vec3<u32>, n: vec3<u32>) -> u32 {
    let g = wg.y * 65535u + wg.x;
    let h = (n.x * n.y + 1u) / 2u;
    return select(2u * (g - h) + 1u, 2u * g, g < h) * 64u + li.x;
}

// One keypoint: GpuKeypoint in src/gpu/buffers.rs, 12 words (48 bytes).
struct Kp {
    x: f32,
    y: f32,
    size: f32,
    angle: f32,
    response: f32,
    level: u32,
    px: u32,
    py: u32,
    m10: i32,
    m01: i32,
    bin: u32,
    // snap.wgsl's sub-pixel offset: x in bits 0-7, y in bits 8-15, i8 each (GpuKeypoint::sub).
    sub: u32,
}

// SPEC 2-3 numerics of gradient.wgsl, nms.wgsl and gradient_nms.wgsl (one
// definition for the three), mirroring src/cpu/gradient.rs and src/cpu/nms.rs.

// floor(sqrt(v)) for every u32: the f32 square root (however the device
// rounds it, within far less than 1 of sqrt(v)) then one exact integer
// correction either way; r <= 65535 keeps r * r and (r + 1)^2 in u32. A
// bit-by-bit loop (the earlier form) ran 10-15 divergent iterations per pixel.
fn isqrt(v: u32) -> u32 {
    var r = min(u32(sqrt(f32(v))), 65535u);
    if (r * r > v) {
        r -= 1u;
    } else if (r < 65535u && (r + 1u) * (r + 1u) <= v) {
        r += 1u;
    }
    return r;
}

// `magnitude` in src/cpu/gradient.rs.
fn magnitude(sq: u32) -> u32 { return isqrt(sq) >> 1u; }

// The direction sector of (gx2, gy2) as booleans: horizontal, vertical (never
// both), and for the diagonals whether the signs are equal. tan(22.5°) ≈
// 13573/32768 and tan(67.5°) ≈ 79109/32768; |g| <= 510 keeps the products far
// below 2^32. (`sector_code` in src/cpu/fused.rs.)
fn sector_tests(gx2: i32, gy2: i32) -> vec3<bool> {
    let ax = u32(abs(gx2));
    let ay = u32(abs(gy2));
    return vec3<bool>(ay * 32768u < 13573u * ax, ay * 32768u > 79109u * ax, (gx2 > 0) == (gy2 > 0));
}

// Neighbour offsets (first.xy, second.xy) of the direction sector of (gx2, gy2).
fn sector(gx2: i32, gy2: i32) -> vec4<i32> {
    let t = sector_tests(gx2, gy2);
    if (t.x) {
        return vec4(-1, 0, 1, 0);
    } else if (t.y) {
        return vec4(0, -1, 0, 1);
    } else if (t.z) {
        return vec4(-1, -1, 1, 1);
    }
    return vec4(1, -1, -1, 1);
}

// The values of the two `sector` neighbours (first, second) of the centre of a
// 3x3 window given as rows up, mid, down (columns x-1, x, x+1): selects on
// the sector tests, no indexed array (a private array indexed by a computed
// value is read lane by lane on a SIMD software rasteriser).
fn sector_pair(gx2: i32, gy2: i32, up: vec3<u32>, mid: vec3<u32>, down: vec3<u32>) -> vec2<u32> {
    let t = sector_tests(gx2, gy2);
    let diag = select(vec2<u32>(up.z, down.x), vec2<u32>(up.x, down.z), t.z);
    let vh = select(vec2<u32>(up.y, down.y), vec2<u32>(mid.x, mid.z), t.x);
    return select(diag, vh, t.x || t.y);
}
