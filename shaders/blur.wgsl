// SPEC 11: the 7x7 sigma-2 Gaussian (integer Q8 weights, BORDER_REFLECT_101)
// smoothing the levels before description. Mirrors src/cpu/blur.rs
// (`gaussian_blur_into`, `blur_any`): a horizontal pass to Q8 sums in
// `blur_tmp` (< 2^16, as the CPU's u16; two rows per word), then a vertical
// pass to Q16, rounded, into `smoothed` (column-packed, common.wgsl pk_word).
// All levels per dispatch (over the tile list): the horizontal pass takes 4x4
// blocks of tiles, the vertical one walks columns (shaders/common.wgsl).
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

// The seven taps over the four rows of packed words v0..v6 (byte r of each
// word is row r of its column).
fn taps4(v0: u32, v1: u32, v2: u32, v3: u32, v4: u32, v5: u32, v6: u32) -> vec4<u32> {
    return ORB_KERNEL[0] * pk_rows(v0) + ORB_KERNEL[1] * pk_rows(v1) + ORB_KERNEL[2] * pk_rows(v2)
        + ORB_KERNEL[3] * pk_rows(v3) + ORB_KERNEL[4] * pk_rows(v4) + ORB_KERNEL[5] * pk_rows(v5)
        + ORB_KERNEL[6] * pk_rows(v6);
}

// `blur_tmp` holds two rows of a column per word, row 2k in the low half of
// word loff(l) + k * w + x (the first half of the level's atlas range).
//
// Horizontal: each invocation takes four columns of one packed word row
// (four rows) of a tile: lane r of the tile's 16 has columns 4 (r % 4) .. + 4
// and rows 4 (r / 4) .. + 4, the seven taps' words in registers, so one gray
// word gives four rows' taps and two blur_tmp words take them.
@compute @workgroup_size(64, 1, 1)
fn horizontal(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let o = workgroup_tile(wg, li.x / TILE);
    if (o.x == NO_TILE) { return; }
    let l = o.z;
    let r = li.x % TILE;
    let x0 = o.x + 4u * (r % 4u);
    let y0 = o.y + 4u * (r / 4u);
    let w = lw(l);
    let h = lh(l);
    if (x0 >= w || y0 >= h) { return; }
    let iw = i32(w);
    let ix = i32(x0);
    var v0 = gray[pk_word(l, reflected(ix - 3, iw), y0)];
    var v1 = gray[pk_word(l, reflected(ix - 2, iw), y0)];
    var v2 = gray[pk_word(l, reflected(ix - 1, iw), y0)];
    var v3 = gray[pk_word(l, x0, y0)];
    var v4 = gray[pk_word(l, reflected(ix + 1, iw), y0)];
    var v5 = gray[pk_word(l, reflected(ix + 2, iw), y0)];
    let end = min(x0 + 4u, w);
    for (var x = x0; x < end; x++) {
        let v6 = gray[pk_word(l, reflected(i32(x) + 3, iw), y0)];
        let t = taps4(v0, v1, v2, v3, v4, v5, v6);
        let k = loff(l) + (y0 >> 1u) * w + x;
        blur_tmp[k] = t.x | (t.y << 16u);
        if (y0 + 2u < h) { blur_tmp[k + w] = t.z | (t.w << 16u); }
        v0 = v1; v1 = v2; v2 = v3; v3 = v4; v4 = v5; v5 = v6;
    }
}

// Row y of column x of `blur_tmp` (level l); `cw` caches the pair word of
// pair `cg` (the walk's rows move down, bar the reflected ones at the ends).
fn tmp_at(l: u32, x: u32, y: u32, cg: ptr<function, u32>, cw: ptr<function, u32>) -> u32 {
    if ((y >> 1u) != *cg) {
        *cw = blur_tmp[loff(l) + (y >> 1u) * lw(l) + x];
        *cg = y >> 1u;
    }
    return (*cw >> ((y & 1u) * 16u)) & 0xffffu;
}

// A column pass (tile_column): each invocation walks one column of a tile,
// a blur_tmp word per two rows, and writes `smoothed` column-packed.
@compute @workgroup_size(64, 1, 1)
fn vertical(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let id = tile_column(wg, li);
    let l = id.z;
    if (id.x >= lw(l) || id.y >= lh(l)) { return; }
    let h = i32(lh(l));
    let x = id.x;
    let y0 = i32(id.y);
    var cg = 0xffffffffu;
    var cw = 0u;
    var v0 = tmp_at(l, x, reflected(y0 - 3, h), &cg, &cw);
    var v1 = tmp_at(l, x, reflected(y0 - 2, h), &cg, &cw);
    var v2 = tmp_at(l, x, reflected(y0 - 1, h), &cg, &cw);
    var v3 = tmp_at(l, x, u32(y0), &cg, &cw);
    var v4 = tmp_at(l, x, reflected(y0 + 1, h), &cg, &cw);
    var v5 = tmp_at(l, x, reflected(y0 + 2, h), &cg, &cw);
    let end = u32(min(y0 + i32(TILE), h));
    var word = 0u;
    for (var y = id.y; y < end; y++) {
        let v6 = tmp_at(l, x, reflected(i32(y) + 3, h), &cg, &cw);
        word |= pk_place((taps(v0, v1, v2, v3, v4, v5, v6) + (1u << 15u)) >> 16u, y);
        if (pk_complete(y, end)) {
            smoothed[pk_word(l, x, y)] = word;
            word = 0u;
        }
        v0 = v1; v1 = v2; v2 = v3; v3 = v4; v4 = v5; v5 = v6;
    }
}
