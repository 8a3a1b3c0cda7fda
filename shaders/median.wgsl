// SPEC 1: noise-flagged 3x3 median. Mirrors src/cpu/median.rs.
// Four columns of a tile per invocation, all levels in one dispatch (over the tile list).
// `src` (the gray levels) and `dst` (D) are column-packed (common.wgsl pk_word).
// Tests: tests/gpu_median.rs (this pass alone == src/cpu/median.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).
//
// Races: no atomics. Each invocation stores only the `dst` words of its own four
// columns of its tile and the padding words past the level's width that its
// quad covers (4 whole words per column of a tile, common.wgsl
// pk_word), quads disjoint, so no two invocations write one word.

@group(0) @binding(1) var<storage, read> src: array<u32>;
// `src` again, four columns' words a load (common.wgsl pk_pitch)
@group(0) @binding(3) var<storage, read> src4: array<vec4<u32>>;
// four columns' words a store, the padding past the level's width included
@group(0) @binding(2) var<storage, read_write> dst: array<vec4<u32>>;

// |G - Gn| > delta * G for all four neighbours (up, down, left, right), as
// integers (u32 cannot overflow: delta_den <= 10^4, delta_num <= 10^6, values <= 255).
fn is_noise(g: u32, n: vec4<u32>) -> bool {
    let gv = vec4<u32>(g);
    let d = select(n - gv, gv - n, gv >= n);
    return all(vec4<u32>(P.delta_den) * d > vec4<u32>(P.delta_num * g));
}

// The 19-exchange network of median9 in src/cpu/median.rs, written out with
// constant indices: a table-driven loop indexes the 9 values dynamically,
// which puts them in memory instead of registers on real GPUs.
// a, b, c: the rows above, at and below, each (left, centre, right).
fn median9(a: vec3<u32>, b: vec3<u32>, c: vec3<u32>) -> u32 {
    var p0 = a.x;
    var p1 = a.y;
    var p2 = a.z;
    var p3 = b.x;
    var p4 = b.y;
    var p5 = b.z;
    var p6 = c.x;
    var p7 = c.y;
    var p8 = c.z;
    var t: u32;
    t = min(p1, p2); p2 = max(p1, p2); p1 = t;
    t = min(p4, p5); p5 = max(p4, p5); p4 = t;
    t = min(p7, p8); p8 = max(p7, p8); p7 = t;
    t = min(p0, p1); p1 = max(p0, p1); p0 = t;
    t = min(p3, p4); p4 = max(p3, p4); p3 = t;
    t = min(p6, p7); p7 = max(p6, p7); p6 = t;
    t = min(p1, p2); p2 = max(p1, p2); p1 = t;
    t = min(p4, p5); p5 = max(p4, p5); p4 = t;
    t = min(p7, p8); p8 = max(p7, p8); p7 = t;
    t = min(p0, p3); p3 = max(p0, p3); p0 = t;
    t = min(p5, p8); p8 = max(p5, p8); p5 = t;
    t = min(p4, p7); p7 = max(p4, p7); p4 = t;
    t = min(p3, p6); p6 = max(p3, p6); p3 = t;
    t = min(p1, p4); p4 = max(p1, p4); p1 = t;
    t = min(p2, p5); p5 = max(p2, p5); p2 = t;
    t = min(p4, p7); p7 = max(p4, p7); p4 = t;
    t = min(p4, p2); p2 = max(p4, p2); p4 = t;
    t = min(p6, p4); p4 = max(p6, p4); p6 = t;
    t = min(p4, p2); p2 = max(p4, p2); p4 = t;
    return p4;
}

// The six columns' words (`cols`, six_columns) holding row y of level l,
// y clamped into the level. Columns x0 .. x0 + 3 (x0 = cols.a.y) are one
// aligned load; those of them past the level (clamped below x0 + k) take the
// word of cols.b.y = min(x0 + 4, last), the last column's whenever one is past.
fn six_at(l: u32, cols: Six, y: u32) -> Six {
    let r = pk_word(l, 0u, min(y, lh(l) - 1u));
    let mid = src4[(r + cols.a.y) >> 2u];
    let e = src[r + cols.b.y];
    let past = vec4<u32>(cols.a.yzw, cols.b.x) < vec4<u32>(cols.a.y) + vec4<u32>(0u, 1u, 2u, 3u);
    let q = select(mid, vec4<u32>(e), past);
    return Six(vec4<u32>(src[r + cols.a.x], q.xyz), vec2<u32>(q.w, e));
}

