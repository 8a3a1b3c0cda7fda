// SPEC 7 rules 1 and 2: isolated-edge suppression (paper Algorithm 3).
// Mirrors src/cpu/rules.rs. `classes` (SPEC 6, column-packed, common.wgsl
// pk_word) -> `ruled`, in which only NONE, WEAK and STRONG remain, as bits: one
// word per column of every tile (common.wgsl tile_word), bit r = row 16 ty + r
// is active (WEAK or STRONG), bit 16 + r is STRONG (gpu::layout::pack_ruled).
// Hysteresis reads them so, a word per column walk; each quad walk with an
// active pixel is appended to `walks` (common.wgsl walk_entry), counted in
// counters[WALKS] (cleared by the pass's prepare). A quad pass (four columns per invocation),
// all levels in one dispatch (over the tile list). Both rules read the classes
// of SPEC 6 only, so the result does not depend on the order of invocations.
// Tests: tests/gpu_edges_back.rs (this pass alone == src/cpu/rules.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).
//
// Races: each invocation stores the `ruled` words of its own four columns of its
// tile (one word per column per tile, pack_ruled), quads disjoint; walk-list
// entries go into the range its workgroup reserved (one atomicAdd on
// counters[WALKS] by lane 0, each lane's offset from an atomicAdd on the
// workgroup's count, wg_base read after a barrier).

@group(0) @binding(1) var<storage, read> classes: array<u32>;
// `classes` again, four columns' words a load (common.wgsl pk_pitch)
@group(0) @binding(5) var<storage, read> classes4: array<vec4<u32>>;
// four columns' words a store (a tile row's words start at a multiple of 16;
// the columns past the level's width are padding, which no pass reads as a pixel)
@group(0) @binding(2) var<storage, read_write> ruled: array<vec4<u32>>;
@group(0) @binding(3) var<storage, read_write> walks: array<u32>;
@group(0) @binding(4) var<storage, read_write> counters: array<atomic<u32>>;

// The workgroup's listed walks, and where they start in `walks`.
var<workgroup> wg_walks: atomic<u32>;
var<workgroup> wg_base: u32;

// Classes of src/cpu/classify.rs.
const NONE: u32 = 0u;
const WEAK_WEAK: u32 = 1u;
const WEAK: u32 = 2u;
const WEAK_STRONG: u32 = 3u;
const STRONG: u32 = 4u;

// The packed words of the six columns of a quad walk (`cols`, six_columns;
// `inside`: all ones for the columns inside the level) holding row y of level
// l (rows y & ~3 .. + 4); 0, all NONE, outside the level (no replicate border
// here: a missing neighbour matches no searched class, as rule_at only looks
// for WEAK_STRONG and WEAK_WEAK; rows past the last of a word are NONE too).
fn six_words(l: u32, cols: Six, inside: Six, y: i32) -> Six {
    // the loads unconditional (clamped row and columns; columns x0 .. x0 + 3,
    // x0 = cols.a.y, one aligned load), then zeroed outside the level
    let h = i32(lh(l));
    let r = pk_word(l, 0u, u32(clamp(y, 0, h - 1)));
    let row = select(0u, 0xffffffffu, y >= 0 && y < h);
    let mid = classes4[(r + cols.a.y) >> 2u];
    return Six(
        vec4<u32>(classes[r + cols.a.x], mid.xyz) & inside.a & vec4<u32>(row),
        vec2<u32>(mid.w, classes[r + cols.b.y]) & inside.b & vec2<u32>(row),
    );
}

// True iff one of the 8 neighbours of the centre of the 3x3 window (a above,
// b its row, c below) has class `k`.
fn has_neighbour(a: vec3<u32>, b: vec3<u32>, c: vec3<u32>, k: u32) -> bool {
    return any(a == vec3<u32>(k)) || b.x == k || b.z == k || any(c == vec3<u32>(k));
}

// The class of the window's centre after rules 1 and 2 (rule_at in the CPU module).
fn rule_at(a: vec3<u32>, b: vec3<u32>, c: vec3<u32>) -> u32 {
    // selects, not early returns: both tests are a few lanes' ALU
    let ws = select(WEAK, STRONG, has_neighbour(a, b, c, WEAK_STRONG));
    let ww = select(WEAK, NONE, has_neighbour(a, b, c, WEAK_WEAK));
    return select(select(b.y, ww, b.y == WEAK_WEAK), ws, b.y == WEAK_STRONG);
}

// Row yy's ruled class as its bits of the column's word (window rows a, b,
// c; row r = yy - y0 of the walk): bit r if active, bit 16 + r if STRONG; none
// past the walk's end.
fn ruled_bits(a: vec3<u32>, b: vec3<u32>, c: vec3<u32>, yy: i32, y0: i32, end: i32) -> u32 {
    let k = rule_at(a, b, c);
    let r = u32(yy - y0);
    let v = select(0u, 1u << r, k != NONE) | select(0u, 1u << (16u + r), k == STRONG);
    return select(0u, v, yy < end);
}

