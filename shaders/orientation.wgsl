// SPEC 11: keypoint orientation by the intensity centroid, and its bin.
// Mirrors src/cpu/orientation.rs (`moments`, `AngleBins::bin_of`, `angle_deg`).
// One invocation per final keypoint, dispatched indirectly over
// counters[KEYPOINTS] (64 per workgroup). The moments are exact integers on
// the *unsmoothed* level; the angle is an f32 approximation (the host
// recomputes it exactly from m10, m01).
// Tests: tests/gpu_levels.rs (this pass alone == src/cpu/orientation.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).

const KEYPOINTS: u32 = 1u; // counter::KEYPOINTS
const HALF_PATCH: i32 = 15;
// OpenCV ORB's umax: half-width of row v of the radius-15 disc (cpu::orientation::UMAX).
const UMAX: array<i32, 16> = array<i32, 16>(15, 15, 15, 15, 14, 14, 14, 13, 13, 12, 11, 10, 9, 8, 6, 3);

@group(0) @binding(1) var<storage, read> gray: array<u32>;
@group(0) @binding(2) var<storage, read_write> keypoints: array<Kp>;
@group(0) @binding(3) var<storage, read> counters: array<u32>;
// Per bin the Q8 direction (cos, sin) of its upper boundary (AngleBins::bounds).
@group(0) @binding(4) var<storage, read> angle_bounds: array<vec2<i32>>;

fn px(l: u32, x: i32, y: i32) -> i32 { return i32(gray[clamped(l, x, y)]); }

// (m10, m01) over the disc around (x, y), reads clamped: the CPU's border
// branch, which its test shows equal to the interior one. |m| < 2^21.
fn moments(l: u32, x: i32, y: i32) -> vec2<i32> {
    var m10 = 0;
    var m01 = 0;
    for (var u = -HALF_PATCH; u <= HALF_PATCH; u++) {
        m10 += u * px(l, x + u, y);
    }
    for (var v = 1; v <= HALF_PATCH; v++) {
        var v_sum = 0;
        let r = UMAX[v];
        for (var u = -r; u <= r; u++) {
            let plus = px(l, x + u, y + v);
            let minus = px(l, x + u, y - v);
            v_sum += plus - minus;
            m10 += u * (plus + minus);
        }
        m01 += v * v_sum;
    }
    return vec2(m10, m01);
}

// 0 for directions in [0°, 180°), 1 for [180°, 360°); (0, 0) counts as 0°.
fn half_of(v: vec2<i32>) -> u32 {
    if (v.y > 0 || (v.y == 0 && v.x >= 0)) { return 0u; }
    return 1u;
}

// True iff the angle of v is >= the angle of b (both in [0, 360)). The cross
// product stays under 2^30 (|b| <= 256, |v| < 2^21).
fn at_or_past(b: vec2<i32>, v: vec2<i32>) -> bool {
    let hb = half_of(b);
    let hv = half_of(v);
    return hb < hv || (hb == hv && b.x * v.y - b.y * v.x >= 0);
}

fn bin_of(m: vec2<i32>) -> u32 {
    if (m.x == 0 && m.y == 0) { return 0u; } // no direction: angle 0
    let n_bins = max(1u, P.orientation_bins);
    var n = 0u;
    for (var b = 0u; b < n_bins; b++) {
        if (at_or_past(angle_bounds[b], m)) { n++; }
    }
    return n % n_bins;
}

// atan2(m01, m10) in degrees, in [0, 360).
fn angle_deg(m: vec2<i32>) -> f32 {
    if (m.x == 0 && m.y == 0) { return 0.0; }
    var a = degrees(atan2(f32(m.y), f32(m.x)));
    if (a < 0.0) { a += 360.0; }
    if (a >= 360.0) { a = 0.0; }
    return a;
}

@compute @workgroup_size(64, 1, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if (i >= counters[KEYPOINTS] || i >= P.capacity) { return; }
    var kp = keypoints[i];
    if (kp.level >= P.n_levels) { return; }
    let m = moments(kp.level, i32(kp.px), i32(kp.py));
    kp.m10 = m.x;
    kp.m01 = m.y;
    kp.bin = bin_of(m);
    kp.angle = angle_deg(m);
    keypoints[i] = kp;
}
