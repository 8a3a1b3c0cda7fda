// SPEC 7 rule 3: hysteresis. Mirrors src/cpu/hysteresis.rs: a pixel is an
// edge (255) iff it is STRONG, or WEAK and joined to a STRONG pixel through
// 8-connected WEAK pixels. `ruled` holds a word per column of every tile
// (rules.wgsl: bit r active, bit 16 + r STRONG, for row 16 ty + r); `edges` is
// column-packed (common.wgsl pk_word); labels hold one u32 per pixel, flags
// one bit.
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
// each over the walk list (`walks`: the quad walks, four columns of a tile
// row, that hold an active pixel, about half of a KITTI frame's; rules.wgsl
// appends them, walk_args writes the args), four columns per invocation (see
// quad_span: with a few run tops per column, the invocations' own work was a
// good part of their cost on lavapipe; hysteresis 6.8 -> 5.8 ms per KITTI
// frame with all three), in this order:
//   merge        union of each active pixel with its active left, up-left,
//                up and up-right neighbours (the other four see it as theirs),
//                as few of them as keep the components, made between the
//                tops of the walks' vertical runs (see merge)
//   compress     per vertical run of a walk: labels[top] = root of the top,
//                and bit `root` of flags set if the run holds a STRONG pixel
//                (`flags` is cleared by the pass's prepare)
//   final_edges  a run is edge (255) iff bit labels[top] of flags is set;
//                the walk's edge rows also as tile-column words (edge_tiles)
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
//
// Races: labels and flags are shared words and are written with atomics only
// (atomicMin, atomicStore, atomicOr: the union-find above, whose roots
// come out the same in any interleaving);
// walk_args, a single invocation, stores `indirect` and pads `walks`;
// final_edges stores its walk's four `edge_tiles` words and the `edges` words
// of its walk's four columns, padding
// past the level's width included (4 whole words per column of a tile,
// common.wgsl pk_word), and walks are distinct
// entries, so no two invocations write one word.

@group(0) @binding(1) var<storage, read> ruled: array<u32>;
// `ruled` again, four columns' words a load (a quad walk's x0 .. x0 + 3: x0
// is a multiple of 4 and a tile row's words start at a multiple of 16)
@group(0) @binding(8) var<storage, read> ruled4: array<vec4<u32>>;
@group(0) @binding(2) var<storage, read_write> labels: array<atomic<u32>>;
@group(0) @binding(3) var<storage, read_write> flags: array<atomic<u32>>;
// four columns' words a store (common.wgsl pk_pitch), padding included
@group(0) @binding(4) var<storage, read_write> edges: array<vec4<u32>>;
// The quad walks holding an active pixel (common.wgsl walk_entry), appended
// by rules.wgsl and counted in counters[WALKS]; walk_args pads them to a
// whole workgroup with NO_WALK and writes the steps' indirect args.
@group(0) @binding(5) var<storage, read_write> walks: array<u32>;
@group(0) @binding(6) var<storage, read_write> counters: array<atomic<u32>>;
@group(0) @binding(7) var<storage, read_write> indirect: array<u32>;
// The edge rows of each tile column (`edge_bits`, common.wgsl tile_word:
// bit r = row 16 ty + r is an edge), four columns a store: Paper mode's
// L-FAST test reads them (lfast.wgsl `paper`; cleared by the pass's prepare,
// so the walks not listed hold none).
@group(0) @binding(9) var<storage, read_write> edge_tiles: array<vec4<u32>>;

// indirect::WALKS / 4 in src/gpu/buffers.rs.
const I_WALKS: u32 = 24u;
// A walk list entry past the list's end.
const NO_WALK: u32 = 0xffffffffu;

@compute @workgroup_size(1, 1, 1)
fn walk_args() {
    let n = atomicLoad(&counters[C_WALKS]);
    let a = list_args(n);
    indirect[I_WALKS] = a.x;
    indirect[I_WALKS + 1u] = a.y;
    indirect[I_WALKS + 2u] = a.z;
    for (var k = n; k < (n + 63u) / 64u * 64u; k++) {
        walks[k] = NO_WALK;
    }
}

// The span (x0, top row, end row, level, as quad_span) of this invocation's
// walk of the list; no rows (end = top) past the list's end. (A dispatch of
// more than 65535 workgroups is a rectangle that may pass the padding: an
// entry there is whatever a frame left, so it must name a walk of this
// frame's levels, and a walk listed twice only repeats idempotent work.)
fn listed_walk(wg: vec3<u32>, li: vec3<u32>) -> vec4<u32> {
    let e = walks[list_index(wg, li)];
    let c = walk_span(e);
    if (e == NO_WALK || c.w >= P.n_levels || c.x >= lw(c.w) || c.y >= lh(c.w)) { return vec4<u32>(0u); }
    return c;
}

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

