// SPEC 11: the 7x7 sigma-2 Gaussian (integer Q8 weights, BORDER_REFLECT_101)
// smoothing the levels before description. Mirrors src/cpu/blur.rs
// (`gaussian_blur_into`, `blur_any`): a horizontal pass to Q8 sums in
// `blur_tmp` (< 2^16, as the CPU's u16), then a vertical pass to Q16, rounded.
// All levels per dispatch (over the tile list): the horizontal pass walks
// rows of tiles, the vertical one columns (shaders/common.wgsl).
// Tests: tests/gpu_levels.rs (this pass alone == src/cpu/blur.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).

// `gray` is column-packed (common.wgsl pk_word).
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

// reflect101, cheap inside [0, len).
fn reflected(i: i32, len: i32) -> u32 {
    if (i >= 0 && i < len) { return u32(i); }
    return u32(reflect101(i, len));
}

// The seven taps of ORB_KERNEL over v0..v6.
fn taps(v0: u32, v1: u32, v2: u32, v3: u32, v4: u32, v5: u32, v6: u32) -> u32 {
    return ORB_KERNEL[0] * v0 + ORB_KERNEL[1] * v1 + ORB_KERNEL[2] * v2 + ORB_KERNEL[3] * v3
        + ORB_KERNEL[4] * v4 + ORB_KERNEL[5] * v5 + ORB_KERNEL[6] * v6;
}

// Pixel (x, y) of level l of `gray`.
fn gray_at(l: u32, x: u32, y: u32) -> u32 { return pk_byte(gray[pk_word(l, x, y)], y); }

// A row pass (tile_row_segment): each invocation walks one row of a tile,
// the seven taps in registers (one read per pixel instead of seven).
@compute @workgroup_size(64, 1, 1)
fn horizontal(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let id = tile_row_segment(wg, li);
    let l = id.z;
    if (id.x >= lw(l) || id.y >= lh(l)) { return; }
    let w = i32(lw(l));
    let y = id.y;
    let row = loff(l) + y * lw(l);
    let x0 = i32(id.x);
    var v0 = gray_at(l, reflected(x0 - 3, w), y);
    var v1 = gray_at(l, reflected(x0 - 2, w), y);
    var v2 = gray_at(l, reflected(x0 - 1, w), y);
    var v3 = gray_at(l, u32(x0), y);
    var v4 = gray_at(l, reflected(x0 + 1, w), y);
    var v5 = gray_at(l, reflected(x0 + 2, w), y);
    let end = min(x0 + i32(TILE), w);
    for (var x = x0; x < end; x++) {
        let v6 = gray_at(l, reflected(x + 3, w), y);
        blur_tmp[row + u32(x)] = taps(v0, v1, v2, v3, v4, v5, v6);
        v0 = v1; v1 = v2; v2 = v3; v3 = v4; v4 = v5; v5 = v6;
    }
}

// A column pass (tile_column): each invocation walks one column of a tile.
@compute @workgroup_size(64, 1, 1)
fn vertical(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let id = tile_column(wg, li);
    let l = id.z;
    if (id.x >= lw(l) || id.y >= lh(l)) { return; }
    let h = i32(lh(l));
    let w = lw(l);
    let col = loff(l) + id.x;
    let y0 = i32(id.y);
    var v0 = blur_tmp[col + reflected(y0 - 3, h) * w];
    var v1 = blur_tmp[col + reflected(y0 - 2, h) * w];
    var v2 = blur_tmp[col + reflected(y0 - 1, h) * w];
    var v3 = blur_tmp[col + u32(y0) * w];
    var v4 = blur_tmp[col + reflected(y0 + 1, h) * w];
    var v5 = blur_tmp[col + reflected(y0 + 2, h) * w];
    let end = min(y0 + i32(TILE), h);
    for (var y = y0; y < end; y++) {
        let v6 = blur_tmp[col + reflected(y + 3, h) * w];
        smoothed[col + u32(y) * w] = (taps(v0, v1, v2, v3, v4, v5, v6) + (1u << 15u)) >> 16u;
        v0 = v1; v1 = v2; v2 = v3; v3 = v4; v4 = v5; v5 = v6;
    }
}
