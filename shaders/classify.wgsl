// SPEC 6: the double adaptive dual threshold (paper Algorithm 2), as exact
// rational comparisons. Mirrors src/cpu/classify.rs.
// m (M8 = min(M, 255)), nms, otsu, windows, grid -> classes (NONE 0, WEAK_WEAK 1, WEAK 2,
// WEAK_STRONG 3, STRONG 4; column-packed, common.wgsl pk_word). A column pass, all levels in one dispatch (over
// the tile list).
// Tests: tests/gpu_edges_front.rs (this pass alone == src/cpu/classify.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).

@group(0) @binding(1) var<storage, read> m: array<u32>;
@group(0) @binding(2) var<storage, read> nms: array<u32>;
@group(0) @binding(3) var<storage, read> otsu: array<u32>;
@group(0) @binding(4) var<storage, read> windows: array<u32>;
@group(0) @binding(5) var<storage, read> grid: array<u32>;
@group(0) @binding(6) var<storage, read_write> classes: array<u32>;

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
    if (above_t1 && above_tl1) {
        return STRONG;
    } else if (above_t1 || above_tl1) {
        return WEAK_STRONG;
    } else if (above_t2 && above_tl2) {
        return WEAK;
    } else if (above_t2 || above_tl2) {
        return WEAK_WEAK;
    }
    return NONE;
}

// A column pass (tile_column): the window column of x is looked up once, and
// the window rows of the walk at its ends.
@compute @workgroup_size(64, 1, 1)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let span = column_span(wg, li);
    if (span.y == span.z) { return; }
    let l = span.w;
    // otsu[l] == 0: the level has no edges (t1 = None on the CPU).
    let t1 = otsu[l];
    // WindowGrid::v3_at: the grid holds xs (nx), ys (ny), col_window (w), row_window (h).
    let g = P.grids[l];
    let i = grid[g.z + g.x + g.y + span.x];
    // row_window (monotone) of the walk's first and last rows, and their V3:
    // every row between has one of these windows when they are equal or
    // adjacent, so a pixel reads the grid only in a walk that crosses a
    // window boundary, and a window's V3 only past two windows (small levels).
    let rows = g.z + g.x + g.y + lw(l);
    let win0 = P.levels[l].w + i;
    var jt = 0u;
    var jb = 0u;
    var vt = 0u;
    var vb = 0u;
    if (t1 != 0u) {
        jt = grid[rows + span.y];
        jb = grid[rows + span.z - 1u];
        vt = windows[(win0 + jt * g.x) * 4u + 3u];
        vb = windows[(win0 + jb * g.x) * 4u + 3u];
    }
    // `classes`, `nms` and `m` are column-packed: an outer loop over the
    // words (four rows) reads a word of each and writes one, unconditionally
    // (see median.wgsl), an inner loop takes the rows
    for (var y = span.y; y < span.z; y += 4u) {
        let flags = nms[pk_word(l, span.x, y)];
        let mags = m[pk_word(l, span.x, y)];
        var word = 0u;
        for (var yy = y; yy < y + 4u; yy++) {
            // rows past the level's last are 0 in `nms`: NONE
            var c = NONE;
            if (t1 != 0u && pk_byte(flags, yy) != 0u) {
                var v3 = vt;
                if (jb != jt) {
                    let j = grid[rows + min(yy, span.z - 1u)];
                    v3 = select(vt, vb, j == jb);
                    if (j != jt && j != jb) { v3 = windows[(win0 + j * g.x) * 4u + 3u]; }
                }
                c = class_of(pk_byte(mags, yy), t1, v3, P.alpha_pct);
            }
            word |= pk_place(c, yy);
        }
        classes[pk_word(l, span.x, y)] = word;
    }
}
