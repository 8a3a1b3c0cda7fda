// SPEC 6: the double adaptive dual threshold (paper Algorithm 2), as exact
// rational comparisons. Mirrors src/cpu/classify.rs.
// m (M8 = min(M, 255)), nms, otsu, windows, grid -> classes (NONE 0, WEAK_WEAK 1, WEAK 2,
// WEAK_STRONG 3, STRONG 4; column-packed, common.wgsl pk_word). A quad pass, all levels in one dispatch (over
// the tile list).
// Tests: tests/gpu_edges_front.rs (this pass alone == src/cpu/classify.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).
//
// Races: no atomics. Each invocation stores only the `classes` words of its
// own four columns of its tile (quad_span), with the padding words past the
// level's width that its quad covers: a tile's 16 rows are 4 whole words
// of a column (common.wgsl pk_word), and quads do not overlap, so no two
// invocations write one word.

@group(0) @binding(1) var<storage, read> m: array<vec4<u32>>;
@group(0) @binding(2) var<storage, read> nms: array<vec4<u32>>;
@group(0) @binding(3) var<storage, read> otsu: array<u32>;
@group(0) @binding(4) var<storage, read> windows: array<u32>;
@group(0) @binding(5) var<storage, read> grid: array<u32>;
@group(0) @binding(6) var<storage, read_write> classes: array<vec4<u32>>;

const NONE: u32 = 0u;
const WEAK_WEAK: u32 = 1u;
const WEAK: u32 = 2u;
const WEAK_STRONG: u32 = 3u;
const STRONG: u32 = 4u;

// `class_of` in src/cpu/classify.rs: t1 = T1 = k + 1, v3 the window's V3,
// alpha_pct alpha in hundredths (< 100). M <= 360 and V3 <= 765 keep every
// product far below 2^32. Given M8 = min(M, 255) for M, it answers as for M
// (docs/algorithm.md, stage 6): Otsu's k <= 254 makes t1 <= 255, so M >= t1
// and 2M >= t1 do not change; M >= 255 already makes M above TL1; and
// 300 * 255 >= 100 * 765 makes it above TL2.
fn class_of(mv: u32, t1: u32, v3: u32, alpha_pct: u32) -> u32 {
    let above_t1 = mv >= t1;
    let above_t2 = 2u * mv >= t1;
    let above_tl1 = mv >= 255u || 300u * mv >= (100u + alpha_pct) * v3;
    let above_tl2 = 300u * mv >= (100u - alpha_pct) * v3;
    // selects, not an if-else chain of returns (a SIMD software rasteriser runs
    // every branch anyway, and pays its mask bookkeeping)
    let weak = select(select(NONE, WEAK_WEAK, above_t2 || above_tl2), WEAK, above_t2 && above_tl2);
    return select(select(weak, WEAK_STRONG, above_t1 || above_tl1), STRONG, above_t1 && above_tl1);
}

// V3 of window (i, j) of the level whose first window is win0 (nx windows along x).
fn v3_of(win0: u32, nx: u32, i: u32, j: u32) -> u32 {
    return windows[(win0 + j * nx + i) * 4u + 3u];
}

// The class of row yy in its place in the word: `flags` and `mags` hold its
// NMS flag and M8, `v3` its window's V3; NONE where the level has no edges
// (t1 = 0) or the pixel is not an NMS survivor.
fn class_row(flags: u32, mags: u32, yy: u32, t1: u32, v3: u32) -> u32 {
    let c = class_of(pk_byte(mags, yy), t1, v3, P.alpha_pct);
    return pk_place(select(NONE, c, t1 != 0u && pk_byte(flags, yy) != 0u), yy);
}

