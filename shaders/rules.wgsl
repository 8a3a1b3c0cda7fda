// SPEC 7 rules 1 and 2: isolated-edge suppression (paper Algorithm 3).
// Mirrors src/cpu/rules.rs. `classes` (SPEC 6, column-packed, common.wgsl
// pk_word) -> `ruled`, in which only NONE, WEAK and STRONG remain, as bits: one
// word per column of every tile (common.wgsl tile_word), bit r = row 16 ty + r
// is active (WEAK or STRONG), bit 16 + r is STRONG (gpu::layout::pack_ruled).
// Hysteresis reads them so, a word per column walk. A column pass, all
// levels in one dispatch (over the tile list). Both rules read the classes
// of SPEC 6 only, so the result does not depend on the order of invocations.
// Tests: tests/gpu_edges_back.rs (this pass alone == src/cpu/rules.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).

@group(0) @binding(1) var<storage, read> classes: array<u32>;
@group(0) @binding(2) var<storage, read_write> ruled: array<u32>;

// Classes of src/cpu/classify.rs.
const NONE: u32 = 0u;
const WEAK_WEAK: u32 = 1u;
const WEAK: u32 = 2u;
const WEAK_STRONG: u32 = 3u;
const STRONG: u32 = 4u;

// The packed words of columns (x-1, x, x+1) holding row y of level l (rows
// y & ~3 .. + 4); 0, all NONE, outside the level (no replicate border here: a
// missing neighbour matches no searched class, as rule_at only looks for
// WEAK_STRONG and WEAK_WEAK; rows past the last of a word are NONE too).
fn words3(l: u32, x: u32, y: i32) -> vec3<u32> {
    // the three loads unconditional (clamped row and columns), then zeroed
    // outside the level
    let inside = y >= 0 && y < i32(lh(l));
    let i = pk_word(l, x, u32(clamp(y, 0, i32(lh(l)) - 1)));
    let left = classes[i - select(0u, 1u, x > 0u)];
    let right = classes[i + select(0u, 1u, x + 1u < lw(l))];
    let r = vec3<u32>(select(0u, left, x > 0u), classes[i], select(0u, right, x + 1u < lw(l)));
    return select(vec3<u32>(0u), r, inside);
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

// A column pass (tile_column): the 3x3 window walks down in registers. `step`
// takes a word (four rows), reading the next group's three words
// unconditionally, with the four rows written out (`ruled_bits`); the walk's
// four words are written out too, no loop (a SIMD software rasteriser pays a
// loop's masks every iteration; steps past the walk's end add no bits). The
// walk's word of `ruled` is written once at the end (see median.wgsl for why
// not under `if`).
@compute @workgroup_size(64, 1, 1)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let span = column_span(wg, li);
    if (span.y == span.z) { return; }
    let l = span.w;
    let x = span.x;
    let y0 = i32(span.y);  // a multiple of 4: the first row of its words
    let end = i32(span.z);
    var a = pk_byte3(words3(l, x, y0 - 1), u32(y0 - 1));
    var cur = words3(l, x, y0);
    var b = pk_byte3(cur, u32(y0));
    let bits = step(&a, &b, &cur, l, x, y0, y0, end) | step(&a, &b, &cur, l, x, y0 + 4, y0, end)
        | step(&a, &b, &cur, l, x, y0 + 8, y0, end) | step(&a, &b, &cur, l, x, y0 + 12, y0, end);
    ruled[tile_word(l, x, span.y / TILE)] = bits;
}

// The `ruled` bits of rows y .. y + 3 (none past `end`); rows a (y - 1) and
// b (y) and the words `cur` of y's group move down a group.
fn step(a: ptr<function, vec3<u32>>, b: ptr<function, vec3<u32>>, cur: ptr<function, vec3<u32>>, l: u32, x: u32, y: i32, y0: i32, end: i32) -> u32 {
    // rows y + 4 .. y + 7: row y + 4 is the last group row's `c`
    let nxt = words3(l, x, y + 4);
    let c0 = pk_byte3(*cur, u32(y + 1));
    let c1 = pk_byte3(*cur, u32(y + 2));
    let c2 = pk_byte3(*cur, u32(y + 3));
    let c3 = pk_byte3(nxt, u32(y + 4));
    let bits = ruled_bits(*a, *b, c0, y, y0, end) | ruled_bits(*b, c0, c1, y + 1, y0, end)
        | ruled_bits(c0, c1, c2, y + 2, y0, end) | ruled_bits(c1, c2, c3, y + 3, y0, end);
    *a = c2;
    *b = c3;
    *cur = nxt;
    return bits;
}
