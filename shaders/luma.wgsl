// SPEC 0: the input as 8-bit gray into level 0 of `gray`. Mirrors
// src/image.rs (`luma_bt601`, `to_gray`).
// `gray` is column-packed (common.wgsl pk_word). Two entry points over level
// 0, one invocation per packed word (four rows of one column; dispatch
// FrameLayout::packed_level_groups):
// - from_bytes: `input` holds the gray bytes, four pixels per word,
//   little-endian, row-major, no row padding (the host's queue.write_buffer).
// - from_texture: an Rgba8Unorm / Bgra8Unorm / R8Unorm texture. Each unorm
//   value is the byte v / 255, so round(v * 255) recovers the byte exactly;
//   then OpenCV's integer BT.601 (alpha ignored). `tex_kind.x` = 1 marks a
//   one-channel texture: its red channel is the gray value itself.
// Tests: tests/gpu_levels.rs (this pass alone == src/cpu/luma.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).

@group(0) @binding(1) var<storage, read> input: array<u32>;
@group(0) @binding(2) var<storage, read_write> gray: array<u32>;
@group(0) @binding(3) var tex: texture_2d<f32>;
@group(0) @binding(4) var<uniform> tex_kind: vec4<u32>;

// Y = (4899 R + 9617 G + 1868 B + 8192) >> 14, as lfast::image::luma_bt601.
fn luma_bt601(r: u32, g: u32, b: u32) -> u32 {
    return (4899u * r + 9617u * g + 1868u * b + 8192u) >> 14u;
}

fn unorm_byte(v: f32) -> u32 { return u32(round(clamp(v, 0.0, 1.0) * 255.0)); }

@compute @workgroup_size(16, 16, 1)
fn from_bytes(@builtin(global_invocation_id) id: vec3<u32>) {
    let y0 = id.y * 4u;
    if (id.x >= lw(0u) || y0 >= lh(0u)) { return; }
    // the four rows written out (a loop costs a SIMD software rasteriser its
    // masks every iteration); rows past the last read it again, and add 0
    let word = input_row(id.x, y0) | input_row(id.x, y0 + 1u) | input_row(id.x, y0 + 2u) | input_row(id.x, y0 + 3u);
    gray[pk_word(0u, id.x, y0)] = word;
}

// Byte (x, y) of the row-major input in its place in the packed word, 0 for
// y past the last row.
fn input_row(x: u32, y: u32) -> u32 {
    let i = min(y, lh(0u) - 1u) * lw(0u) + x;
    return select(0u, pk_place((input[i >> 2u] >> (8u * (i & 3u))) & 255u, y), y < lh(0u));
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
