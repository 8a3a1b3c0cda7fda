// SPEC 10: level l of the pyramid resized from level l-1 with integer
// bilinear weights in Q11 (OpenCV INTER_LINEAR). Mirrors src/cpu/pyramid.rs
// (`tap`, `resize_naive`). One dispatch per level: `level_index.x` = l,
// given by the dynamic offset of `level_index` (record l at l * 256 bytes).
// `gray` is column-packed (common.wgsl pk_word).
// Tests: tests/gpu_levels.rs (this pass alone == src/cpu/pyramid.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).

const COEF_BITS: u32 = 11u;
const ONE: u32 = 2048u; // 1 << COEF_BITS

@group(0) @binding(1) var<uniform> level_index: vec4<u32>;
@group(0) @binding(2) var<storage, read_write> gray: array<u32>;

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

// The horizontal blend of source row sy of level p at taps sx0, sx1 with
// weight wx (< 2^19). `b.cw` caches the two columns' words of group `b.cg`
// (rows only move down, so each word is read once).
fn hblend(b: ptr<function, Blends>, p: u32, sy: u32, sx0: u32, sx1: u32, wx: u32) -> u32 {
    if ((sy >> 2u) != (*b).cg) {
        (*b).cw = vec2<u32>(gray[pk_word(p, sx0, sy)], gray[pk_word(p, sx1, sy)]);
        (*b).cg = sy >> 2u;
    }
    return (ONE - wx) * pk_byte((*b).cw.x, sy) + wx * pk_byte((*b).cw.y, sy);
}

// Dispatched as FrameLayout::level_column_groups: each invocation walks 16
// rows of one destination column (four packed words). Its horizontal taps are
// computed once, and a source row's blend is reused by the next destination
// row that reads it.
@compute @workgroup_size(64, 1, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>, @builtin(workgroup_id) wg: vec3<u32>) {
    let l = level_index.x;
    if (l == 0u || l >= P.n_levels) { return; }
    let dw = lw(l);
    let dh = lh(l);
    let x = id.x;
    let y0 = wg.y * TILE;
    if (x >= dw || y0 >= dh) { return; }
    let p = l - 1u;
    let sw = lw(p);
    let sh = lh(p);
    let tx = tap(x, sw, dw);
    let sx0 = tx.x;
    let sx1 = min(sx0 + 1u, sw - 1u);
    let wx = tx.y;
    // the blends of source rows r0 and r1 of the previous destination row
    var b: Blends;
    b.r0 = 0xffffffffu;
    b.r1 = 0xffffffffu;
    b.cg = 0xffffffffu;
    let c = Column(l, p, x, sx0, sx1, wx, sh, dh, min(y0 + TILE, dh));
    // the walk's four words (TILE rows) and their rows written out: a loop
    // costs a SIMD software rasteriser its masks every iteration
    var st = vec2<u32>(0u);
    store_word(&b, c, y0, &st);
    store_word(&b, c, y0 + 4u, &st);
    store_word(&b, c, y0 + 8u, &st);
    store_word(&b, c, y0 + 12u, &st);
}

// A walk's destination column x of level l (source level p): its horizontal
// taps, the source height, the level's height, the walk's end row.
struct Column {
    l: u32,
    p: u32,
    x: u32,
    sx0: u32,
    sx1: u32,
    wx: u32,
    sh: u32,
    dh: u32,
    end: u32,
}

// The horizontal blends h0, h1 of source rows r0, r1 (the previous
// destination row's), and hblend's cached words cw of group cg.
struct Blends {
    r0: u32,
    r1: u32,
    h0: u32,
    h1: u32,
    cg: u32,
    cw: vec2<u32>,
}

// Destination row y in its place in the packed word (0 past the walk's end,
// which no branch below runs for: y and the walk are the same for the whole
// workgroup).
fn row_value(b: ptr<function, Blends>, c: Column, y: u32) -> u32 {
    if (y >= c.end) { return 0u; }
    let ty = tap(y, c.sh, c.dh);
    let sy0 = ty.x;
    let sy1 = min(sy0 + 1u, c.sh - 1u);
    // rows only move down: the new upper row is the old lower or upper one, or new
    if (sy0 == (*b).r1) {
        (*b).h0 = (*b).h1;
    } else if (sy0 != (*b).r0) {
        (*b).h0 = hblend(b, c.p, sy0, c.sx0, c.sx1, c.wx);
    }
    if (sy1 == sy0) {
        (*b).h1 = (*b).h0;
    } else if (sy1 != (*b).r1) {
        (*b).h1 = hblend(b, c.p, sy1, c.sx0, c.sx1, c.wx);
    }
    (*b).r0 = sy0;
    (*b).r1 = sy1;
    let wy = ty.y;
    // the vertical blend (< 2^30): no overflow
    let v = (ONE - wy) * (*b).h0 + wy * (*b).h1;
    return pk_place((v + (1u << (2u * COEF_BITS - 1u))) >> (2u * COEF_BITS), y);
}

// The word of rows y .. y + 3; `st` is the last store (index, word), stored
// again when y is past the walk's end: no store under `if`.
fn store_word(b: ptr<function, Blends>, c: Column, y: u32, st: ptr<function, vec2<u32>>) {
    let word = row_value(b, c, y) | row_value(b, c, y + 1u) | row_value(b, c, y + 2u) | row_value(b, c, y + 3u);
    *st = select(*st, vec2<u32>(pk_word(c.l, c.x, y), word), y < c.end);
    gray[(*st).x] = (*st).y;
}
