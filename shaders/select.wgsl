// SPEC 9: the n_features cap and the deterministic output order. Mirrors
// src/cpu/select.rs (select with distribution = false; the quadtree is not
// done on the GPU). `corners` (unordered, counters[CORNERS] of them) ->
// `keypoints` in SPEC 9 order: response descending (f32 total order), then
// level, y, x ascending.
//
// Entry points, in recording order:
// - args (1 invocation): indirect args over the corner list, resets TAKEN and
//   the key range.
// - rank_level (indirect, 64 per group): each corner counts the corners of its
//   level that precede it; it is "taken" iff that count < quota(level) (a level
//   keeps its best up to its quota). No cap (n_features = 0): all are taken.
//   Each corner writes its record (key, taken, position) to `ranks`, and the
//   group folds its responses' magnitudes into the frame's range (counters
//   MAG_MAX, MAG_MIN).
// - count (indirect): each corner adds itself to its bucket and, when taken,
//   to its bucket's taken count. bucket_of spreads the magnitudes that occur
//   (both signs: Harris responses of L-FAST corners are about half negative,
//   from ~1e-12 to ~1e-2 either side) over the BUCKETS buckets, positives
//   first, larger magnitudes first, then negatives, smaller first: buckets
//   ascend as keys descend, so every corner of a lower bucket precedes every
//   corner of a higher one. (The top 12 bits of the order key, sign and
//   exponent, gave 8 buckets an octave, and the key range between a frame's
//   extreme keys still holds every exponent between ~1e-2 and 0 either side.)
// - scan (one workgroup): exclusive prefix sums of both counts over the buckets.
// - scatter (indirect): each corner copies its record into a slot of its
//   bucket's range of `members` (in any order).
// - place (indirect): each corner counts the taken (T) and not taken (U)
//   corners that precede it: those of lower buckets from the prefix sums, those
//   of its own bucket by comparing with the bucket's members (one contiguous
//   record each: key, taken and position, no indirection). The not-taken
//   corners that fill the spare quota are the first `spare` of them in order,
//   so a corner is selected iff it is taken or U < spare, and its output index
//   is T + min(U, spare).
// - finish (1 invocation): the final count, indirect args (64 keypoints per
//   group, and one keypoint per group) and draw args.
// rank_level is O(n^2) over the corner list (tiled through workgroup memory)
// only under a cap; place is O(n * bucket size), and the buckets split the
// magnitudes' actual range 4096 ways. Positions are unique, so the order is total
// and the output deterministic.
//
// Races: every plain (non-atomic) store goes to a word only one invocation
// owns: ranks[i] by corner i; members[slot] by the corner whose atomicAdd on
// its bucket's cursor returned that slot; keypoints[at] by the corner whose
// rank is `at` (ranks are distinct, the order being total); indirect and the
// counters' stores by the single invocation of args / finish; scan_sums[li]
// and each bucket's prefix words by lane li of the one scan workgroup, between
// barriers; tile_* [li] by lane li between barriers; wg_n, wg_max, wg_min by
// lane 0 (or through atomics); `blur_tiles` words with atomicStore of 1 only
// (the pass's prepare clears them): any order leaves the same marks.
//
// `place` also marks, for blur.wgsl, the 16x16 tiles of each placed
// keypoint's level that hold a pixel its descriptor reads: those within
// DESC_REACH (spec::pattern::descriptor_reach) of the keypoint's pixel,
// clamped into the level as orb.wgsl's reads are (~60% of a KITTI frame's
// tiles). (Marked in orientation, which then had to run before blur, its
// reads of the level missed the cache blur had filled: +0.3 ms a frame.)
// Tests: tests/gpu_keypoints.rs (this pass alone == src/cpu/select.rs),
// tests/gpu_blur_tiles.rs (the marks, by hand and against the host's) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).

@group(0) @binding(1) var<storage, read> corners: array<Kp>;
@group(0) @binding(2) var<storage, read_write> counters: array<atomic<u32>>;
// Per corner its record: order key, taken (0/1), level, y << 16 | x.
@group(0) @binding(3) var<storage, read_write> ranks: array<vec4<u32>>;
@group(0) @binding(4) var<storage, read_write> keypoints: array<Kp>;
@group(0) @binding(5) var<storage, read_write> indirect: array<u32>;
// BUCKETS words each: count, taken, corners before the bucket, taken corners
// before the bucket, slots claimed (cleared by the pass before it runs).
@group(0) @binding(6) var<storage, read_write> buckets: array<atomic<u32>>;
// The records of each bucket's corners, bucket by bucket (its range starts at
// the bucket's corners-before count).
@group(0) @binding(7) var<storage, read_write> members: array<vec4<u32>>;
// A word per tile of the tile list (common.wgsl tile_origin): 1 = blur it.
@group(0) @binding(8) var<storage, read_write> blur_tiles: array<atomic<u32>>;

