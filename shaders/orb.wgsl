// SPEC 11: the rBRIEF descriptor on the smoothed level. Mirrors
// src/cpu/orb.rs (`describe`, `describe_continuous`). One workgroup of 8
// invocations per final keypoint, dispatched indirectly
// (indirect::KEYPOINT_GROUPS: keypoint = wg.y * 65535 + wg.x); invocation k
// makes word k, pairs 32k..32k+31, and stores it: no workgroup memory, no
// barrier. (64 invocations of four pairs each, OR-ed into workgroup memory
// between two barriers, took 2.2 ms per KITTI frame on lavapipe, where every
// SIMD group of 8 of a workgroup with a barrier is a coroutine; this 1.4.)
// Descriptor i is descriptors[8i .. 8i+8]: bit b of word k is pair 32k + b,
// so (little-endian) bit i of byte j is pair 8j + i and the buffer's bytes
// are the [u8; 32] descriptors.
// With a snap (P.snap_radius > 0) and orientation bins, each sample is read
// between pixels at the keypoint's sub-pixel position (`fine_word`).
// Tests: tests/gpu_levels.rs (this pass alone == src/cpu/orb.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).
//
// Races: no atomics. Invocation k of keypoint i's workgroup stores word
// descriptors[8 i + k] only, so no two invocations write one word.

const PI: f32 = 3.14159265358979323846;

// `smoothed` is Buffers::smooth (`smooth` is a WGSL reserved word).
@group(0) @binding(1) var<storage, read> smoothed: array<u32>;
@group(0) @binding(2) var<storage, read> keypoints: array<Kp>;
@group(0) @binding(3) var<storage, read> counters: array<u32>;
// Per bin 256 pairs (x1, y1, x2, y2), pre-rotated to the bin's centre; with
// orientation_bins = 0 the one unrotated table.
// One word per pair: x1, y1, x2, y2 as i8 bytes, lowest first; four pairs
// are one vec4 (one load rather than sixteen).
@group(0) @binding(4) var<storage, read> patterns: array<vec4<u32>>;

// The pair (x1, y1, x2, y2) of a `patterns` word.
fn pair_of(w: u32) -> vec4<i32> {
    return vec4<i32>(bitcast<i32>(w << 24u), bitcast<i32>(w << 16u), bitcast<i32>(w << 8u), bitcast<i32>(w)) >> vec4<u32>(24u);
}
@group(0) @binding(5) var<storage, read_write> descriptors: array<u32>;

// Pixel (x, y) of level l, clamped into the level; `smoothed` is
// column-packed (common.wgsl pk_word).
fn px(l: u32, x: i32, y: i32) -> u32 {
    let c = clamped_xy(l, x, y);
    return pk_byte(smoothed[pk_word(l, c.x, c.y)], c.y);
}

// OpenCV's per-keypoint rotation: x' = x cos - y sin, y' = x sin + y cos in
// f32, rounded half to even (WGSL round). The GPU's sin/cos may differ from
// the CPU's in the last bit, so a few bits of the descriptor may differ.
fn rotate(p: vec4<i32>, c: f32, s: f32) -> vec4<i32> {
    let f = vec4<f32>(p);
    return vec4<i32>(round(vec4(f.x * c - f.y * s, f.x * s + f.y * c, f.z * c - f.w * s, f.z * s + f.w * c)));
}

@compute @workgroup_size(8, 1, 1)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    let i = wg.y * 65535u + wg.x;
    if (i >= counters[C_KEYPOINTS] || i >= P.capacity) { return; }
    let kp = keypoints[i];
    if (kp.level >= P.n_levels) { return; }
    if (P.snap_radius > 0u && P.orientation_bins > 0u) {
        descriptors[8u * i + lane] = fine_word(kp, lane);
    } else {
        descriptors[8u * i + lane] = describe_word(kp, lane);
    }
}

