// SPEC 7 rule 3: hysteresis. Mirrors src/cpu/hysteresis.rs: a pixel is an
// edge (255) iff it is STRONG, or WEAK and joined to a STRONG pixel through
// 8-connected WEAK pixels. `ruled` and `edges` are column-packed (common.wgsl
// pk_word); labels hold one u32 per pixel, flags one bit.
//
// The CPU floods each WEAK component that touches a STRONG pixel. Here the
// same set comes from connected-component labelling of the active (WEAK or
// STRONG) pixels with a lock-free union-find (Playne & Hawick, "A New Algorithm for Parallel
// Connected-Component Labelling on GPUs", 2018): a component is an edge iff it
// holds a STRONG pixel.
//
// `labels` holds each pixel's parent p as its complement ~p, so the buffer as
// cleared by the pass's prepare (all 0) says "no parent": every pixel starts
// as a root, without an init dispatch. Below, "labels[i]" means the parent
// ~labels[i], with NONE (= ~0) ordered above every index. Three dispatches,
// each a column pass over every level (one invocation per column of a tile,
// see tile_column), in this order:
//   merge        union of each active pixel with its active left, up-left,
//                up and up-right neighbours (the other four see it as theirs),
//                as few of them as keep the components (see merge)
//   compress     labels[i] = root of i, and bit `root` of flags set for every
//                STRONG pixel (`flags` is cleared by the pass's prepare)
//   final_edges  edges = 255 iff active and bit labels[i] of flags is set
// No host loop and no iteration cap: the result is exact after one pass of
// each, whatever the length or shape of a contour. Through the complement,
// atomicMin of a parent is atomicMax of its stored word.
//
// Why it converges and is exact:
// - Labels only decrease and always point to a smaller or equal index:
//   they start at NONE, and the only writes are atomicMin(labels[hi], lo)
//   with lo < hi and (compress) labels[i] = root, root <= i. So every parent
//   chain strictly decreases until a root (labels[r] == NONE, or == r once
//   compressed): `find` ends after at most i steps, there are no cycles.
// - `unite(a, b)` (union) loops on a pair (a, b): it takes the two roots, and
//   atomicMin links the larger root hi to the smaller lo. If atomicMin returns
//   NONE, hi was still a root: the link is made and the loop ends. Otherwise
//   another invocation had linked hi to old < hi meanwhile; labels[hi] is now
//   min(old, lo), so hi is joined to lo or stays joined to old, and the loop
//   goes on with the pair (old, lo) to join the other one too. Each round
//   the larger element of the pair strictly decreases (roots <= inputs,
//   old < hi, lo < hi), so the loop ends after finitely many rounds, without
//   waiting on any other invocation (lock-free).
// - No link ever separates pixels (a re-linked hi keeps its old parent joined
//   through the pending pair), and every link joins two pixels of one
//   component, so when the merge dispatch ends the trees are exactly the
//   8-connected components of active pixels. Stale relaxed loads in `find` are
//   harmless: a stale parent is an older ancestor, still in the same tree, and
//   the atomicMin result decides.
// - Levels never connect: neighbours are taken only inside the level's bounds,
//   and each level owns its own range of atlas indices.
// Tests: tests/gpu_edges_back.rs (this pass alone == src/cpu/hysteresis.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).

@group(0) @binding(1) var<storage, read> ruled: array<u32>;
@group(0) @binding(2) var<storage, read_write> labels: array<atomic<u32>>;
@group(0) @binding(3) var<storage, read_write> flags: array<atomic<u32>>;
@group(0) @binding(4) var<storage, read_write> edges: array<u32>;

// Classes of src/cpu/classify.rs (after rules only NONE, WEAK and STRONG remain).
const WEAK: u32 = 2u;
const STRONG: u32 = 4u;
const EDGE: u32 = 255u;

// The parent of a root that has not been compressed (labels as cleared).
const NONE: u32 = 0xffffffffu;

// The parent of i: NONE, an index below i, or i itself (a compressed root).
fn parent(i: u32) -> u32 {
    return ~atomicLoad(&labels[i]);
}