// The active rows (`ruled` bits 0..15) of the six columns of a quad walk
// (`cols`, six_columns; `inside`: all ones for the columns inside the level)
// in tile row ty of level l; a column outside the level reads as 0 (never
// active). Six unconditional loads (columns clamped), then zeroed outside.
fn six_active(l: u32, cols: Six, inside: Six, ty: u32) -> Six {
    let t = (P.tiles[l].x + ty * P.tiles[l].y) * TILE;
    // columns x0 .. x0 + 3 (cols.a.y: x0) in one load: past the level's
    // right edge they are padding, zeroed below
    let mid = ruled4[(t + cols.a.y) >> 2u];
    let a = vec4<u32>(ruled[t + tile_col(cols.a.x)], mid.xyz);
    let b = vec2<u32>(mid.w, ruled[t + tile_col(cols.b.y)]);
    return Six(a & inside.a & vec4<u32>(0xffffu), b & inside.b & vec2<u32>(0xffffu));
}

// Column x's offset in its tile row of a tile-column plane (tile_word).
fn tile_col(x: u32) -> u32 { return (x / TILE) * TILE + x % TILE; }

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
//
// Unions are made between *run tops*, not pixels: a walk's vertical run of
// active pixels (16 rows of a tile column) is one component, represented by
// its top, and every union (p, q) above becomes (top(p), top(q)). A pixel
// under an active one (U active, in its run) then has nothing to do: its
// union with U is the run itself. compress and final_edges read the tops'
// labels only, so no other pixel's label is ever written or read. The tops
// of the neighbours' runs come from the `ruled` bit words of columns x-1, x,
// x+1 of the walk's tile and the tile above (for a quad walk's four columns,
// twelve loads of six columns, unconditional); every row's decision is taken
// at once in bit operations, and each column's unions are made in a loop
// over the rows that have any (merge_pair, two columns a loop). A SIMD software rasteriser runs a
// branch's body for every lane of the group (masked), so the unions in the
// walk cost 16 times per column; compacted, they cost as many times as the
// busiest lane of the group has tops to join.
@compute @workgroup_size(64, 1, 1)
fn merge(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let c = listed_walk(wg, li);
    if (c.y == c.z) { return; }
    let l = c.w;
    let w = lw(l);
    let x0 = c.x;
    let ty = c.y / TILE;
    // the walk's active rows of columns x0 - 1 .. x0 + 4 (bit r = row c.y + r;
    // rows past the level's last are clear), and those of the walk above
    // (none above row 0)
    let cols = six_columns(x0, w);
    let inside = six_inside(x0, w);
    let cur = six_active(l, cols, inside, ty);
    let above = six_active(l, cols, Six(inside.a * u32(ty > 0u), inside.b * u32(ty > 0u)), max(ty, 1u) - 1u);
    // atlas index of row 0 of this walk at column x0 - 1
    let row0 = loff(l) + c.y * w + x0 - 1u;
    merge_pair(merge_rows(tri(cur, 0u), tri(above, 0u)), merge_rows(tri(cur, 1u), tri(above, 1u)), row0, w);
    merge_pair(merge_rows(tri(cur, 2u), tri(above, 2u)), merge_rows(tri(cur, 3u), tri(above, 3u)), row0 + 2u, w);
}

// What one column x of a quad walk unites (merge_rows): which rows join U
// (`u`), L (`l`) or UL (`ul`) and which UR as well (`ur`), bits 0..15; the
// run tops of columns x - 1 and x + 1 (`tops_l`, `tops_r`); the rows (-16 ..
// -1, in the walk above) of the tops of the runs holding the last row of the
// walk above in columns x - 1, x, x + 1 (`up_tops`).
struct Unions {
    u: u32,
    l: u32,
    ul: u32,
    ur: u32,
    tops_l: u32,
    tops_r: u32,
    up_tops: vec3<i32>,
}

