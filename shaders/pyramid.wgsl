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
// weight wx (< 2^19). `cw` caches the two columns' words of group `cg` (rows
// only move down, so each word is read once).
fn hblend(p: u32, sy: u32, sx0: u32, sx1: u32, wx: u32, cg: ptr<function, u32>, cw: ptr<function, vec2<u32>>) -> u32 {
    if ((sy >> 2u) != *cg) {
        *cw = vec2<u32>(gray[pk_word(p, sx0, sy)], gray[pk_word(p, sx1, sy)]);
        *cg = sy >> 2u;
    }
    return (ONE - wx) * pk_byte((*cw).x, sy) + wx * pk_byte((*cw).y, sy);
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
    var r0 = 0xffffffffu;
    var r1 = 0xffffffffu;
    var h0 = 0u;
    var h1 = 0u;
    var cg = 0xffffffffu;
    var cw = vec2<u32>(0u);
    var word = 0u;
    let end = min(y0 + TILE, dh);
    for (var y = y0; y < end; y++) {
        let ty = tap(y, sh, dh);
        let sy0 = ty.x;
        let sy1 = min(sy0 + 1u, sh - 1u);
        // rows only move down: the new upper row is the old lower or upper one, or new
        if (sy0 == r1) {
            h0 = h1;
        } else if (sy0 != r0) {
            h0 = hblend(p, sy0, sx0, sx1, wx, &cg, &cw);
        }
        if (sy1 == sy0) {
            h1 = h0;
        } else if (sy1 != r1) {
            h1 = hblend(p, sy1, sx0, sx1, wx, &cg, &cw);
        }
        r0 = sy0;
        r1 = sy1;
        let wy = ty.y;
        // the vertical blend (< 2^30): no overflow
        let v = (ONE - wy) * h0 + wy * h1;
        word |= pk_place((v + (1u << (2u * COEF_BITS - 1u))) >> (2u * COEF_BITS), y);
        if (pk_complete(y, end)) {
            gray[pk_word(l, x, y)] = word;
            word = 0u;
        }
    }
}
