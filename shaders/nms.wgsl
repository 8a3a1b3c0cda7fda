// SPEC 3: non-maximum suppression across the gradient direction, with the
// direction sector found by integer tests. Mirrors src/cpu/nms.rs.
// gx, gy, s -> nms (1 = survivor, 0 otherwise). A column pass, all levels in
// one dispatch (over the tile list).
// Tests: tests/gpu_edges_front.rs (this pass alone == src/cpu/nms.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).

@group(0) @binding(1) var<storage, read> gx: array<i32>;
@group(0) @binding(2) var<storage, read> gy: array<i32>;
@group(0) @binding(3) var<storage, read> s: array<u32>;
@group(0) @binding(4) var<storage, read_write> nms: array<u32>;

// Neighbour offsets (first.xy, second.xy) of the direction sector of (gx2, gy2).
// tan(22.5°) ≈ 13573/32768 and tan(67.5°) ≈ 79109/32768; |g| <= 510 keeps the
// products far below 2^32.
fn sector(gx2: i32, gy2: i32) -> vec4<i32> {
    let ax = u32(abs(gx2));
    let ay = u32(abs(gy2));
    if (ay * 32768u < 13573u * ax) {
        return vec4(-1, 0, 1, 0);
    } else if (ay * 32768u > 79109u * ax) {
        return vec4(0, -1, 0, 1);
    } else if ((gx2 > 0) == (gy2 > 0)) {
        return vec4(-1, -1, 1, 1);
    }
    return vec4(1, -1, -1, 1);
}

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
    for (var yy = span.y; yy < span.z; yy++) {
        let y = i32(yy);
        let i = loff(l) + yy * lw(l) + span.x;
        let v = s[i];
        var keep = 0u;
        if (v != 0u) {
            let o = sector(gx[i], gy[i]);
            keep = select(0u, 1u, v > s_or_zero(l, x + o.x, y + o.y) && v >= s_or_zero(l, x + o.z, y + o.w));
        }
        nms[i] = keep;
    }
}
