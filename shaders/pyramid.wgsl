// SPEC 10: level l of the pyramid resized from level l-1 with integer
// bilinear weights in Q11 (OpenCV INTER_LINEAR). Mirrors src/cpu/pyramid.rs
// (`tap`, `resize_naive`). One dispatch per level: `level_index.x` = l,
// given by the dynamic offset of `level_index` (record l at l * 256 bytes).
// `gray` is column-packed (common.wgsl pk_word).
// Tests: tests/gpu_levels.rs (this pass alone == src/cpu/pyramid.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).
//
// Races: no atomics. Invocation (id.x, wg.y) stores only the `gray` words of
// level l's columns 4 id.x .. 4 id.x + 3 at rows 16 wg.y .. + 15 (the padding
// words past the level's width included): 4 whole words per column
// (common.wgsl pk_word), disjoint across invocations; it reads level
// l - 1 only, which this dispatch does not write, and the taps in `grid`.

const COEF_BITS: u32 = 11u;
const ONE: u32 = 2048u; // 1 << COEF_BITS

@group(0) @binding(1) var<uniform> level_index: vec4<u32>;
@group(0) @binding(2) var<storage, read_write> gray: array<u32>;
// `gray` again, four columns' words a store (common.wgsl pk_pitch; the
// padding words past the level's width included)
@group(0) @binding(3) var<storage, read_write> gray4: array<vec4<u32>>;
@group(0) @binding(4) var<storage, read> grid: array<u32>;
@group(0) @binding(5) var<storage, read> grid4: array<vec4<u32>>;

// The taps come from the grid buffer (FrameLayout::grid_data, from P.taps):
// grid[P.taps + l] is the offset of level l's table, a multiple of 4: the
// taps of its columns 0 .. pitch - 1 (padded to a multiple of 4 with the
// last column's), then those of its rows (padded as well), each the source
// index s | the Q11 weight w of the right / lower neighbour << 16, made by
// cpu::pyramid::tap, the CPU's own (`s` < 16384 = MAX_SIDE, `w` <= 2048).
// A walk loads its four columns' taps as one vec4 and four rows' at a time.
// (Computed here, a tap took two integer divisions per lane, a row's for
// every lane of the walk: the pass 2.40 -> 2.30 ms per KITTI frame on
// lavapipe with the table, 2.53 -> 2.39 with four rows' taps a load.)

// Dispatched as FrameLayout::level_quad_groups: each invocation walks 16
// rows of four neighbouring destination columns x0 .. x0 + 3 (four packed
// words each). Their horizontal taps are read once; each row's vertical
// tap once for the four; and a source row's blends are reused by the next
// destination row that reads it.
@compute @workgroup_size(64, 1, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>, @builtin(workgroup_id) wg: vec3<u32>) {
    let l = level_index.x;
    if (l == 0u || l >= P.n_levels) { return; }
    let dw = lw(l);
    let dh = lh(l);
    let x0 = 4u * id.x;
    let y0 = wg.y * TILE;
    if (x0 >= dw || y0 >= dh) { return; }
    let p = l - 1u;
    let sw = lw(p);
    let sh = lh(p);
    // the four columns' taps (a column past the level's edge takes the last's)
    let tc = grid[P.taps + l];
    let tx = grid4[(tc + x0) >> 2u];
    let sx0 = tx & vec4<u32>(0xffffu);
    let c = Columns(l, p, x0, dw, sx0, min(sx0 + vec4<u32>(1u), vec4<u32>(sw - 1u)), tx >> vec4<u32>(16u), sh, dh, min(y0 + TILE, dh), tc + pk_pitch(l));
    // the blends of source rows r0 and r1 of the previous destination row
    var b: Blends;
    b.r0 = 0xffffffffu;
    b.r1 = 0xffffffffu;
    b.cg = 0xffffffffu;
    for (var y = y0; y < c.end; y += 4u) {
        let tw = grid4[(c.rows + y) >> 2u];
        let words = row_value(&b, c, y, tw.x) | row_value(&b, c, y + 1u, tw.y) | row_value(&b, c, y + 2u, tw.z) | row_value(&b, c, y + 3u, tw.w);
        gray4[pk_word(l, x0, y) >> 2u] = words;
    }
}

// A walk's destination columns x0 .. x0 + 3 of level l (source level p):
// the level's width, their horizontal taps, the source height, the level's
// height, the walk's end row, the offset of the level's row taps in `grid`.
struct Columns {
    l: u32,
    p: u32,
    x0: u32,
    dw: u32,
    sx0: vec4<u32>,
    sx1: vec4<u32>,
    wx: vec4<u32>,
    sh: u32,
    dh: u32,
    end: u32,
    rows: u32,
}

// The horizontal blends h0, h1 of source rows r0, r1 (the previous
// destination row's) at the four columns, and the source words cw0 (columns
// sx0), cw1 (sx1) of word row cg.
struct Blends {
    r0: u32,
    r1: u32,
    h0: vec4<u32>,
    h1: vec4<u32>,
    cg: u32,
    cw0: vec4<u32>,
    cw1: vec4<u32>,
}

// The horizontal blends (< 2^19) of source row sy of level p at the four
// columns' taps. The source words are read when sy leaves word row cg (rows
// only move down, so each word is read once).
fn hblend(b: ptr<function, Blends>, c: Columns, sy: u32) -> vec4<u32> {
    if ((sy >> 2u) != (*b).cg) {
        let r = pk_word(c.p, 0u, sy);
        (*b).cw0 = vec4<u32>(gray[r + c.sx0.x], gray[r + c.sx0.y], gray[r + c.sx0.z], gray[r + c.sx0.w]);
        (*b).cw1 = vec4<u32>(gray[r + c.sx1.x], gray[r + c.sx1.y], gray[r + c.sx1.z], gray[r + c.sx1.w]);
        (*b).cg = sy >> 2u;
    }
    return (vec4<u32>(ONE) - c.wx) * pk_byte4((*b).cw0, sy) + c.wx * pk_byte4((*b).cw1, sy);
}

// Destination row y of the four columns (`tw` its row's tap) in its place in
// their packed words (0 past the walk's end, which no branch below runs for: y and the walk are
// the same for the whole workgroup).
fn row_value(b: ptr<function, Blends>, c: Columns, y: u32, tw: u32) -> vec4<u32> {
    if (y >= c.end) { return vec4<u32>(0u); }
    let ty = vec2<u32>(tw & 0xffffu, tw >> 16u);
    let sy0 = ty.x;
    let sy1 = min(sy0 + 1u, c.sh - 1u);
    // rows only move down: the new upper row is the old lower or upper one, or new
    if (sy0 == (*b).r1) {
        (*b).h0 = (*b).h1;
    } else if (sy0 != (*b).r0) {
        (*b).h0 = hblend(b, c, sy0);
    }
    if (sy1 == sy0) {
        (*b).h1 = (*b).h0;
    } else if (sy1 != (*b).r1) {
        (*b).h1 = hblend(b, c, sy1);
    }
    (*b).r0 = sy0;
    (*b).r1 = sy1;
    let wy = ty.y;
    // the vertical blend (< 2^30): no overflow
    let v = (ONE - wy) * (*b).h0 + wy * (*b).h1;
    return ((v + vec4<u32>(1u << (2u * COEF_BITS - 1u))) >> vec4<u32>(2u * COEF_BITS)) << vec4<u32>((y & 3u) * 8u);
}
