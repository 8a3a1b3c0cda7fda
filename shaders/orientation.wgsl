// SPEC 11: keypoint orientation by the intensity centroid, and its bin.
// Mirrors src/cpu/orientation.rs (`moments`, `AngleBins::bin_of`, `angle_deg`).
// One invocation per final keypoint, dispatched indirectly over them
// (indirect::KEYPOINTS, 64 a workgroup), summing the disc's 62 half columns
// (moments_part) alone. A workgroup per keypoint sharing the half columns
// and adding them in workgroup atomics took 2.3 ms per KITTI frame on
// lavapipe with 64 invocations, 1.5 with 8 (every SIMD group of 8 of a
// workgroup with a barrier is a coroutine there, and each of ~1500
// workgroups paid its own work). The moments are exact integers on
// the *unsmoothed* level; the angle is an f32 approximation (the host
// recomputes it exactly from m10, m01).
// Tests: tests/gpu_levels.rs (this pass alone == src/cpu/orientation.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).
//
// Races: invocation i stores keypoints[i] only (a whole keypoint, read and
// written by the same invocation), so no two invocations write one word.

const HALF_PATCH: i32 = 15;
// OpenCV ORB's umax: half-width of row v of the radius-15 disc (cpu::orientation::UMAX).
const UMAX: array<i32, 16> = array<i32, 16>(15, 15, 15, 15, 14, 14, 14, 13, 13, 12, 11, 10, 9, 8, 6, 3);

// `gray` is column-packed (common.wgsl pk_word).
@group(0) @binding(1) var<storage, read> gray: array<u32>;
@group(0) @binding(2) var<storage, read_write> keypoints: array<Kp>;
@group(0) @binding(3) var<storage, read> counters: array<u32>;
// Per bin the Q8 direction (cos, sin) of its upper boundary (AngleBins::bounds).
@group(0) @binding(4) var<storage, read> angle_bounds: array<vec2<i32>>;

// Half column k's share of (m10, m01) over the disc around (x, y) (those
// pixels of the 31x31 square with |u| <= UMAX[|v|]): k < 62 is column
// u = k % 31 - 15 and half of its rows (v <= 0 for k < 31, v > 0 after). The
// disc is symmetric about its diagonal (src/spec/angle.rs tests it), so column
// u holds the rows |v| <= UMAX[|u|]: a range, which is taken a packed
// word (four rows) at a time, all of it unconditionally. Reads clamp (the
// CPU's border branch, which its test shows equal to the interior one): rows
// above the level read row 0 and rows below it row h - 1, added apart. The
// whole sums are below 2^21 in magnitude.
fn moments_part(l: u32, x: i32, y: i32, k: u32) -> vec2<i32> {
    let u = i32(k % 31u) - HALF_PATCH;
    let top = k < 31u;
    let vm = UMAX[abs(u)];
    let v0 = select(1, -vm, top);
    let v1 = select(vm, 0, top);
    let h = i32(lh(l));
    let cx = clamped_xy(l, x + u, 0).x;
    // the rows of the level, each once: sum of p and of v p
    let r0 = max(y + v0, 0);
    let r1 = min(y + v1, h - 1);
    // at most 16 rows: five words from r0's, written out (a loop costs a SIMD
    // software rasteriser its masks every iteration); a word past r1 adds
    // nothing (its load clamped into the level)
    let k0 = r0 & ~3;
    var acc = vec2<i32>(0);
    acc += word_sums(l, cx, k0, r0, r1, y, h);
    acc += word_sums(l, cx, k0 + 4, r0, r1, y, h);
    acc += word_sums(l, cx, k0 + 8, r0, r1, y, h);
    acc += word_sums(l, cx, k0 + 12, r0, r1, y, h);
    acc += word_sums(l, cx, k0 + 16, r0, r1, y, h);
    var s = acc.x;
    var sv = acc.y;
    // rows v0 .. a1 lie above the level (read row 0), b0 .. v1 below it (row h - 1)
    let a1 = min(v1, -y - 1);
    if (a1 >= v0) {
        let p = i32(pk_byte(gray[pk_word(l, cx, 0u)], 0u));
        let n = a1 - v0 + 1;
        s += n * p;
        sv += (n * (v0 + a1) / 2) * p;
    }
    let b0 = max(v0, h - y);
    if (v1 >= b0) {
        let p = i32(pk_byte(gray[pk_word(l, cx, u32(h - 1))], u32(h - 1)));
        let n = v1 - b0 + 1;
        s += n * p;
        sv += (n * (b0 + v1) / 2) * p;
    }
    return vec2(u * s, sv);
}

