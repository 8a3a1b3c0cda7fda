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
// l - 1 only, which this dispatch does not write.

const COEF_BITS: u32 = 11u;
const ONE: u32 = 2048u; // 1 << COEF_BITS

@group(0) @binding(1) var<uniform> level_index: vec4<u32>;
@group(0) @binding(2) var<storage, read_write> gray: array<u32>;
// `gray` again, four columns' words a store (common.wgsl pk_pitch; the
// padding words past the level's width included)
@group(0) @binding(3) var<storage, read_write> gray4: array<vec4<u32>>;

// Source index and Q11 weight of the right/lower neighbour for destination
// index d when resizing src_len -> dst_len, exactly as cpu::pyramid::tap:
// the source coordinate is ((2d+1)*src - dst) / (2*dst), clamped. Sides are
// at most MAX_SIDE = 16384, so every product fits 32 bits (udiv: no
// integer division).
fn tap(d: u32, src_len: u32, dst_len: u32) -> vec2<u32> {
    let a = (2u * d + 1u) * src_len;
    let den = 2u * dst_len;
    if (a < dst_len) { return vec2(0u, 0u); }
    let num = a - dst_len;
    let s = udiv(num, den);
    if (s + 1u >= src_len) { return vec2(src_len - 1u, 0u); }
    let rem = num - s * den;
    // round(rem / den * 2048), half up
    let w = udiv(rem * ONE * 2u + den, 2u * den);
    return vec2(s, w);
}

// Dispatched as FrameLayout::level_quad_groups: each invocation walks 16
// rows of four neighbouring destination columns x0 .. x0 + 3 (four packed
// words each). Their horizontal taps are computed once; each row's vertical
// tap (two divisions, the same for every column) once for the four; and a
// source row's blends are reused by the next destination row that reads it.
// (One column per invocation, the vertical taps were ~0.7 of the pass's
// ~3.9 ms per KITTI frame on lavapipe.)
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
    let xs = min(vec4<u32>(x0) + vec4<u32>(0u, 1u, 2u, 3u), vec4<u32>(dw - 1u));
    let t0 = tap(xs.x, sw, dw);
    let t1 = tap(xs.y, sw, dw);
    let t2 = tap(xs.z, sw, dw);
    let t3 = tap(xs.w, sw, dw);
    let sx0 = vec4<u32>(t0.x, t1.x, t2.x, t3.x);
    let c = Columns(l, p, x0, dw, sx0, min(sx0 + vec4<u32>(1u), vec4<u32>(sw - 1u)), vec4<u32>(t0.y, t1.y, t2.y, t3.y), sh, dh, min(y0 + TILE, dh));
    // the blends of source rows r0 and r1 of the previous destination row
    var b: Blends;
    b.r0 = 0xffffffffu;
    b.r1 = 0xffffffffu;
    b.cg = 0xffffffffu;
    for (var y = y0; y < c.end; y += 4u) {
        let words = row_value(&b, c, y) | row_value(&b, c, y + 1u) | row_value(&b, c, y + 2u) | row_value(&b, c, y + 3u);
        gray4[pk_word(l, x0, y) >> 2u] = words;
    }
}

// A walk's destination columns x0 .. x0 + 3 of level l (source level p):
// the level's width, their horizontal taps, the source height, the level's
// height, the walk's end row.
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

// Destination row y of the four columns in its place in their packed words
// (0 past the walk's end, which no branch below runs for: y and the walk are
// the same for the whole workgroup).
fn row_value(b: ptr<function, Blends>, c: Columns, y: u32) -> vec4<u32> {
    if (y >= c.end) { return vec4<u32>(0u); }
    let ty = tap(y, c.sh, c.dh);
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
