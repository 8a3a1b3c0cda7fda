// The M8 counting of the per-level histogram (SPEC 4), shared by histogram.wgsl
// and gradient_nms.wgsl: src/gpu/histogram.rs and src/gpu/gradient_nms.rs append
// this file to their shader, which declares `hist` (256 bins per level, cleared
// by the pass before it runs). One definition, so the two cannot drift.
//
// A column pass's workgroup counts into one 256-bin sub-histogram per tile
// (its COLUMN_TILES tiles may belong to different levels), zero at the start of
// the workgroup (WGSL zero-initialises workgroup memory); runs of equal values
// along a column (flat regions) are counted locally and added once. After one
// barrier each non-empty bin is added to the global histogram once (integer
// adds commute, so the result does not depend on the order).

var<workgroup> bins: array<atomic<u32>, 1024>;

// Counts M8 value `v` into `run` (value, length): the run goes to
// sub-histogram `sub` (256 * tile of the workgroup) when the value changes.
fn count_m8(run: ptr<function, vec2<u32>>, sub: u32, v: u32) {
    if (v != (*run).x && (*run).y != 0u) {
        atomicAdd(&bins[sub + (*run).x], (*run).y);
        (*run).y = 0u;
    }
    (*run).x = v;
    (*run).y += 1u;
}

// Ends the count of every invocation of workgroup `wg` (call from uniform
// control flow): the last run, one barrier, then bins 16 li.x .. 16 li.x + 15,
// all of tile li.x / 16 of the workgroup, into `hist`.
fn flush_m8(wg: vec3<u32>, li: vec3<u32>, run: vec2<u32>) {
    if (run.y != 0u) { atomicAdd(&bins[(li.x / TILE) * 256u + run.x], run.y); }
    workgroupBarrier();
    let t = workgroup_tile(wg, li.x / 16u);
    if (t.x == NO_TILE) { return; }
    for (var k = li.x * 16u; k < li.x * 16u + 16u; k++) {
        let c = atomicLoad(&bins[k]);
        if (c != 0u) { atomicAdd(&hist[t.z * 256u + k % 256u], c); }
    }
}