// The root of i's tree.
fn find(i: u32) -> u32 {
    var r = i;
    loop {
        let n = parent(r);
        if (n == NONE || n == r) { return r; }
        r = n;
    }
    return r; // never reached; naga wants a return after the loop
}

// Joins the trees of a and b (see the convergence argument above).
fn unite(a0: u32, b0: u32) {
    var a = a0;
    var b = b0;
    loop {
        a = find(a);
        b = find(b);
        if (a == b) { return; }
        let hi = max(a, b);
        let lo = min(a, b);
        // atomicMin(labels[hi], lo) through the complement
        let old = ~atomicMax(&labels[hi], ~lo);
        if (old == NONE) { return; }
        // hi was linked to old < hi meanwhile: join old with lo as well.
        a = old;
        b = lo;
    }
}

// Joins the trees of i and t < i, i a pixel of the walk: i is most often
// still a root (nobody linked it yet), so it is linked to t directly, with no
// find. Otherwise i's parent old was replaced by min(old, t) and old is
// joined to t as well: the first round of `unite` from the pair (i, t), whose
// argument (above) holds for any hi > lo, root or not.
fn link(i: u32, t: u32) {
    let old = ~atomicMax(&labels[i], ~t);
    if (old != NONE && old != t) { unite(old, t); }
}

// The packed words of columns x-1, x, x+1 holding row y of level l (the
// column's own word in .y); a column outside the level reads as 0 (class
// NONE in every row: never active). rules.wgsl's words3, over `ruled` (a
// shader function cannot take a storage buffer as an argument).
fn words3(l: u32, x: u32, y: u32) -> vec3<u32> {
    let k = pk_word(l, x, y);
    var r = vec3<u32>(0u, ruled[k], 0u);
    if (x > 0u) { r.x = ruled[k - 1u]; }
    if (x + 1u < lw(l)) { r.z = ruled[k + 1u]; }
    return r;
}

fn active3(c: vec3<u32>) -> vec3<bool> {
    return (c == vec3<u32>(WEAK)) | (c == vec3<u32>(STRONG));
}

// merge: active pixel i at (x, y) is united with its active neighbours of
// the row above (UL, U, UR) and the left (L), the only neighbours that come
// before it in raster order, but only with as many as keep the components
// exact (the scan-mask decision tree of Wu, Otoo & Suzuki, "Optimizing
// two-pass connected-component labeling algorithms", 2009):
// - U active: U alone. L, UL and UR come before i and are U's neighbours, so
//   each is joined to U by the unions made at L, U and UR respectively (by
//   induction in raster order: each pixel is joined to all its neighbours
//   that come before it).
// - otherwise L, else UL (L's up neighbour, so joined to L at L), and UR when
//   active: UR is no neighbour of L or UL.
// Every union made joins two 8-neighbours and every 8-neighbour pair ends up
// joined, so the trees are the 8-connected components, as with all four unions.
// Each invocation walks its column with the words of columns x-1, x, x+1 in
// registers (three reads per four rows, in an outer loop over the words, not
// under `if`: see median.wgsl) and notes each row's unions as bits;
// then it makes them in a loop over the rows that have any. A SIMD software
// rasteriser runs a branch's body for every lane of the group (masked), so the
// unions in the walk cost 16 times per column; compacted, they cost as many
// times as the busiest lane of the group has pixels to join.
@compute @workgroup_size(64, 1, 1)
fn merge(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let c = column_span(wg, li);
    if (c.y == c.z) { return; }
    let l = c.w;
    let w = lw(l);
    // classes of the row above at x-1, x, x+1 (none above row 0)
    var up = vec3<bool>(false);
    if (c.y > 0u) { up = active3(pk_byte3(words3(l, c.x, c.y - 1u), c.y - 1u)); }
    // per row r of the walk: bit r of `rows` if it has a union to make;
    // bits 2r, 2r+1 of `first`: its first union (0 none, 1 U, 2 L, 3 UL);
    // bit r of `ur`: a second union, with UR
    var rows = 0u;
    var first = 0u;
    var ur = 0u;
    // an outer loop over the words (four rows), an inner one over the rows
    // (rows past the level's last are NONE in their word: never active)
    for (var y = c.y; y < c.z; y += 4u) {
        let words = words3(l, c.x, y);
        for (var k = 0u; k < 4u; k++) {
            let cur = active3(pk_byte3(words, y + k));
            let r = y + k - c.y;
            var code = 0u;
            var second = false;
            if (up.y) {
                code = 1u;
            } else {
                code = select(select(0u, 3u, up.x), 2u, cur.x);
                second = up.z;
            }
            if (cur.y && (code != 0u || second)) {
                rows |= 1u << r;
                first |= code << (2u * r);
                ur |= u32(second) << r;
            }
            up = cur;
        }
    }
    while (rows != 0u) {
        let r = countTrailingZeros(rows);
        rows &= rows - 1u;
        let i = loff(l) + (c.y + r) * w + c.x;
        let code = (first >> (2u * r)) & 3u;
        if (code != 0u) { link(i, select(select(i - w - 1u, i - 1u, code == 2u), i - w, code == 1u)); }
        if (((ur >> r) & 1u) != 0u) { link(i, i - w + 1u); }
    }
}