// A quad pass (common.wgsl quad_span): four columns per invocation, so the
// row windows' word (column-packed in `grid`: four rows a word, monotone) and
// the walk's first and last row windows are read once for four columns
// (classify 2.8 -> 2.3 ms per KITTI frame on lavapipe). Each column's window
// column is looked up once, and V3 of its first and last rows' windows; a
// row between them in a third window (small levels, where a window is
// shorter than a tile) is a "hard" row, looked up in a `while` loop over the
// four columns' hard rows that runs only when some lane has one. The walk's
// words are a loop (see median.wgsl); nothing is stored past the walk's end
// or the level's right edge.
@compute @workgroup_size(64, 1, 1)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let span = quad_span(wg, li);
    if (span.y == span.z) { return; }
    let l = span.w;
    let x0 = span.x;
    let w = lw(l);
    // otsu[l] == 0: the level has no edges (t1 = None on the CPU).
    let t1 = otsu[l];
    // WindowGrid::v3_at: the grid holds xs (nx), ys (ny), col_window (w), row_window (packed).
    let g = P.grids[l];
    let cw = g.z + g.x + g.y;
    let xs = min(vec4<u32>(x0) + vec4<u32>(0u, 1u, 2u, 3u), vec4<u32>(w - 1u));
    let i = vec4<u32>(grid[cw + xs.x], grid[cw + xs.y], grid[cw + xs.z], grid[cw + xs.w]);
    let rows = cw + w;
    let win0 = P.levels[l].w;
    let last = span.z - 1u;
    let jt = pk_byte(grid[rows + (span.y >> 2u)], span.y);
    let jb = pk_byte(grid[rows + (last >> 2u)], last);
    let k = Walk(l, x0, rows, t1, win0, g.x, i, jt, jb, v3s(win0, g.x, i, jt), v3s(win0, g.x, i, jb));
    for (var y = span.y; y < span.z; y += 4u) {
        step(k, y);
    }
}

// V3 of windows (i.x .. i.w, j) of the level whose first window is win0.
fn v3s(win0: u32, nx: u32, i: vec4<u32>, j: u32) -> vec4<u32> {
    return vec4<u32>(v3_of(win0, nx, i.x, j), v3_of(win0, nx, i.y, j), v3_of(win0, nx, i.z, j), v3_of(win0, nx, i.w, j));
}

// What every word of a walk needs: level, first column, the row
// windows' offset in `grid`, Otsu's t1, the level's first window, windows
// along x, the four columns' windows, the first and last rows' row windows
// and the columns' V3 in them.
struct Walk {
    l: u32,
    x0: u32,
    rows: u32,
    t1: u32,
    win0: u32,
    nx: u32,
    i: vec4<u32>,
    jt: u32,
    jb: u32,
    vt: vec4<u32>,
    vb: vec4<u32>,
}

// Column k's word of `classes` of rows y .. y + 3 (flags, mags: its words
// of `nms` and `m`; js its rows' row windows), the hard rows left as NONE.
fn class_word(k: Walk, c: u32, flags: u32, mags: u32, js: vec4<u32>, y: u32) -> u32 {
    let v3 = select(vec4<u32>(k.vt[c]), vec4<u32>(k.vb[c]), js == vec4<u32>(k.jb));
    return class_row(flags, mags, y, k.t1, v3.x) | class_row(flags, mags, y + 1u, k.t1, v3.y)
        | class_row(flags, mags, y + 2u, k.t1, v3.z) | class_row(flags, mags, y + 3u, k.t1, v3.w);
}

// The four words of `classes` of rows y .. y + 3 of the walk.
fn step(k: Walk, y: u32) {
    // `classes`, `nms`, `m` and the row windows are column-packed: a word
    // of each per four rows (rows past the level's last are 0 in `nms`: NONE)
    // the four columns' words, one aligned load each (common.wgsl pk_pitch;
    // a column past the level's right edge is padding, classified and
    // stored like the others and never read as a pixel): 1.77-1.88 ->
    // 1.42-1.51 ms per KITTI frame on lavapipe, which loads and stores
    // lane by lane, a vec4 at about the cost of one word
    let at = pk_word(k.l, k.x0, y) >> 2u;
    let flags = nms[at];
    let mags = m[at];
    let jw = grid[k.rows + (y >> 2u)];
    let js = pk_rows(jw);
    var words = vec4<u32>(
        class_word(k, 0u, flags.x, mags.x, js, y),
        class_word(k, 1u, flags.y, mags.y, js, y),
        class_word(k, 2u, flags.z, mags.z, js, y),
        class_word(k, 3u, flags.w, mags.w, js, y),
    );
    // hard rows of the four columns: bit 4c + r for row y + r of column c
    let third = bits4(js != vec4<u32>(k.jt) & js != vec4<u32>(k.jb));
    let busy = bits4(flags != vec4<u32>(0u));
    var hard = 0u;
    for (var c = 0u; c < 4u; c++) {
        hard |= (third & bits4(pk_rows(flags[c]) != vec4<u32>(0u))) << (4u * c);
    }
    hard = select(0u, hard, busy != 0u);
    while (hard != 0u) {
        let b = firstTrailingBit(hard);
        hard &= hard - 1u;
        let c = b >> 2u;
        let yy = y + (b & 3u);
        let v = v3_of(k.win0, k.nx, k.i[c], pk_byte(jw, yy));
        words[c] = (words[c] & ~pk_place(0xffu, yy)) | class_row(flags[c], mags[c], yy, k.t1, v);
    }
    classes[at] = words;
}
