// SPEC 3: non-maximum suppression across the gradient direction, with the
// direction sector found by integer tests. Mirrors src/cpu/nms.rs.
// gx, gy, s -> nms (1 = survivor, 0 otherwise; column-packed, common.wgsl pk_word). A column pass, all levels in
// one dispatch (over the tile list).
// Tests: tests/gpu_edges_front.rs (this pass alone == src/cpu/nms.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).
//
// Races: no atomics. Each invocation owns one column of one tile and stores only
// that column's 4 words of `nms` (common.wgsl pk_word), so no two invocations
// write one word.

@group(0) @binding(1) var<storage, read> gx: array<i32>;
@group(0) @binding(2) var<storage, read> gy: array<i32>;
@group(0) @binding(3) var<storage, read> s: array<u32>;
@group(0) @binding(4) var<storage, read_write> nms: array<u32>;

// S at (x, y) of level l, 0 outside the image (no clamping here).
fn s_or_zero(l: u32, x: i32, y: i32) -> u32 {
    if (x < 0 || y < 0 || x >= i32(lw(l)) || y >= i32(lh(l))) { return 0u; }
    return s[loff(l) + u32(y) * lw(l) + u32(x)];
}

// A column pass (tile_column): one invocation per 16 pixels.
@compute @workgroup_size(64, 1, 1)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let span = column_span(wg, li);
    let l = span.w;
    let x = i32(span.x);
    // `nms` is column-packed (common.wgsl pk_word): a word per four rows
    var word = 0u;
    for (var yy = span.y; yy < span.z; yy++) {
        let y = i32(yy);
        let i = loff(l) + yy * lw(l) + span.x;
        let v = s[i];
        var keep = 0u;
        if (v != 0u) {
            let o = sector(gx[i], gy[i]);
            keep = select(0u, 1u, v > s_or_zero(l, x + o.x, y + o.y) && v >= s_or_zero(l, x + o.z, y + o.w));
        }
        word |= pk_place(keep, yy);
        if (pk_complete(yy, span.z)) {
            nms[pk_word(l, span.x, yy)] = word;
            word = 0u;
        }
    }
}