// The unions of column x: `cols` the active rows of columns x-1, x, x+1 in
// this walk, `prev` in the walk above.
fn merge_rows(cols: vec3<u32>, prev: vec3<u32>) -> Unions {
    let above = prev >> vec3<u32>(15u);
    // every row's neighbours at once, as bits: up-left, up, up-right
    let ups = ((cols << vec3<u32>(1u)) | above) & vec3<u32>(0xffffu);
    let act = cols.y;
    // the decision tree, row by row in parallel: U alone when active (a
    // union only at row 0, U in the walk above; below, U is the same run);
    // else L, else UL, and UR as a second union
    // the first rows of the vertical runs of this walk and the one above
    let tops = cols & ~(cols << vec3<u32>(1u));
    let tops_above = prev & ~(prev << vec3<u32>(1u));
    return Unions(
        act & ups.y & 1u,
        act & ~ups.y & cols.x,
        act & ~ups.y & ~cols.x & ups.x,
        act & ~ups.y & ups.z,
        tops.x,
        tops.z,
        vec3<i32>(row_of_top(tops_above.x, 15u), row_of_top(tops_above.y, 15u), row_of_top(tops_above.z, 15u)) - vec3<i32>(16),
    );
}

// The unions of two neighbouring columns of a quad walk (`a`, `b`; `row0` the
// atlas index of row 0 of the column left of `a`), in one loop over both
// columns' rows (bit 16 k + r: row r of column k), as compress_pair: a
// SIMD software rasteriser runs a loop as often as its busiest lane needs,
// so one loop over the pair costs at most what one per column did.
fn merge_pair(a: Unions, b: Unions, row0: u32, w: u32) {
    let by_u = a.u | (b.u << 16u);
    let by_l = a.l | (b.l << 16u);
    let by_ul = a.ul | (b.ul << 16u);
    let ur = a.ur | (b.ur << 16u);
    var rows = by_u | by_l | by_ul | ur;
    while (rows != 0u) {
        let bit = countTrailingZeros(rows);
        rows &= rows - 1u;
        let k = bit >> 4u;
        let r = bit & 15u;
        let one = 1u << bit;
        let second = k == 1u;
        let tops_l = select(a.tops_l, b.tops_l, second);
        let up_tops = select(a.up_tops, b.up_tops, vec3<bool>(second));
        let r0 = row0 + k;
        let i = r0 + r * w + 1u;
        // L: the top of L's run, same walk, at or above row r
        let l_top = row_of_top(tops_l, r);
        // UL, UR: the top of the run holding row r - 1 of column x -+ 1, in
        // this walk or (r = 0) the walk above; U only at row 0 (up_tops.y)
        let ul_top = select(up_tops.x, row_of_top(tops_l, r - 1u), r > 0u);
        let ur_top = select(up_tops.z, row_of_top(select(a.tops_r, b.tops_r, second), r - 1u), r > 0u);
        if (((by_u | by_l | by_ul) & one) != 0u) {
            let t = select(select(at(r0, w, ul_top, 0u), at(r0, w, l_top, 0u), (by_l & one) != 0u), at(r0, w, up_tops.y, 1u), (by_u & one) != 0u);
            link(i, t);
        }
        if ((ur & one) != 0u) { link(i, at(r0, w, ur_top, 2u)); }
    }
}

// The row (of the walk, bit r of `tops`) of the top of the run holding row r:
// the last top at or above r.
fn row_of_top(tops: u32, r: u32) -> i32 {
    return i32(firstLeadingBit(tops & ((2u << r) - 1u)));
}