// Marks the tiles of level l holding a pixel within DESC_REACH of (x, y),
// clamped into the level: at most 4 x 4 tiles for a reach up to 24
// (tests/gpu_blur_tiles.rs checks DESC_REACH against it), stored
// straight-line, the columns and rows past the last repeating it (nested
// loops bounded per lane cost lavapipe ~0.07 ms a KITTI frame more).
fn mark_tiles(l: u32, x: i32, y: i32) {
    let xm = i32(lw(l)) - 1;
    let ym = i32(lh(l)) - 1;
    let tx0 = u32(clamp(x - DESC_REACH, 0, xm)) / TILE;
    let tx1 = u32(clamp(x + DESC_REACH, 0, xm)) / TILE;
    let ty0 = u32(clamp(y - DESC_REACH, 0, ym)) / TILE;
    let ty1 = u32(clamp(y + DESC_REACH, 0, ym)) / TILE;
    let t = P.tiles[l];
    let cols = t.x + min(vec4<u32>(tx0) + vec4<u32>(0u, 1u, 2u, 3u), vec4<u32>(tx1));
    let rows = min(vec4<u32>(ty0) + vec4<u32>(0u, 1u, 2u, 3u), vec4<u32>(ty1)) * t.y;
    mark_row(cols + rows.x);
    mark_row(cols + rows.y);
    mark_row(cols + rows.z);
    mark_row(cols + rows.w);
}

fn mark_row(c: vec4<u32>) {
    atomicStore(&blur_tiles[c.x], 1u);
    atomicStore(&blur_tiles[c.y], 1u);
    atomicStore(&blur_tiles[c.z], 1u);
    atomicStore(&blur_tiles[c.w], 1u);
}

// gpu::select::BUCKETS = 1 << BUCKET_BITS.
const BUCKET_BITS: u32 = 12u;
const BUCKETS: u32 = 1u << BUCKET_BITS;
const B_COUNT: u32 = 0u;
const B_TAKEN: u32 = BUCKETS;
const B_BEFORE: u32 = 2u * BUCKETS;
const B_TAKEN_BEFORE: u32 = 3u * BUCKETS;
const B_CURSOR: u32 = 4u * BUCKETS;

// indirect::* in src/gpu/buffers.rs, in words.
const I_CORNERS: u32 = 0u;
const I_KEYPOINTS: u32 = 4u;
const I_DRAW: u32 = 8u;
const I_KEYPOINT_GROUPS: u32 = 12u;
// max_compute_workgroups_per_dimension's guaranteed minimum.
const MAX_GROUPS: u32 = 65535u;

const GROUP: u32 = 64u;

// Corners in the list (a count past the capacity cannot happen; clamp anyway).
fn corner_count() -> u32 { return min(atomicLoad(&counters[C_CORNERS]), P.capacity); }

// f32 total order (Rust's total_cmp) as u32 order: negative -> !bits, else
// bits | sign, so -0.0 < +0.0 and every negative is below every positive.
fn order_key(r: f32) -> u32 {
    let b = bitcast<u32>(r);
    return select(b | 0x80000000u, ~b, (b >> 31u) == 1u);
}

// True iff corner j comes before corner i in SPEC 9 order (cpu::select::order):
// greater key first, then level, y, x ascending. `pos` = (level, y, x).
fn precedes(kj: u32, pj: vec3<u32>, ki: u32, pi: vec3<u32>) -> bool {
    if (kj != ki) { return kj > ki; }
    if (pj.x != pi.x) { return pj.x < pi.x; }
    if (pj.y != pi.y) { return pj.y < pi.y; }
    return pj.z < pi.z;
}

fn pos_of(k: Kp) -> vec3<u32> { return vec3(k.level, k.py, k.px); }

