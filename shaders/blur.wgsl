// SPEC 11: the 7x7 sigma-2 Gaussian (integer Q8 weights, BORDER_REFLECT_101)
// smoothing the levels before description. Mirrors src/cpu/blur.rs
// (`gaussian_blur_into`, `blur_any`): a horizontal pass to Q8 sums in
// `blur_tmp` (< 2^16, as the CPU's u16), then a vertical pass to Q16, rounded.
// All levels per dispatch (z = level).
// Tests: tests/gpu_levels.rs (this pass alone == src/cpu/blur.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).

@group(0) @binding(1) var<storage, read> gray: array<u32>;
@group(0) @binding(2) var<storage, read_write> blur_tmp: array<u32>;
// `smoothed` is Buffers::smooth (`smooth` is a WGSL reserved word).
@group(0) @binding(3) var<storage, read_write> smoothed: array<u32>;

// cpu::blur::ORB_KERNEL
const ORB_KERNEL: array<u32, 7> = array<u32, 7>(18u, 34u, 49u, 54u, 49u, 34u, 18u);
const R: i32 = 3;

// BORDER_REFLECT_101 index (gfedcb|abcdefgh|gfedcba); a 1-pixel axis clamps.
fn reflect101(i: i32, len: i32) -> i32 {
    if (len == 1) { return 0; }
    let period = 2 * (len - 1);
    var j = ((i % period) + period) % period; // rem_euclid
    if (j >= len) { j = period - j; }
    return j;
}

@compute @workgroup_size(16, 16, 1)
fn horizontal(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let id = tile_pixel(wg, li);
    let l = id.z;
    if (id.x >= lw(l) || id.y >= lh(l)) { return; }
    let w = i32(lw(l));
    let row = loff(l) + id.y * lw(l);
    var acc = 0u;
    for (var k = 0; k < 7; k++) {
        acc += ORB_KERNEL[k] * gray[row + u32(reflect101(i32(id.x) + k - R, w))];
    }
    blur_tmp[row + id.x] = acc;
}

@compute @workgroup_size(16, 16, 1)
fn vertical(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let id = tile_pixel(wg, li);
    let l = id.z;
    if (id.x >= lw(l) || id.y >= lh(l)) { return; }
    let h = i32(lh(l));
    var acc = 0u;
    for (var k = 0; k < 7; k++) {
        let yy = u32(reflect101(i32(id.y) + k - R, h));
        acc += ORB_KERNEL[k] * blur_tmp[loff(l) + yy * lw(l) + id.x];
    }
    smoothed[loff(l) + id.y * lw(l) + id.x] = (acc + (1u << 15u)) >> 16u;
}
