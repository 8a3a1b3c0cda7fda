// The M8 counting of the per-level histogram (SPEC 4), shared by histogram.wgsl
// and gradient_nms.wgsl: src/gpu/histogram.rs and src/gpu/gradient_nms.rs append
// this file to their shader, which declares `hist` (256 bins per level, cleared
// by the pass before it runs). One definition, so the two cannot drift.
//
// A column pass's workgroup counts into one 256-bin sub-histogram per level
// among its COLUMN_TILES tiles (consecutive in the tile list, so mostly all of
// one level; up to COLUMN_TILES levels where levels are a tile or two), zero
// at the start of the workgroup (WGSL zero-initialises workgroup memory); runs
// of equal values along a column (flat regions) are counted locally and added
// once. After one barrier each non-empty bin is added to the global histogram
// once (integer adds commute, so the result does not depend on the order).

var<workgroup> bins: array<atomic<u32>, 1024>;

// The sub-histogram (256 * its index) of this invocation's tile: the tile's
// level less the level of the workgroup's first tile (levels never decrease
// along the list). 0 past the last tile (such an invocation counts nothing).
fn m8_sub(wg: vec3<u32>, li: vec3<u32>) -> u32 {
    let t = workgroup_tile(wg, li.x / TILE);
    if (t.x == NO_TILE) { return 0u; }
    return (t.z - workgroup_tile(wg, 0u).z) * 256u;
}

// Counts M8 value `v` into `run` (value, length): the run goes to
// sub-histogram `sub` (m8_sub) when the value changes.
fn count_m8(run: ptr<function, vec2<u32>>, sub: u32, v: u32) {
    if (v != (*run).x && (*run).y != 0u) {
        atomicAdd(&bins[sub + (*run).x], (*run).y);
        (*run).y = 0u;
    }
    (*run).x = v;
    (*run).y += 1u;
}

// Ends the count of every invocation of workgroup `wg` (call from uniform
// control flow): the last run, one barrier, then the bins of the workgroup's
// sub-histograms (those of levels first .. last of its tiles), side by side
// over the invocations, into `hist`.
fn flush_m8(wg: vec3<u32>, li: vec3<u32>, sub: u32, run: vec2<u32>) {
    if (run.y != 0u) { atomicAdd(&bins[sub + run.x], run.y); }
    workgroupBarrier();
    let first = workgroup_tile(wg, 0u);
    if (first.x == NO_TILE) { return; }
    var last = first.z;
    for (var k = 1u; k < COLUMN_TILES; k++) {
        let t = workgroup_tile(wg, k);
        if (t.x != NO_TILE) { last = t.z; }
    }
    for (var k = li.x; k < (last - first.z + 1u) * 256u; k += 64u) {
        let c = atomicLoad(&bins[k]);
        if (c != 0u) { atomicAdd(&hist[first.z * 256u + k], c); }
    }
}
