// SPEC 4, first half: the 256-bin histogram of M8 = min(M, 255), per level.
// Mirrors src/cpu/histogram.rs. m -> hist[l * 256 + M8], all levels in one
// dispatch (over the tile list). `hist` is cleared by the pass before this runs.
//
// Each workgroup counts its tiles into workgroup-private bins, then adds each
// non-empty bin to the global histogram once (integer adds commute, so the
// result does not depend on the order).
// Tests: tests/gpu_edges_front.rs (this pass alone == src/cpu/histogram.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).

@group(0) @binding(1) var<storage, read> m: array<u32>;
@group(0) @binding(2) var<storage, read_write> hist: array<atomic<u32>>;

// Sub-histograms of the workgroup's COLUMN_TILES tiles (256 bins each: the
// tiles may belong to different levels). Zero at the start of the workgroup
// (WGSL zero-initialises workgroup memory).
var<workgroup> bins: array<atomic<u32>, 1024>;

// A column pass (tile_column): each invocation counts its column's 16 pixels,
// runs of equal values (flat regions) locally, into its tile's bins; after one
// barrier each invocation adds 16 of the bins to the global histogram.
@compute @workgroup_size(64, 1, 1)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let span = column_span(wg, li);
    let l = span.w;
    let sub = (li.x / TILE) * 256u;
    var run_v = 0u;
    var run_n = 0u;
    for (var y = span.y; y < span.z; y++) {
        let v = min(m[loff(l) + y * lw(l) + span.x], 255u);
        if (v != run_v && run_n != 0u) {
            atomicAdd(&bins[sub + run_v], run_n);
            run_n = 0u;
        }
        run_v = v;
        run_n += 1u;
    }
    if (run_n != 0u) { atomicAdd(&bins[sub + run_v], run_n); }
    workgroupBarrier();
    // Bins 16 li.x .. 16 li.x + 15 all belong to tile li.x / 16 of the workgroup.
    let t = workgroup_tile(wg, li.x / 16u);
    if (t.x == NO_TILE) { return; }
    for (var k = li.x * 16u; k < li.x * 16u + 16u; k++) {
        let c = atomicLoad(&bins[k]);
        if (c != 0u) { atomicAdd(&hist[t.z * 256u + k % 256u], c); }
    }
}