// The same order on records (key, taken, level, y << 16 | x; sides are at most
// 16384, so y << 16 | x orders as (y, x)).
fn record_precedes(j: vec4<u32>, i: vec4<u32>) -> bool {
    if (j.x != i.x) { return j.x > i.x; }
    if (j.z != i.z) { return j.z < i.z; }
    return j.w < i.w;
}

// The magnitude bits of an order key's response (|r| as u32 order).
fn key_magnitude(key: u32) -> u32 { return select(~key, key, (key >> 31u) == 1u) & 0x7fffffffu; }

// The bucket of an order key, from its response's magnitude t above the
// frame's smallest (span = largest - smallest): a positive response is at
// span - t, a negative one at span + 1 + t, in 0 ..= 2 span + 1, shifted right
// until that fits BUCKETS. Greater keys, lower (or equal) buckets.
fn bucket_of(key: u32) -> u32 {
    let lo = atomicLoad(&counters[C_MAG_MIN]);
    let span = atomicLoad(&counters[C_MAG_MAX]) - lo;
    let t = key_magnitude(key) - lo;
    let at = select(span + 1u + t, span - t, (key >> 31u) == 1u);
    let bits = 32u - countLeadingZeros(2u * span + 1u);
    let shift = select(0u, bits - BUCKET_BITS, bits > BUCKET_BITS);
    return at >> shift;
}

// Quota left for the best not-taken corners of any level.
fn spare() -> u32 {
    let taken = atomicLoad(&counters[C_TAKEN]);
    return select(0u, P.n_features - taken, P.n_features > taken);
}

// The args over a list of n corners or keypoints, an invocation each and
// GROUP (= 64) a workgroup: list_args, within the workgroup count a dimension
// every device allows whatever n (wgpu's check of indirect args would zero
// a dispatch past it, and a device without the check may do anything).
fn write_dispatch(at: u32, n: u32) {
    let a = list_args(n);
    indirect[at] = a.x;
    indirect[at + 1u] = a.y;
    indirect[at + 2u] = a.z;
}

@compute @workgroup_size(1)
fn args() {
    write_dispatch(I_CORNERS, corner_count());
    atomicStore(&counters[C_TAKEN], 0u);
    atomicStore(&counters[C_KEYPOINTS], 0u);
    atomicStore(&counters[C_MAG_MAX], 0u);
    atomicStore(&counters[C_MAG_MIN], 0xffffffffu);
}

var<workgroup> tile_key: array<u32, GROUP>;
var<workgroup> tile_pos: array<vec3<u32>, GROUP>;
var<workgroup> wg_n: u32;
var<workgroup> wg_max: atomic<u32>;
var<workgroup> wg_min: atomic<u32>;

// The corner count as a workgroup-uniform value (the loop below has barriers).
fn uniform_count(li: u32) -> u32 {
    if (li == 0u) { wg_n = corner_count(); }
    return workgroupUniformLoad(&wg_n);
}

@compute @workgroup_size(64)
fn rank_level(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    if (li == 0u) {
        atomicStore(&wg_max, 0u);
        atomicStore(&wg_min, 0xffffffffu);
    }
    let n = uniform_count(li);
    let i = list_index(wg, vec3(li, 0u, 0u));
    let live = i < n;
    var ki = 0u;
    var pi = vec3(0u);
    if (live) {
        ki = order_key(corners[i].response);
        pi = pos_of(corners[i]);
        atomicMax(&wg_max, key_magnitude(ki));
        atomicMin(&wg_min, key_magnitude(ki));
    }
    // Without a cap every corner is taken: no need to count.
    let m = select(n, 0u, P.n_features == 0u);
    var before = 0u;
    for (var t = 0u; t < m; t += GROUP) {
        let j = t + li;
        if (j < m) {
            tile_key[li] = order_key(corners[j].response);
            tile_pos[li] = pos_of(corners[j]);
        }
        workgroupBarrier();
        let len = min(GROUP, m - t);
        if (live) {
            for (var k = 0u; k < len; k++) {
                if (tile_pos[k].x == pi.x && precedes(tile_key[k], tile_pos[k], ki, pi)) { before++; }
            }
        }
        workgroupBarrier();
    }
    workgroupBarrier();
    if (li == 0u && atomicLoad(&wg_max) >= atomicLoad(&wg_min)) {
        atomicMax(&counters[C_MAG_MAX], atomicLoad(&wg_max));
        atomicMin(&counters[C_MAG_MIN], atomicLoad(&wg_min));
    }
    if (live) {
        let taken = P.n_features == 0u || before < quota(pi.x);
        ranks[i] = vec4(ki, u32(taken), pi.x, (pi.y << 16u) | pi.z);
        if (taken) { atomicAdd(&counters[C_TAKEN], 1u); }
    }
}

