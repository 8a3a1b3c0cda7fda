// SPEC 11: the rBRIEF descriptor on the smoothed level. Mirrors
// src/cpu/orb.rs (`describe`, `describe_continuous`). One invocation per final
// keypoint, dispatched indirectly over counters[KEYPOINTS] (64 per workgroup).
// Descriptor i is descriptors[8i .. 8i+8]: bit b of word k is pair 32k + b,
// so (little-endian) bit i of byte j is pair 8j + i and the buffer's bytes
// are the [u8; 32] descriptors.
// Tests: tests/gpu_levels.rs (this pass alone == src/cpu/orb.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).

const KEYPOINTS: u32 = 1u; // counter::KEYPOINTS
const PI: f32 = 3.14159265358979323846;

// `smoothed` is Buffers::smooth (`smooth` is a WGSL reserved word).
@group(0) @binding(1) var<storage, read> smoothed: array<u32>;
@group(0) @binding(2) var<storage, read> keypoints: array<Kp>;
@group(0) @binding(3) var<storage, read> counters: array<u32>;
// Per bin 256 pairs (x1, y1, x2, y2), pre-rotated to the bin's centre; with
// orientation_bins = 0 the one unrotated table.
@group(0) @binding(4) var<storage, read> patterns: array<vec4<i32>>;
@group(0) @binding(5) var<storage, read_write> descriptors: array<u32>;

fn px(l: u32, x: i32, y: i32) -> u32 { return smoothed[clamped(l, x, y)]; }

// OpenCV's per-keypoint rotation: x' = x cos - y sin, y' = x sin + y cos in
// f32, rounded half to even (WGSL round). The GPU's sin/cos may differ from
// the CPU's in the last bit, so a few bits of the descriptor may differ.
fn rotate(p: vec4<i32>, c: f32, s: f32) -> vec4<i32> {
    let f = vec4<f32>(p);
    return vec4<i32>(round(vec4(f.x * c - f.y * s, f.x * s + f.y * c, f.z * c - f.w * s, f.z * s + f.w * c)));
}

@compute @workgroup_size(64, 1, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if (i >= counters[KEYPOINTS] || i >= P.capacity) { return; }
    let kp = keypoints[i];
    if (kp.level >= P.n_levels) { return; }
    let l = kp.level;
    let x = i32(kp.px);
    let y = i32(kp.py);
    let continuous = P.orientation_bins == 0u;
    let base = select(min(kp.bin, P.orientation_bins - 1u), 0u, continuous) * 256u;
    let a = kp.angle * (PI / 180.0);
    let s = sin(a);
    let c = cos(a);
    for (var k = 0u; k < 8u; k++) {
        var word = 0u;
        for (var b = 0u; b < 32u; b++) {
            var p = patterns[base + 32u * k + b];
            if (continuous) { p = rotate(p, c, s); }
            let va = px(l, x + p.x, y + p.y);
            let vb = px(l, x + p.z, y + p.w);
            word |= select(0u, 1u, va < vb) << b;
        }
        descriptors[8u * i + k] = word;
    }
}
