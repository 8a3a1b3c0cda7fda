// SPEC 4, first half: the 256-bin histogram of M8 = min(M, 255), per level.
// Mirrors src/cpu/histogram.rs. m (M8, column-packed, common.wgsl pk_word) ->
// hist[l * 256 + M8], all levels in one
// dispatch (over the tile list). `hist` is cleared by the pass before this runs.
// The counting itself is shaders/histogram_bins.wgsl, shared with gradient_nms.wgsl.
// Tests: tests/gpu_edges_front.rs (this pass alone == src/cpu/histogram.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).

@group(0) @binding(1) var<storage, read> m: array<u32>;
@group(0) @binding(2) var<storage, read_write> hist: array<atomic<u32>>;

// A column pass (tile_column): each invocation counts its column's 16 pixels
// (histogram_bins.wgsl, appended to this shader).
@compute @workgroup_size(64, 1, 1)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let span = column_span(wg, li);
    let l = span.w;
    let sub = m8_sub(wg, li);
    var run = vec2<u32>(0u);
    var word = 0u;
    for (var y = span.y; y < span.z; y++) {
        if ((y & 3u) == 0u) { word = m[pk_word(l, span.x, y)]; }
        count_m8(&run, sub, pk_byte(word, y));
    }
    flush_m8(wg, li, sub, run);
}