// Rows k .. k + 3 (k a multiple of 4) of column cx that lie in [r0, r1]: the
// sums of p and of (row - y) p.
fn word_sums(l: u32, cx: u32, k: i32, r0: i32, r1: i32, y: i32, h: i32) -> vec2<i32> {
    let rows = vec4<i32>(k) + vec4<i32>(0, 1, 2, 3);
    let inside = (rows >= vec4<i32>(r0)) & (rows <= vec4<i32>(r1));
    let p = select(vec4<i32>(0), vec4<i32>(pk_rows(gray[pk_word(l, cx, u32(min(k, h - 1)))])), inside);
    return vec2<i32>(p.x + p.y + p.z + p.w, dot(p, rows - vec4<i32>(y)));
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

// AngleBins::bin_of: how many boundaries m is at or past, mod bins. The
// boundaries ascend strictly in angle (src/spec/angle.rs tests it for every
// bin count allowed), so those m is at or past are a prefix: a binary search
// counts them in log2(bins) + 1 reads instead of a loop over all of them.
fn bin_of(m: vec2<i32>) -> u32 {
    let n_bins = max(1u, P.orientation_bins);
    var lo = 0u;
    var hi = n_bins;
    while (lo < hi) {
        let mid = (lo + hi) >> 1u;
        let past = at_or_past(angle_bounds[mid], m);
        lo = select(lo, mid + 1u, past);
        hi = select(mid, hi, past);
    }
    // no direction: angle 0
    return select(lo % n_bins, 0u, m.x == 0 && m.y == 0);
}

// atan2(m01, m10) in degrees, in [0, 360).
fn angle_deg(m: vec2<i32>) -> f32 {
    if (m.x == 0 && m.y == 0) { return 0.0; }
    var a = degrees(atan2(f32(m.y), f32(m.x)));
    if (a < 0.0) { a += 360.0; }
    if (a >= 360.0) { a = 0.0; }
    return a;
}

// One invocation per keypoint, 64 a workgroup (indirect::KEYPOINTS), no
// workgroup memory and no barrier: the invocation sums the disc's 62 half
// columns itself, in a loop bounded by a value read at run time (a constant
// trip count is unrolled by lavapipe's compiler).
@compute @workgroup_size(64, 1, 1)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let i = list_index(wg, li);
    if (i >= counters[C_KEYPOINTS] || i >= P.capacity) { return; }
    // Every lane reads the three fields it needs, not the whole record (a
    // SIMD software rasteriser reads each field lane by lane).
    let level = keypoints[i].level;
    let kx = i32(keypoints[i].px);
    let ky = i32(keypoints[i].py);
    if (level >= P.n_levels) { return; }
    var m = vec2<i32>(0);
    // n_levels <= 32: a bound the compiler cannot see
    let halves = 62u + (P.n_levels >> 6u);
    for (var k = 0u; k < halves; k++) {
        m += moments_part(level, kx, ky, k);
    }
    var kp = keypoints[i];
    kp.m10 = m.x;
    kp.m01 = m.y;
    kp.bin = bin_of(m);
    kp.angle = angle_deg(m);
    keypoints[i] = kp;
}
