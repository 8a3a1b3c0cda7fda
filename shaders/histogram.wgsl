// SPEC 4, first half: the 256-bin histogram of M8 = min(M, 255), per level.
// Mirrors src/cpu/histogram.rs. m (M8, column-packed, common.wgsl pk_word) ->
// hist[l * 256 + M8], all levels in one
// dispatch (over the tile list). `hist` is cleared by the pass before this runs.
// The pipeline counts the histogram in local_threshold.wgsl's cells (SPEC 5
// counts every pixel anyway); this pass is the per-stage reference the tests
// compare it with.
// Tests: tests/gpu_edges_front.rs (this pass alone == src/cpu/histogram.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).
//
// Races: every shared word (the workgroup's bins and the level histograms) is
// written with atomicAdd only; the m words are only read.

@group(0) @binding(1) var<storage, read> m: array<u32>;
@group(0) @binding(2) var<storage, read_write> hist: array<atomic<u32>>;

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

// A column pass (tile_column): each invocation counts its column's 16 pixels.
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
