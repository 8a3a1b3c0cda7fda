// Brute-force Hamming matcher with ratio test and cross-check (not a SPEC
// stage; used by visual odometry). Mirrors src/cpu/matcher.rs: same scan
// order and strict comparisons, so ties go to the lowest index and the
// results are identical.
//
// Descriptors are 8 u32 words each (the 32 bytes little-endian). One query
// (or train, for the backward scan) per invocation; the other set is walked
// in tiles of MATCH_TILE descriptors staged in workgroup memory, each invocation of
// the workgroup loading one descriptor of the tile. `P` (the common prelude's
// uniform) is declared but unused here.
// Tests: tests/gpu_matcher.rs (this pass alone == src/cpu/matcher.rs); tests/gpu_shaders.rs (naga, bindings).
//
// Races: tile[li * WORDS ..] is written by lane li only, between two barriers
// that every lane reaches (uniform loop bounds); fwd[i], back[j] and
// matches[i] by invocation i (j) only.

struct MatchParams {
    n_query: u32,
    n_train: u32,
    ratio_q16: u32,     // 0 = no ratio test; else keep d1 * 65536 < ratio_q16 * d2
    max_distance: u32,
    cross_check: u32,   // 0 or 1
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

const MATCH_TILE: u32 = 64u;
const WORDS: u32 = 8u;
const NO_INDEX: u32 = 0xffffffffu;
const NO_DISTANCE: u32 = 0xffffffffu;

@group(0) @binding(1) var<uniform> M: MatchParams;
@group(0) @binding(2) var<storage, read> query: array<u32>;
@group(0) @binding(3) var<storage, read> train: array<u32>;
// per query: best train, d1, d2, (unused)
@group(0) @binding(4) var<storage, read_write> fwd: array<vec4<u32>>;
// per train: best query (the cross-check's backward scan)
@group(0) @binding(5) var<storage, read_write> back: array<u32>;
// per query: train index or NO_INDEX, distance
@group(0) @binding(6) var<storage, read_write> matches: array<vec2<u32>>;

var<workgroup> tile: array<u32, 512>; // MATCH_TILE * WORDS

fn dist(a: array<u32, 8>, k: u32) -> u32 {
    var d = 0u;
    for (var w = 0u; w < WORDS; w++) {
        d += countOneBits(a[w] ^ tile[k * WORDS + w]);
    }
    return d;
}

// forward scan: each query against every train descriptor, in train order
@compute @workgroup_size(64, 1, 1)
fn forward(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let i = gid.x;
    let live = i < M.n_query;
    var a: array<u32, 8>;
    if (live) {
        for (var w = 0u; w < WORDS; w++) { a[w] = query[i * WORDS + w]; }
    }
    var best = NO_INDEX;
    var d1 = NO_DISTANCE;
    var d2 = NO_DISTANCE;
    // the loop bounds are uniform, so every invocation reaches the barriers
    for (var base = 0u; base < M.n_train; base += MATCH_TILE) {
        let j = base + li;
        if (j < M.n_train) {
            for (var w = 0u; w < WORDS; w++) { tile[li * WORDS + w] = train[j * WORDS + w]; }
        }
        workgroupBarrier();
        let count = min(MATCH_TILE, M.n_train - base);
        for (var k = 0u; k < count; k++) {
            let d = dist(a, k);
            // strict: an equal distance later in the order never wins
            if (d < d1) {
                d2 = d1;
                d1 = d;
                best = base + k;
            } else if (d < d2) {
                d2 = d;
            }
        }
        workgroupBarrier();
    }
    if (live) { fwd[i] = vec4<u32>(best, d1, d2, 0u); }
}

// backward scan for the cross-check: each train against every query
@compute @workgroup_size(64, 1, 1)
fn backward(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let j = gid.x;
    let live = j < M.n_train;
    var a: array<u32, 8>;
    if (live) {
        for (var w = 0u; w < WORDS; w++) { a[w] = train[j * WORDS + w]; }
    }
    var best = NO_INDEX;
    var d1 = NO_DISTANCE;
    for (var base = 0u; base < M.n_query; base += MATCH_TILE) {
        let i = base + li;
        if (i < M.n_query) {
            for (var w = 0u; w < WORDS; w++) { tile[li * WORDS + w] = query[i * WORDS + w]; }
        }
        workgroupBarrier();
        let count = min(MATCH_TILE, M.n_query - base);
        for (var k = 0u; k < count; k++) {
            let d = dist(a, k);
            if (d < d1) {
                d1 = d;
                best = base + k;
            }
        }
        workgroupBarrier();
    }
    if (live) { back[j] = best; }
}

// the tests of src/cpu/matcher.rs `passes` and the cross-check, per query
@compute @workgroup_size(64, 1, 1)
fn combine(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if (i >= M.n_query) { return; }
    let n = fwd[i];
    var ok = n.x != NO_INDEX && n.y <= M.max_distance;
    // d1, d2 <= 256 and ratio_q16 <= 65536: the products fit in u32
    if (ok && M.ratio_q16 != 0u && n.z != NO_DISTANCE) {
        ok = n.y * 65536u < M.ratio_q16 * n.z;
    }
    if (ok && M.cross_check != 0u) {
        ok = back[n.x] == i;
    }
    matches[i] = vec2<u32>(select(NO_INDEX, n.x, ok), n.y);
}