@compute @workgroup_size(64)
fn count(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let i = list_index(wg, li);
    if (i >= corner_count()) { return; }
    let r = ranks[i];
    let b = bucket_of(r.x);
    atomicAdd(&buckets[B_COUNT + b], 1u);
    if (r.y == 1u) { atomicAdd(&buckets[B_TAKEN + b], 1u); }
}

// scan: lane li sums buckets 16 li .. 16 li + 15; the lane sums' exclusive
// prefix (Hillis-Steele over 256 lanes, both counts at once) then gives each
// lane the start of its run.
var<workgroup> scan_sums: array<vec2<u32>, 256>;

@compute @workgroup_size(256)
fn scan(@builtin(local_invocation_index) li: u32) {
    let first = li * (BUCKETS / 256u);
    var own = vec2(0u);
    for (var k = 0u; k < BUCKETS / 256u; k++) {
        own += vec2(atomicLoad(&buckets[B_COUNT + first + k]), atomicLoad(&buckets[B_TAKEN + first + k]));
    }
    scan_sums[li] = own;
    workgroupBarrier();
    for (var d = 1u; d < 256u; d <<= 1u) {
        var add = vec2(0u);
        if (li >= d) { add = scan_sums[li - d]; }
        workgroupBarrier();
        scan_sums[li] += add;
        workgroupBarrier();
    }
    // inclusive -> exclusive for this lane's run, then bucket by bucket
    var acc = scan_sums[li] - own;
    for (var k = 0u; k < BUCKETS / 256u; k++) {
        let b = first + k;
        atomicStore(&buckets[B_BEFORE + b], acc.x);
        atomicStore(&buckets[B_TAKEN_BEFORE + b], acc.y);
        acc += vec2(atomicLoad(&buckets[B_COUNT + b]), atomicLoad(&buckets[B_TAKEN + b]));
    }
}

@compute @workgroup_size(64)
fn scatter(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let i = list_index(wg, li);
    if (i >= corner_count()) { return; }
    let r = ranks[i];
    let b = bucket_of(r.x);
    let slot = atomicLoad(&buckets[B_BEFORE + b]) + atomicAdd(&buckets[B_CURSOR + b], 1u);
    members[slot] = r;
}

@compute @workgroup_size(64)
fn place(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let i = list_index(wg, li);
    if (i >= corner_count()) { return; }
    let ri = ranks[i];
    let b = bucket_of(ri.x);
    let start = atomicLoad(&buckets[B_BEFORE + b]);
    let end = start + atomicLoad(&buckets[B_COUNT + b]);
    // every corner of a lower bucket precedes this one
    var taken_before = atomicLoad(&buckets[B_TAKEN_BEFORE + b]);
    var rest_before = start - taken_before;
    // (a corner does not precede itself)
    for (var k = start; k < end; k++) {
        let rj = members[k];
        if (record_precedes(rj, ri)) {
            if (rj.y == 1u) { taken_before++; } else { rest_before++; }
        }
    }
    let sp = spare();
    if (ri.y == 1u || rest_before < sp) {
        let at = taken_before + min(rest_before, sp);
        if (at < P.capacity) {
            let c = corners[i];
            keypoints[at] = c;
            if (c.level < P.n_levels) { mark_tiles(c.level, i32(c.px), i32(c.py)); }
        }
    }
}

@compute @workgroup_size(1)
fn finish() {
    let n = corner_count();
    let taken = atomicLoad(&counters[C_TAKEN]);
    let count = taken + min(spare(), n - taken);
    atomicStore(&counters[C_KEYPOINTS], count);
    write_dispatch(I_KEYPOINTS, count);
    indirect[I_KEYPOINT_GROUPS] = min(count, MAX_GROUPS);
    indirect[I_KEYPOINT_GROUPS + 1u] = (count + MAX_GROUPS - 1u) / MAX_GROUPS;
    indirect[I_KEYPOINT_GROUPS + 2u] = 1u;
    indirect[I_DRAW] = 4u;
    indirect[I_DRAW + 1u] = count;
    indirect[I_DRAW + 2u] = 0u;
    indirect[I_DRAW + 3u] = 0u;
}
