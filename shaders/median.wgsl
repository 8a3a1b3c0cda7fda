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

// The 19-exchange network of median9 in src/cpu/median.rs, written out with
// constant indices: a table-driven loop indexes the 9 values dynamically,
// which puts them in memory instead of registers on real GPUs.
fn median9(x: i32, y: i32, l: u32) -> u32 {
    var p0 = px(l, x - 1, y - 1);
    var p1 = px(l, x, y - 1);
    var p2 = px(l, x + 1, y - 1);
    var p3 = px(l, x - 1, y);
    var p4 = px(l, x, y);
    var p5 = px(l, x + 1, y);
    var p6 = px(l, x - 1, y + 1);
    var p7 = px(l, x, y + 1);
    var p8 = px(l, x + 1, y + 1);
    var t: u32;
    t = min(p1, p2); p2 = max(p1, p2); p1 = t;
    t = min(p4, p5); p5 = max(p4, p5); p4 = t;
    t = min(p7, p8); p8 = max(p7, p8); p7 = t;
    t = min(p0, p1); p1 = max(p0, p1); p0 = t;
    t = min(p3, p4); p4 = max(p3, p4); p3 = t;
    t = min(p6, p7); p7 = max(p6, p7); p6 = t;
    t = min(p1, p2); p2 = max(p1, p2); p1 = t;
    t = min(p4, p5); p5 = max(p4, p5); p4 = t;
    t = min(p7, p8); p8 = max(p7, p8); p7 = t;
    t = min(p0, p3); p3 = max(p0, p3); p0 = t;
    t = min(p5, p8); p8 = max(p5, p8); p5 = t;
    t = min(p4, p7); p7 = max(p4, p7); p4 = t;
    t = min(p3, p6); p6 = max(p3, p6); p3 = t;
    t = min(p1, p4); p4 = max(p1, p4); p1 = t;
    t = min(p2, p5); p5 = max(p2, p5); p2 = t;
    t = min(p4, p7); p7 = max(p4, p7); p4 = t;
    t = min(p4, p2); p2 = max(p4, p2); p4 = t;
    t = min(p6, p4); p4 = max(p6, p4); p6 = t;
    t = min(p4, p2); p2 = max(p4, p2); p4 = t;
    return p4;
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
