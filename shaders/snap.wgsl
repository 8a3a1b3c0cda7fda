// Beyond the paper (docs/quality.md): each corner that survived corner NMS
// moves to the Harris maximum of the (2s+1)^2 square around it, s =
// P.snap_radius (Config::snap()), and takes that response. Mirrors src/cpu/snap.rs.
// Compiled after response.wgsl (src/gpu/snap.rs): its Harris response on D
// (structure_sums, harris_from_sums, bit-identical to the CPU) is the one
// definition used here; this file adds the entry point `snap`.
// `corners` (counters[CORNERS] of them, any order) are updated in place; the
// square is scanned row by row and the first of equal responses wins (the
// earlier (y, x), as in corner NMS); only pixels at least P.border from every
// side and, with a mask, where the level mask is on are candidates. 2s <= nms_radius keeps positions distinct.
// The maximum is then located to 1/16 pixel (`subpixel`, = src/cpu/snap.rs
// `subpixel`): the offset's steps are decided by comparisons of f32 sums and
// products, each rounded once (WGSL rounds f32 + - * correctly, not /), and
// packed into Kp.sub; the host builds the keypoint from them (src/gpu/readback.rs).
// Two entry points: `snap_args` writes the dispatch size from the corner count
// (indirect::CORNERS), then `snap` runs one invocation per corner.
// Tests: tests/gpu_end_to_end.rs (whole pipeline with snap_radius 1 and 2 == CPU).

@group(0) @binding(5) var<storage, read_write> corners: array<Kp>;
@group(0) @binding(6) var<storage, read> mask: array<u32>;
@group(0) @binding(7) var<storage, read_write> indirect: array<u32>;

// indirect::CORNERS in src/gpu/buffers.rs, in words.
const I_SNAP_CORNERS: u32 = 0u;

// The dispatch size of `snap`: one invocation per corner, 64 per workgroup
// (as select.wgsl `args` writes it for its own passes over the corners).
@compute @workgroup_size(1)
fn snap_args() {
    let a = list_args(min(counters[C_CORNERS], P.capacity));
    indirect[I_SNAP_CORNERS] = a.x;
    indirect[I_SNAP_CORNERS + 1u] = a.y;
    indirect[I_SNAP_CORNERS + 2u] = a.z;
}

fn harris_at(l: u32, x: u32, y: u32) -> f32 {
    let s = structure_sums(l, i32(x), i32(y));
    return harris_from_sums(s.x, s.y, s.z);
}

// round(16 d), clamped to +-7, for the peak d of the parabola through
// (-1, a), (0, r0), (1, b); 0 where the curvature 2 r0 - a - b is not positive.
// 16 d >= k - 1/2  <=>  b - a >= ((2k - 1) / 16) (2 r0 - a - b).
fn subpixel(a: f32, r0: f32, b: f32) -> i32 {
    // 2 r0 is exact, so a fused 2 r0 - a rounds as the two steps do
    let den = opaque(opaque(2.0 * r0 - a) - b);
    if (!(den > 0.0)) { return 0; }
    let num = opaque(b - a);
    var q = 0;
    for (var k = 1; k <= 7; k++) {
        let t = opaque(opaque(f32(2 * k - 1) * 0.0625) * den);
        if (num >= t) {
            q = k;
        } else if (num <= -t) {
            q = -k;
        }
    }
    return q;
}

@compute @workgroup_size(64, 1, 1)
fn snap(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let k = list_index(wg, li);
    let s = P.snap_radius;
    if (s == 0u || k >= min(counters[C_CORNERS], P.capacity)) { return; }
    var c = corners[k];
    let l = c.level;
    // corners lie in [border, size - border): the square is cut to it
    let b = P.border;
    let x0 = max(select(0u, c.px - s, c.px >= s), b);
    let y0 = max(select(0u, c.py - s, c.py >= s), b);
    let x1 = min(c.px + s, lw(l) - b - 1u);
    let y1 = min(c.py + s, lh(l) - b - 1u);
    // The responses in one loop, so harris_at (structure_sums, nine col9
    // calls) has one call site: each site is inlined whole, and six of them
    // made this the slowest pipeline to build on lavapipe (65 of the stages'
    // 225 ms, one thread). Step 0 is the corner itself (the best so far),
    // steps 1..n the square row by row (first of equal responses wins), the
    // last four the best's left, right, upper and lower neighbours for the
    // sub-pixel peak (when both of a pair are inside the level).
    var bx = c.px;
    var by = c.py;
    var br = 0.0;
    let n = (x1 - x0 + 1u) * (y1 - y0 + 1u);
    var side = array<f32, 4>(0.0, 0.0, 0.0, 0.0);
    var sx = x0;
    var sy = y0;
    for (var i = 0u; i < n + 5u; i++) {
        var x = c.px;
        var y = c.py;
        var take = true;
        if (i >= 1u && i <= n) {
            x = sx;
            y = sy;
            sx += 1u;
            if (sx > x1) {
                sx = x0;
                sy += 1u;
            }
            let own = x == c.px && y == c.py;
            let off = P.use_mask != 0u && mask[loff(l) + y * lw(l) + x] == 0u;
            take = !own && !off;
        } else if (i > n) {
            let t = i - n - 1u;
            let horizontal = t < 2u;
            take = select(by >= 1u && by + 1u < lh(l), bx >= 1u && bx + 1u < lw(l), horizontal);
            let d = select(1u, 0xffffffffu, (t & 1u) == 0u);  // -1 for left and up
            x = select(bx, bx + d, horizontal);
            y = select(by + d, by, horizontal);
        }
        if (!take) { continue; }
        let r = harris_at(l, x, y);
        if (i == 0u) {
            br = r;
        } else if (i <= n) {
            if (r > br || (r == br && (y < by || (y == by && x < bx)))) {
                bx = x;
                by = y;
                br = r;
            }
        } else {
            side[i - n - 1u] = r;
        }
    }
    var qx = 0;
    var qy = 0;
    if (bx >= 1u && bx + 1u < lw(l)) {
        qx = subpixel(side[0], br, side[1]);
    }
    if (by >= 1u && by + 1u < lh(l)) {
        qy = subpixel(side[2], br, side[3]);
    }
    let sc = P.scales[l];
    c.px = bx;
    c.py = by;
    c.x = (f32(bx) + 0.5 + f32(qx) * 0.0625) * sc.x;
    c.y = (f32(by) + 0.5 + f32(qy) * 0.0625) * sc.x;
    c.response = br;
    c.sub = (bitcast<u32>(qx) & 0xffu) | ((bitcast<u32>(qy) & 0xffu) << 8u);
    corners[k] = c;
}