// Row y + r + 1 (clamped into the level) of the six columns, from this
// group's words or the next's.
fn below(cur: Six, nxt: Six, y: u32, r: u32, h: u32) -> Six {
    let yc = min(y + r + 1u, h - 1u);
    return six_bytes(six_select(nxt, cur, (yc >> 2u) == (y >> 2u)), yc);
}

// D of row yy in its place in the word, from rows a (above), b, c (below);
// 0 past the walk's end.
fn out_row(a: vec3<u32>, b: vec3<u32>, c: vec3<u32>, yy: u32, end: u32) -> u32 {
    var v = b.y;
    if (is_noise(v, vec4<u32>(a.y, c.y, b.x, b.z))) { v = median9(a, b, c); }
    return select(0u, pk_place(v, yy), yy < end);
}

// Column x0 + k's word of rows y .. y + 3, from rows a (y - 1), b (y) and
// c0 .. c3 (y + 1 .. y + 4) of the six columns.
fn out_word(a: Six, b: Six, c0: Six, c1: Six, c2: Six, c3: Six, k: u32, y: u32, end: u32) -> u32 {
    return out_row(tri(a, k), tri(b, k), tri(c0, k), y, end) | out_row(tri(b, k), tri(c0, k), tri(c1, k), y + 1u, end)
        | out_row(tri(c0, k), tri(c1, k), tri(c2, k), y + 2u, end)
        | out_row(tri(c1, k), tri(c2, k), tri(c3, k), y + 3u, end);
}

// A quad pass (common.wgsl quad_span): each invocation walks four columns of
// a tile with the 3x3 windows of all four in registers (six columns' words),
// so a word is read about 1.5 times, not 3 (median 2.4 -> 1.75 ms per KITTI
// frame on lavapipe). `step` takes a word of rows, reading the next group's
// six words unconditionally, in a loop over the walk's words: with four
// columns a step, the loop's masks cost lavapipe nothing measurable, and
// the four steps written out tripled its compile of the pass (23 -> 73 ms).
// Nothing is stored past the walk's end (a level's last, partial tile);
// past the level's right edge, only the padding words of its quad
// (common.wgsl pk_pitch). Four columns' words are one load or store:
// 1.32-1.38 -> 1.12-1.16 ms per KITTI frame on lavapipe.
@compute @workgroup_size(64, 1, 1)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let span = quad_span(wg, li);
    if (span.y == span.z) { return; }
    let l = span.w;
    let cols = six_columns(span.x, lw(l));
    // row y0 - 1 (clamped: row 0 above the first), then the group of y0
    let ya = select(span.y - 1u, 0u, span.y == 0u);
    var a = six_bytes(six_at(l, cols, ya), ya);
    var cur = six_at(l, cols, span.y);
    var b = six_bytes(cur, span.y);
    for (var y = span.y; y < span.z; y += 4u) {
        step(&a, &b, &cur, cols, y, span);
    }
}

// One word of rows of the walk (rows y .. y + 3): rows a (y - 1) and b (y)
// and the words `cur` of y's group move down a group.
fn step(a: ptr<function, Six>, b: ptr<function, Six>, cur: ptr<function, Six>, cols: Six, y: u32, span: vec4<u32>) {
    let l = span.w;
    let h = lh(l);
    // the next group's words (its first row, clamped, is row y + 4's)
    let nxt = six_at(l, cols, y + 4u);
    let c0 = below(*cur, nxt, y, 0u, h);
    let c1 = below(*cur, nxt, y, 1u, h);
    let c2 = below(*cur, nxt, y, 2u, h);
    let c3 = below(*cur, nxt, y, 3u, h);
    let w0 = out_word(*a, *b, c0, c1, c2, c3, 0u, y, span.z);
    let w1 = out_word(*a, *b, c0, c1, c2, c3, 1u, y, span.z);
    let w2 = out_word(*a, *b, c0, c1, c2, c3, 2u, y, span.z);
    let w3 = out_word(*a, *b, c0, c1, c2, c3, 3u, y, span.z);
    *a = c2;
    *b = c3;
    *cur = nxt;
    if (y < span.z) {
        dst[pk_word(l, span.x, y) >> 2u] = vec4<u32>(w0, w1, w2, w3);
    }
}
