// SPEC 1: noise-flagged 3x3 median. Mirrors src/cpu/median.rs.
// One invocation per pixel, all levels in one dispatch (over the tile list).
// Tests: tests/gpu_median.rs (this pass alone == src/cpu/median.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).

@group(0) @binding(1) var<storage, read> src: array<u32>;
@group(0) @binding(2) var<storage, read_write> dst: array<u32>;

fn px(l: u32, x: i32, y: i32) -> u32 { return src[clamped(l, x, y)]; }

// |G - Gn| > delta * G for all four neighbours, as integers (u32 cannot
// overflow: delta_den <= 10^4, delta_num <= 10^6, values <= 255).
fn is_noise(l: u32, x: i32, y: i32) -> bool {
    let g = px(l, x, y);
    let lim = P.delta_num * g;
    let n = array<u32, 4>(px(l, x, y - 1), px(l, x, y + 1), px(l, x - 1, y), px(l, x + 1, y));
    for (var i = 0u; i < 4u; i++) {
        let d = select(n[i] - g, g - n[i], g >= n[i]);
        if (P.delta_den * d <= lim) { return false; }
    }
    return true;
}

// The 19-exchange network of median9 in src/cpu/median.rs.
fn median9(x: i32, y: i32, l: u32) -> u32 {
    var p: array<u32, 9>;
    var i = 0u;
    for (var dy = -1; dy <= 1; dy++) {
        for (var dx = -1; dx <= 1; dx++) {
            p[i] = px(l, x + dx, y + dy);
            i++;
        }
    }
    let net = array<vec2<u32>, 19>(
        vec2(1u, 2u), vec2(4u, 5u), vec2(7u, 8u), vec2(0u, 1u), vec2(3u, 4u), vec2(6u, 7u),
        vec2(1u, 2u), vec2(4u, 5u), vec2(7u, 8u), vec2(0u, 3u), vec2(5u, 8u), vec2(4u, 7u),
        vec2(3u, 6u), vec2(1u, 4u), vec2(2u, 5u), vec2(4u, 7u), vec2(4u, 2u), vec2(6u, 4u),
        vec2(4u, 2u));
    for (var k = 0u; k < 19u; k++) {
        let a = p[net[k].x];
        let b = p[net[k].y];
        p[net[k].x] = min(a, b);
        p[net[k].y] = max(a, b);
    }
    return p[4];
}

@compute @workgroup_size(16, 16, 1)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let id = tile_pixel(wg, li);
    let l = id.z;
    if (id.x >= lw(l) || id.y >= lh(l)) { return; }
    let x = i32(id.x);
    let y = i32(id.y);
    var v = px(l, x, y);
    if (is_noise(l, x, y)) { v = median9(x, y, l); }
    dst[loff(l) + id.y * lw(l) + id.x] = v;
}
