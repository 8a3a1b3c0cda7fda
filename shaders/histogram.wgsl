// SPEC 4, first half: the 256-bin histogram of M8 = min(M, 255), per level.
// Mirrors src/cpu/histogram.rs. m -> hist[l * 256 + M8], all levels in one
// dispatch (over the tile list). `hist` is cleared by the pass before this runs.
//
// Each workgroup counts its 16x16 tile into workgroup-private bins, then adds
// each non-empty bin to the global histogram once (integer adds commute, so
// the result does not depend on the order).
// Tests: tests/gpu_edges_front.rs (this pass alone == src/cpu/histogram.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).

@group(0) @binding(1) var<storage, read> m: array<u32>;
@group(0) @binding(2) var<storage, read_write> hist: array<atomic<u32>>;

var<workgroup> bins: array<atomic<u32>, 256>;

@compute @workgroup_size(16, 16, 1)
fn main(
    @builtin(local_invocation_id) lid: vec3<u32>,
    @builtin(local_invocation_index) li: u32,
    @builtin(workgroup_id) wg: vec3<u32>,
) {
    let id = tile_pixel(wg, lid);
    let l = id.z;
    // A padding workgroup of the tile list: workgroup-uniform, so the
    // barriers below are still reached by all or none.
    if (wg.x + wg.y * P.tile_row >= P.total_tiles) { return; }
    atomicStore(&bins[li], 0u);
    workgroupBarrier();
    if (id.x < lw(l) && id.y < lh(l)) {
        let v = min(m[loff(l) + id.y * lw(l) + id.x], 255u);
        atomicAdd(&bins[v], 1u);
    }
    workgroupBarrier();
    let c = atomicLoad(&bins[li]);
    if (c != 0u) {
        atomicAdd(&hist[l * 256u + li], c);
    }
}