fn compress_px(i: u32, strong: bool) {
    // Roots do not change any more: every store writes a root, an ancestor
    // of i, so concurrent finds still end at the same root.
    let root = find(i);
    atomicStore(&labels[i], ~root);
    // A STRONG pixel marks its component (final_edges reads the mark only
    // after this dispatch has ended).
    // (`flags` is a bit per pixel: a 32nd of a u32 plane to clear each frame)
    if (strong) { atomicOr(&flags[root >> 5u], 1u << (root & 31u)); }
}

// Bits of the walk's rows (bit r = row y0 + r, rows past `end` clear): which
// are active (.x) and which STRONG (.y), from the column's words of `ruled`.
fn active_rows(l: u32, x: u32, y0: u32, end: u32) -> vec2<u32> {
    var m = vec2<u32>(0u);
    for (var y = y0; y < end; y += 4u) {
        let k = pk_rows(ruled[pk_word(l, x, y)]);
        let strong = bits4(k == vec4<u32>(STRONG));
        m |= vec2<u32>(bits4(k == vec4<u32>(WEAK)) | strong, strong) << vec2<u32>(y - y0);
    }
    // rows past the level's last are 0 in their word (NONE), never active
    return m;
}

// Compacted as merge: a loop over the column's active pixels only.
@compute @workgroup_size(64, 1, 1)
fn compress(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let c = column_span(wg, li);
    if (c.y == c.z) { return; }
    let m = active_rows(c.w, c.x, c.y, c.z);
    var rows = m.x;
    while (rows != 0u) {
        let r = countTrailingZeros(rows);
        rows &= rows - 1u;
        compress_px(loff(c.w) + (c.y + r) * lw(c.w) + c.x, ((m.y >> r) & 1u) != 0u);
    }
}

// Compacted as merge: the flag of each active pixel's root (after compress
// its parent), then the column's packed words of `edges`.
@compute @workgroup_size(64, 1, 1)
fn final_edges(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let c = column_span(wg, li);
    if (c.y == c.z) { return; }
    var rows = active_rows(c.w, c.x, c.y, c.z).x;
    var e = 0u;
    while (rows != 0u) {
        let r = countTrailingZeros(rows);
        rows &= rows - 1u;
        let root = parent(loff(c.w) + (c.y + r) * lw(c.w) + c.x);
        e |= ((atomicLoad(&flags[root >> 5u]) >> (root & 31u)) & 1u) << r;
    }
    // `edges` is column-packed as `ruled`: bit r of e -> 255 at row c.y + r
    for (var y = c.y; y < c.z; y += 4u) {
        edges[pk_word(c.w, c.x, y)] = pk_from_bits(e >> (y - c.y)) * EDGE;
    }
}