// With a snap, the descriptor at the keypoint's sub-pixel position
// (src/cpu/orb.rs `describe_fine`, docs/algorithm.md): the pixel moved by
// Kp.sub / 16 px, the pattern of the keypoint's bin in 1/16 px, each sample
// bilinear (`fine_sample`). The fine tables follow the whole-pixel ones in
// `patterns`: per bin 256 pairs of two words (x1 | y1 << 16, x2 | y2 << 16,
// i16 each), so 128 vec4 a bin, two pairs a vec4.
fn fine_word(kp: Kp, k: u32) -> u32 {
    let l = kp.level;
    let sx = bitcast<i32>(kp.sub << 24u) >> 24u;
    let sy = bitcast<i32>(kp.sub << 16u) >> 24u;
    let ox = i32(kp.px) * 16 + sx;
    let oy = i32(kp.py) * 16 + sy;
    let lv = Level(i32(lw(l)) - 1, i32(lh(l)) - 1, P.tiles[l].w, pk_pitch(l));
    let base = P.orientation_bins * 64u + min(kp.bin, P.orientation_bins - 1u) * 128u + 16u * k;
    var word = 0u;
    for (var q = 0u; q < 16u; q++) {
        let two = patterns[base + q];
        let bits = fine_bit(two.x, two.y, lv, ox, oy) | (fine_bit(two.z, two.w, lv, ox, oy) << 1u);
        word |= bits << (2u * q);
    }
    return word;
}

// What fine_sample needs of the keypoint's level, taken once a keypoint:
// its last column and row, and its packed words' offset and pitch
// (common.wgsl pk_word).
struct Level {
    xm: i32,
    ym: i32,
    base: u32,
    pitch: u32,
}

// The bit of one pair (its two words a, b) of the keypoint at (ox, oy) in 1/16 px.
fn fine_bit(a: u32, b: u32, lv: Level, ox: i32, oy: i32) -> u32 {
    let va = fine_sample(lv, ox + (bitcast<i32>(a << 16u) >> 16u), oy + (bitcast<i32>(a) >> 16u));
    let vb = fine_sample(lv, ox + (bitcast<i32>(b << 16u) >> 16u), oy + (bitcast<i32>(b) >> 16u));
    return select(0u, 1u, va < vb);
}

// 256 times the level's value at (qx, qy) in 1/16 px, bilinear over the
// pixels (qx, qy) >> 4 to one right and one down, reads clamped
// (src/cpu/orb.rs `sample_fine`): the two columns and two rows clamped once,
// each row's word offset once, four loads.
fn fine_sample(lv: Level, qx: i32, qy: i32) -> u32 {
    let ix = qx >> 4u;
    let iy = qy >> 4u;
    let fx = u32(qx & 15);
    let fy = u32(qy & 15);
    let x0 = u32(clamp(ix, 0, lv.xm));
    let x1 = u32(clamp(ix + 1, 0, lv.xm));
    let y0 = u32(clamp(iy, 0, lv.ym));
    let y1 = u32(clamp(iy + 1, 0, lv.ym));
    let r0 = lv.base + (y0 >> 2u) * lv.pitch;
    let r1 = lv.base + (y1 >> 2u) * lv.pitch;
    let top = pk_byte(smoothed[r0 + x0], y0) * (16u - fx) + pk_byte(smoothed[r0 + x1], y0) * fx;
    let bottom = pk_byte(smoothed[r1 + x0], y1) * (16u - fx) + pk_byte(smoothed[r1 + x1], y1) * fx;
    return top * (16u - fy) + bottom * fy;
}

// Word k of keypoint kp's descriptor: pairs 32 k .. 32 k + 31.
fn describe_word(kp: Kp, k: u32) -> u32 {
    let l = kp.level;
    let x = i32(kp.px);
    let y = i32(kp.py);
    let continuous = P.orientation_bins == 0u;
    let base = select(min(kp.bin, P.orientation_bins - 1u), 0u, continuous) * 256u;
    let a = kp.angle * (PI / 180.0);
    let s = sin(a);
    let c = cos(a);
    var word = 0u;
    for (var q = 0u; q < 8u; q++) {
        let four = patterns[(base >> 2u) + 8u * k + q];
        let bits = pair_bit(four.x, l, x, y, c, s, continuous) | (pair_bit(four.y, l, x, y, c, s, continuous) << 1u)
            | (pair_bit(four.z, l, x, y, c, s, continuous) << 2u) | (pair_bit(four.w, l, x, y, c, s, continuous) << 3u);
        word |= bits << (4u * q);
    }
    return word;
}

// The bit of one pair (its `patterns` word w) of the keypoint at (x, y) of
// level l: 1 iff the first point is darker than the second.
fn pair_bit(w: u32, l: u32, x: i32, y: i32, c: f32, s: f32, continuous: bool) -> u32 {
    var p = pair_of(w);
    if (continuous) { p = rotate(p, c, s); }
    let va = px(l, x + p.x, y + p.y);
    let vb = px(l, x + p.z, y + p.w);
    return select(0u, 1u, va < vb);
}
