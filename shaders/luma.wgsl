// SPEC 0: the input as 8-bit gray into level 0 of `gray`. Mirrors
// src/image.rs (`luma_bt601`, `to_gray`).
// `gray` is column-packed (common.wgsl pk_word). Two entry points over level
// 0:
// - from_bytes: `input` holds the gray bytes, four pixels per word,
//   little-endian, row-major, no row padding (the host's queue.write_buffer).
//   One invocation per four packed words (four rows of four columns; dispatch
//   FrameLayout::quad_level_words): two input words per row give the four
//   columns' bytes, transposed into four column words (12 accesses for 16
//   pixels where a word per invocation made 20: 0.64 -> 0.43 ms per KITTI
//   frame on lavapipe).
// - from_texture: one invocation per packed word (four rows of one column;
//   dispatch FrameLayout::packed_level_groups), from an Rgba8Unorm /
//   Bgra8Unorm / R8Unorm texture. Each unorm
//   value is the byte v / 255, so round(v * 255) recovers the byte exactly;
//   then OpenCV's integer BT.601 (alpha ignored). `tex_kind.x` = 1 marks a
//   one-channel texture: its red channel is the gray value itself.
// Tests: tests/gpu_levels.rs (this pass alone == src/cpu/luma.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).
//
// Races: no atomics. from_bytes: each invocation stores its own four packed
// words (four rows of four columns: one word per column); from_texture: its own
// one word. The words of different invocations are distinct (common.wgsl
// pk_word), so no two invocations write one word.

@group(0) @binding(1) var<storage, read> input: array<u32>;
@group(0) @binding(2) var<storage, read_write> gray: array<u32>;
@group(0) @binding(3) var tex: texture_2d<f32>;
@group(0) @binding(4) var<uniform> tex_kind: vec4<u32>;

// Y = (19596 R + 38470 G + 7470 B + 32768) >> 16, as lfast::image::luma_bt601
// (OpenCV 4.x/5.x cvtColor BGR2GRAY; at most 65536 * 255 + 32768 < 2^32).
fn luma_bt601(r: u32, g: u32, b: u32) -> u32 {
    return (19596u * r + 38470u * g + 7470u * b + 32768u) >> 16u;
}

fn unorm_byte(v: f32) -> u32 { return u32(round(clamp(v, 0.0, 1.0) * 255.0)); }

@compute @workgroup_size(16, 16, 1)
fn from_bytes(@builtin(global_invocation_id) id: vec3<u32>) {
    let x0 = id.x * 4u;
    let y0 = id.y * 4u;
    let w = lw(0u);
    if (x0 >= w || y0 >= lh(0u)) { return; }
    // the four rows written out (a loop costs a SIMD software rasteriser its
    // masks every iteration); rows past the last read it again, and add 0
    let r0 = input_row(x0, y0);
    let r1 = input_row(x0, y0 + 1u);
    let r2 = input_row(x0, y0 + 2u);
    let r3 = input_row(x0, y0 + 3u);
    // column k's word: byte k of each row, row r in byte r
    let m = vec4<u32>(0xffu);
    let sh = vec4<u32>(0u, 8u, 16u, 24u);
    let words = ((vec4<u32>(r0) >> sh) & m) | (((vec4<u32>(r1) >> sh) & m) << vec4<u32>(8u))
        | (((vec4<u32>(r2) >> sh) & m) << vec4<u32>(16u)) | (((vec4<u32>(r3) >> sh) & m) << vec4<u32>(24u));
    let i = pk_word(0u, x0, y0);
    gray[i] = words.x;
    if (x0 + 1u < w) { gray[i + 1u] = words.y; }
    if (x0 + 2u < w) { gray[i + 2u] = words.z; }
    if (x0 + 3u < w) { gray[i + 3u] = words.w; }
}

// Bytes x .. x + 3 of row y of the row-major input (byte k: column x + k;
// columns past the row's end are the next row's, never stored), 0 for y
// past the last row: two input words, the second clamped to the last.
fn input_row(x: u32, y: u32) -> u32 {
    let i = min(y, lh(0u) - 1u) * lw(0u) + x;
    let last = (lw(0u) * lh(0u) - 1u) >> 2u;
    let lo = input[i >> 2u];
    let hi = input[min((i >> 2u) + 1u, last)];
    let s = (i & 3u) * 8u;
    let v = select((lo >> s) | (hi << (32u - s)), lo, s == 0u);
    return select(0u, v, y < lh(0u));
}

@compute @workgroup_size(16, 16, 1)
fn from_texture(@builtin(global_invocation_id) id: vec3<u32>) {
    let y0 = id.y * 4u;
    if (id.x >= lw(0u) || y0 >= lh(0u)) { return; }
    var word = 0u;
    for (var y = y0; y < min(y0 + 4u, lh(0u)); y++) {
        // textureLoad returns the channels in logical order, so Bgra8Unorm
        // reads as RGBA too.
        let v = textureLoad(tex, vec2<u32>(id.x, y), 0);
        var g = unorm_byte(v.r);
        if (tex_kind.x == 0u) {
            g = luma_bt601(unorm_byte(v.r), unorm_byte(v.g), unorm_byte(v.b));
        }
        word |= pk_place(g, y);
    }
    gray[pk_word(0u, id.x, y0)] = word;
}
