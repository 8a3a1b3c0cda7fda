// SPEC 7 rule 3: hysteresis. Mirrors src/cpu/hysteresis.rs: a pixel is an
// edge (255) iff it is STRONG, or WEAK and joined to a STRONG pixel through
// 8-connected WEAK pixels. `ruled` and `edges` are column-packed (common.wgsl
// pk_word); labels and flags hold one u32 per pixel.
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
//                up and up-right neighbours (the other four see it as theirs)
//   compress     labels[i] = root of i, and flags[root] = 1 for every STRONG
//                pixel (`flags` is cleared by the pass's prepare)
//   final_edges  edges = 255 iff active and flags[labels[i]] == 1
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

// A pixel the CPU flood can reach or start from: a seed (STRONG) or WEAK.
// `ruled` is column-packed (common.wgsl pk_word): the class at (x, y) of level l.
fn class_at(l: u32, x: u32, y: u32) -> u32 { return pk_byte(ruled[pk_word(l, x, y)], y); }

fn is_active(c: u32) -> bool {
    return c == WEAK || c == STRONG;
}

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

// The atlas index of pixel id.

// Union with the active ones of the left, up-left, up and up-right neighbours
// (each 8-neighbour pair is visited once) of active pixel (x, y) of level l.
fn merge_px(l: u32, x: u32, y: u32) {
    let i = loff(l) + y * lw(l) + x;
    let w = lw(l);
    if (x > 0u && is_active(class_at(l, x - 1u, y))) { unite(i, i - 1u); }
    if (y > 0u) {
        let u = i - w;
        if (x > 0u && is_active(class_at(l, x - 1u, y - 1u))) { unite(i, u - 1u); }
        if (is_active(class_at(l, x, y - 1u))) { unite(i, u); }
        if (x + 1u < w && is_active(class_at(l, x + 1u, y - 1u))) { unite(i, u + 1u); }
    }
}

// Column passes: each invocation reads its column's packed word once per four
// rows (its 16 rows are 4 whole words) and works at the active pixels.
@compute @workgroup_size(64, 1, 1)
fn merge(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let c = column_span(wg, li);
    var word = 0u;
    for (var y = c.y; y < c.z; y++) {
        if ((y & 3u) == 0u) { word = ruled[pk_word(c.w, c.x, y)]; }
        if (is_active(pk_byte(word, y))) { merge_px(c.w, c.x, y); }
    }
}

fn compress_px(i: u32, strong: bool) {
    // Roots do not change any more: every store writes a root, an ancestor
    // of i, so concurrent finds still end at the same root.
    let root = find(i);
    atomicStore(&labels[i], ~root);
    // A STRONG pixel marks its component (final_edges reads the mark only
    // after this dispatch has ended).
    if (strong) { atomicOr(&flags[root], 1u); }
}

@compute @workgroup_size(64, 1, 1)
fn compress(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let c = column_span(wg, li);
    var word = 0u;
    for (var y = c.y; y < c.z; y++) {
        if ((y & 3u) == 0u) { word = ruled[pk_word(c.w, c.x, y)]; }
        let k = pk_byte(word, y);
        if (is_active(k)) { compress_px(loff(c.w) + y * lw(c.w) + c.x, k == STRONG); }
    }
}

@compute @workgroup_size(64, 1, 1)
fn final_edges(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let c = column_span(wg, li);
    var word = 0u;
    var out = 0u;
    for (var y = c.y; y < c.z; y++) {
        if ((y & 3u) == 0u) { word = ruled[pk_word(c.w, c.x, y)]; }
        let i = loff(c.w) + y * lw(c.w) + c.x;
        var e = 0u;
        // after compress every active pixel's parent is its root
        if (is_active(pk_byte(word, y)) && atomicLoad(&flags[parent(i)]) == 1u) { e = EDGE; }
        // `edges` is column-packed as `ruled`
        out |= pk_place(e, y);
        if (pk_complete(y, c.z)) {
            edges[pk_word(c.w, c.x, y)] = out;
            out = 0u;
        }
    }
}