// Atlas index of walk row `row` (-16 .. 15: negative in the walk above) of
// column x - 1 + dx, from `row0` (row 0, column x - 1) and the level width w.
fn at(row0: u32, w: u32, row: i32, dx: u32) -> u32 {
    return u32(i32(row0) + row * i32(w)) + dx;
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

// The rows of the vertical run of active rows `act` that starts at row r0.
fn run_mask(act: u32, r0: u32) -> u32 {
    return ((1u << countTrailingZeros(~(act >> r0))) - 1u) << r0;
}

// Compacted as merge, and per vertical run of the walk rather than per pixel:
// merge united runs through their tops, so a run is one component and its
// top's root is every pixel's. A loop over the runs' tops: the top's label
// becomes its root, and the root is marked when any pixel of the run is
// STRONG. (The other pixels have no label: final_edges reads the tops only.)
// Over the walk list (listed_walk): four columns per invocation, their
// run tops in two loops of two columns each (compress_pair).
@compute @workgroup_size(64, 1, 1)
fn compress(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let c = listed_walk(wg, li);
    if (c.y == c.z) { return; }
    let l = c.w;
    let w = lw(l);
    let x0 = c.x;
    let m = quad_rows(l, x0, w, c.y);
    let row0 = loff(l) + c.y * w + x0;
    compress_pair(m[0], m[1], row0, w);
    compress_pair(m[2], m[3], row0 + 2u, w);
}

// compress for two neighbouring columns of a walk (active_rows a, b; i0 the
// atlas index of the first column's row 0): one loop over both columns' run
// tops (bit 16 k + r: row r of column k).
fn compress_pair(a: vec2<u32>, b: vec2<u32>, i0: u32, w: u32) {
    var tops = tops2(a.x, b.x);
    while (tops != 0u) {
        let bit = countTrailingZeros(tops);
        tops &= tops - 1u;
        let k = bit >> 4u;
        let r = bit & 15u;
        let mk = select(a, b, k == 1u);
        compress_px(i0 + r * w + k, (mk.y & run_mask(mk.x, r)) != 0u);
    }
}

// The walk's rows of columns x0 .. x0 + 3 (bit r = row y0 + r; rows past the
// level's last clear): which are active (.x) and which STRONG (.y), from
// their `ruled` words (a column past the level's right edge has none).
fn quad_rows(l: u32, x0: u32, w: u32, y0: u32) -> array<vec2<u32>, 4> {
    // the four columns' words in one load; those past the level (padding) read as none
    let inside = vec4<u32>(x0) + vec4<u32>(0u, 1u, 2u, 3u) < vec4<u32>(w);
    let words = select(vec4<u32>(0u), ruled4[tile_word(l, x0, y0 / TILE) >> 2u], inside);
    return array<vec2<u32>, 4>(
        vec2<u32>(words.x & 0xffffu, words.x >> 16u),
        vec2<u32>(words.y & 0xffffu, words.y >> 16u),
        vec2<u32>(words.z & 0xffffu, words.z >> 16u),
        vec2<u32>(words.w & 0xffffu, words.w >> 16u),
    );
}

// The run tops of two columns' active rows a (bits 0..15) and b (16..31).
fn tops2(a: u32, b: u32) -> u32 {
    return (a & ~(a << 1u)) | ((b & ~(b << 1u)) << 16u);
}

// final_edges for two neighbouring columns of a walk (active rows a, b; i0
// the atlas index of the first column's row 0): their edge rows, column k's
// in bits 16 k .., from one loop over both columns' run tops.
fn edge_pair(a: u32, b: u32, i0: u32, w: u32) -> u32 {
    var tops = tops2(a, b);
    var e = 0u;
    while (tops != 0u) {
        let bit = countTrailingZeros(tops);
        tops &= tops - 1u;
        let k = bit >> 4u;
        let r = bit & 15u;
        let root = parent(i0 + r * w + k);
        let edge = ((atomicLoad(&flags[root >> 5u]) >> (root & 31u)) & 1u) != 0u;
        e |= select(0u, run_mask(select(a, b, k == 1u), r) << (16u * k), edge);
    }
    return e;
}

// Compacted as compress, per run: the flag of each run top's root (after
// compress its parent) for the whole run, then the columns' packed words of
// `edges` (the walks not listed stay as the pass's prepare cleared them: 0).
// Over the walk list, as compress (edge_pair).
@compute @workgroup_size(64, 1, 1)
fn final_edges(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let c = listed_walk(wg, li);
    if (c.y == c.z) { return; }
    let l = c.w;
    let w = lw(l);
    let x0 = c.x;
    let m = quad_rows(l, x0, w, c.y);
    let row0 = loff(l) + c.y * w + x0;
    let e01 = edge_pair(m[0].x, m[1].x, row0, w);
    let e23 = edge_pair(m[2].x, m[3].x, row0 + 2u, w);
    edge_tiles[tile_word(l, x0, c.y / TILE) >> 2u] = vec4<u32>(e01 & 0xffffu, e01 >> 16u, e23 & 0xffffu, e23 >> 16u);
    // `edges` is column-packed as `ruled`: bit r of column k's edge rows ->
    // 255 at row c.y + r. The walk's words in a loop (see median.wgsl).
    // (columns past the level's width have no edge rows: their padding words 0)
    for (var y = c.y; y < c.z; y += 4u) {
        let s = y - c.y;
        let q = vec4<u32>(e01 >> s, e01 >> (16u + s), e23 >> s, e23 >> (16u + s));
        edges[pk_word(l, x0, y) >> 2u] = vec4<u32>(
            pk_from_bits(q.x), pk_from_bits(q.y), pk_from_bits(q.z), pk_from_bits(q.w)) * vec4<u32>(EDGE);
    }
}
