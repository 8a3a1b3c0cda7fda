// SPEC 1: noise-flagged 3x3 median. Mirrors src/cpu/median.rs.
// One invocation per column of a tile, all levels in one dispatch (over the tile list).
// `src` (the gray levels) and `dst` (D) are column-packed (common.wgsl pk_word).
// Tests: tests/gpu_median.rs (this pass alone == src/cpu/median.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).

@group(0) @binding(1) var<storage, read> src: array<u32>;
@group(0) @binding(2) var<storage, read_write> dst: array<u32>;

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

// The words of columns xl, x, xr (x-1, x, x+1 clamped) holding row y of
// level l, y clamped into the level.
fn words3_at(l: u32, xl: u32, x: u32, xr: u32, y: u32) -> vec3<u32> {
    let yc = min(y, lh(l) - 1u);
    return vec3<u32>(src[pk_word(l, xl, yc)], src[pk_word(l, x, yc)], src[pk_word(l, xr, yc)]);
}

// Row y + r + 1 (clamped into the level) of the three columns, from this
// group's words or the next's.
fn below(cur: vec3<u32>, nxt: vec3<u32>, y: u32, r: u32, h: u32) -> vec3<u32> {
    let yc = min(y + r + 1u, h - 1u);
    return pk_byte3(select(nxt, cur, (yc >> 2u) == (y >> 2u)), yc);
}

// D of row yy in its place in the word, from rows a (above), b, c (below);
// 0 past the walk's end.
fn out_row(a: vec3<u32>, b: vec3<u32>, c: vec3<u32>, yy: u32, end: u32) -> u32 {
    var v = b.y;
    if (is_noise(v, vec4<u32>(a.y, c.y, b.x, b.z))) { v = median9(a, b, c); }
    return select(0u, pk_place(v, yy), yy < end);
}

// A column pass (tile_column): each invocation walks one column of a tile
// with the 3x3 window in registers: `step` takes a word (four rows), reading
// the next group's three words unconditionally, and the walk's four words are
// written out, no loop (a SIMD software rasteriser pays a loop's masks every
// iteration: median 2.9 -> 2.4 ms per KITTI frame on lavapipe). A step past
// the walk's end (a level's last, partial tile) stores the last word again at
// its place. (A load cached under `if`, an earlier form, ran every row on a
// SIMD software rasteriser, which executes an if-body masked for every lane.)
@compute @workgroup_size(64, 1, 1)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let span = column_span(wg, li);
    if (span.y == span.z) { return; }
    let l = span.w;
    let w = lw(l);
    let h = lh(l);
    let x = span.x;
    let xl = select(x - 1u, 0u, x == 0u);
    let xr = min(x + 1u, w - 1u);
    // row y0 - 1 (clamped: row 0 above the first), then the group of y0
    let ya = select(span.y - 1u, 0u, span.y == 0u);
    var a = pk_byte3(words3_at(l, xl, x, xr, ya), ya);
    var cur = words3_at(l, xl, x, xr, span.y);
    var b = pk_byte3(cur, span.y);
    // the walk's four words (TILE rows), written out
    var st = vec2<u32>(0u);
    step(&a, &b, &cur, l, xl, x, xr, span.y, span, h, &st);
    step(&a, &b, &cur, l, xl, x, xr, span.y + 4u, span, h, &st);
    step(&a, &b, &cur, l, xl, x, xr, span.y + 8u, span, h, &st);
    step(&a, &b, &cur, l, xl, x, xr, span.y + 12u, span, h, &st);
}

// One word of the walk (rows y .. y + 3): rows a (y - 1) and b (y) and the
// words `cur` of y's group move down a group; `st` is the last store (index,
// word), repeated when y is past the walk's end.
fn step(
    a: ptr<function, vec3<u32>>,
    b: ptr<function, vec3<u32>>,
    cur: ptr<function, vec3<u32>>,
    l: u32,
    xl: u32,
    x: u32,
    xr: u32,
    y: u32,
    span: vec4<u32>,
    h: u32,
    st: ptr<function, vec2<u32>>,
) {
    // the next group's words (its first row, clamped, is row y + 4's)
    let nxt = words3_at(l, xl, x, xr, y + 4u);
    let c0 = below(*cur, nxt, y, 0u, h);
    let c1 = below(*cur, nxt, y, 1u, h);
    let c2 = below(*cur, nxt, y, 2u, h);
    let c3 = below(*cur, nxt, y, 3u, h);
    let word = out_row(*a, *b, c0, y, span.z) | out_row(*b, c0, c1, y + 1u, span.z)
        | out_row(c0, c1, c2, y + 2u, span.z) | out_row(c1, c2, c3, y + 3u, span.z);
    *a = c2;
    *b = c3;
    *cur = nxt;
    *st = select(*st, vec2<u32>(pk_word(l, x, y), word), y < span.z);
    dst[(*st).x] = (*st).y;
}