// Column x0 + k's `ruled` bits of rows yy .. yy + 3 of the walk from rows a
// (yy - 1), b (yy) and c0 .. c3 (yy + 1 .. yy + 4) of the six columns.
fn quad_bits(a: Six, b: Six, c0: Six, c1: Six, c2: Six, c3: Six, k: u32, yy: i32, y0: i32, end: i32) -> u32 {
    return ruled_bits(tri(a, k), tri(b, k), tri(c0, k), yy, y0, end)
        | ruled_bits(tri(b, k), tri(c0, k), tri(c1, k), yy + 1, y0, end)
        | ruled_bits(tri(c0, k), tri(c1, k), tri(c2, k), yy + 2, y0, end)
        | ruled_bits(tri(c1, k), tri(c2, k), tri(c3, k), yy + 3, y0, end);
}

// A quad pass (common.wgsl quad_span): the 3x3 windows of four columns walk
// down in registers, six columns' words per word of rows (a column walk read
// three for one: rules 2.2 -> 1.3 ms per KITTI frame on lavapipe). `step`
// takes a word (four rows), reading the next group's six words
// unconditionally, with the four rows written out (`ruled_bits`), in a loop
// over the walk's words (written out, the steps cost lavapipe's compile
// 39 ms instead of 16 and saved nothing measurable). The walk's four words
// of `ruled` are written once at the end, none past the level's right edge.
@compute @workgroup_size(64, 1, 1)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    // A lane without a walk (quad_span's empty span: level 0, no rows) runs
    // the walk's code with nothing to do, no `if` around it: the barriers
    // below need every lane, and the walk inside an `if` took lavapipe's
    // compiler ~2 ms longer.
    let span = quad_span(wg, li);
    let listed = rule_walk(span, span.y != span.z);
    // A walk with an active pixel joins the walk list (hysteresis runs over
    // it; about half the walks of a KITTI frame have none). One list
    // reservation per workgroup: an atomic per walk on the one counter
    // (~11k a frame, the cache line bouncing between the cores) made rules
    // 40% slower on lavapipe.
    var slot = 0u;
    if (listed) { slot = atomicAdd(&wg_walks, 1u); }
    workgroupBarrier();
    if (li.x == 0u) { wg_base = atomicAdd(&counters[C_WALKS], atomicLoad(&wg_walks)); }
    workgroupBarrier();
    if (listed) { walks[wg_base + slot] = walk_entry(span.w, span.x, span.y); }
}

// The walk `span` (quad_span) of rules: its four words of `ruled` (when
// `real`); true when it is real and has an active pixel.
fn rule_walk(span: vec4<u32>, real: bool) -> bool {
    let l = span.w;
    let x0 = span.x;
    let w = lw(l);
    let cols = six_columns(x0, w);
    let inside = six_inside(x0, w);
    let y0 = i32(span.y);  // a multiple of 4: the first row of its words
    let end = i32(span.z);
    var a = six_bytes(six_words(l, cols, inside, y0 - 1), u32(y0 - 1));
    var cur = six_words(l, cols, inside, y0);
    var b = six_bytes(cur, u32(y0));
    var bits = vec4<u32>(0u);
    for (var y = y0; y < end; y += 4) {
        bits |= step(&a, &b, &cur, l, cols, inside, y, y0, end);
    }
    if (real) { ruled[tile_word(l, x0, span.y / TILE) >> 2u] = bits; }
    return real && ((bits.x | bits.y | bits.z | bits.w) & 0xffffu) != 0u;
}

// The four columns' `ruled` bits of rows y .. y + 3 (none past `end`); rows
// a (y - 1) and b (y) and the words `cur` of y's group move down a group.
fn step(a: ptr<function, Six>, b: ptr<function, Six>, cur: ptr<function, Six>, l: u32, cols: Six, inside: Six, y: i32, y0: i32, end: i32) -> vec4<u32> {
    // rows y + 4 .. y + 7: row y + 4 is the last group row's `c`
    let nxt = six_words(l, cols, inside, y + 4);
    let c0 = six_bytes(*cur, u32(y + 1));
    let c1 = six_bytes(*cur, u32(y + 2));
    let c2 = six_bytes(*cur, u32(y + 3));
    let c3 = six_bytes(nxt, u32(y + 4));
    let bits = vec4<u32>(
        quad_bits(*a, *b, c0, c1, c2, c3, 0u, y, y0, end),
        quad_bits(*a, *b, c0, c1, c2, c3, 1u, y, y0, end),
        quad_bits(*a, *b, c0, c1, c2, c3, 2u, y, y0, end),
        quad_bits(*a, *b, c0, c1, c2, c3, 3u, y, y0, end),
    );
    *a = c2;
    *b = c3;
    *cur = nxt;
    return bits;
}
