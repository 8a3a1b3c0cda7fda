// SPEC 2-3 in one walk: the LSD gradient and non-maximum suppression. Equal to
// gradient.wgsl -> nms.wgsl (which mirror src/cpu/gradient.rs, nms.rs), and
// to the CPU's fused rows (src/cpu/fused.rs, `gradient_row` and the NMS inside
// `classify_row`), without the gx, gy and S planes: those live only in registers.
// denoised -> m (M8 = min(M, 255)), nms (1 = survivor), both column-packed;
// four columns per invocation, all levels in one dispatch (over the tile list). SPEC 4's histogram of M8 is
// counted by local_threshold.wgsl's cells, which count every pixel anyway.
// Tests: tests/gpu_edges_front.rs (this pass == the three staged passes and the
// CPU) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).
//
// Races: no atomics. Each invocation stores only the `m` and `nms` words of its
// own four columns of its tile (quad_span), with the padding words past the
// level's width that its quad covers: 4 whole words per column of a tile
// (common.wgsl pk_word), quads disjoint, so no two invocations write one word.

@group(0) @binding(1) var<storage, read> denoised: array<u32>;
// `denoised` again, four columns' words a load (common.wgsl pk_pitch)
@group(0) @binding(4) var<storage, read> denoised4: array<vec4<u32>>;
// four columns' words a store, the padding past the level's width included
@group(0) @binding(2) var<storage, read_write> m: array<vec4<u32>>;
@group(0) @binding(3) var<storage, read_write> nms: array<vec4<u32>>;

// Seven neighbouring columns' D words or values: columns x0 - 1 .. x0 + 2 in
// `a`, x0 + 3 .. x0 + 5 in `b`.
struct W7 {
    a: vec4<u32>,
    b: vec3<u32>,
}
struct D7 {
    a: vec4<i32>,
    b: vec3<i32>,
}

// D is column-packed (common.wgsl pk_word). The words of columns x0 - 1 ..
// x0 + 5 holding row y, y clamped into the level (x0 - 1 only feeds S at
// x0 - 1, which is 0 at x0 = 0 whatever it reads; columns past the level
// clamp to its last).
// Columns x0 .. x0 + 3 are one aligned load; those of them past the level
// take the word at min(x0 + 4, last), which is the last column's whenever
// one is past.
fn d7_words(l: u32, x0: u32, y: u32) -> W7 {
    let row = pk_word(l, 0u, min(y, lh(l) - 1u));
    let last = lw(l) - 1u;
    let mid = denoised4[(row + x0) >> 2u];
    let e = denoised[row + min(x0 + 4u, last)];
    let past = vec4<u32>(x0) + vec4<u32>(0u, 1u, 2u, 3u) > vec4<u32>(last);
    let q = select(mid, vec4<u32>(e), past);
    return W7(vec4<u32>(denoised[row + min(max(x0, 1u) - 1u, last)], q.xyz), vec3<u32>(q.w, e, denoised[row + min(x0 + 5u, last)]));
}

// D of row y (clamped into the level) at the seven columns, from `words`
// holding it.
fn d7_at(l: u32, words: W7, y: u32) -> D7 {
    let sh = (min(y, lh(l) - 1u) & 3u) * 8u;
    return D7(vec4<i32>((words.a >> vec4<u32>(sh)) & vec4<u32>(0xffu)), vec3<i32>((words.b >> vec3<u32>(sh)) & vec3<u32>(0xffu)));
}

fn w7_select(b: W7, a: W7, yes: bool) -> W7 {
    return W7(select(b.a, a.a, yes), select(b.b, a.b, yes));
}

// (gx2, gy2) at columns x0 - 1 .. x0 + 4 (gx in x, gy in y; columns x0 - 1 ..
// x0 + 2 in `a`, x0 + 3, x0 + 4 in `b`) from D rows y (a) and y + 1 (c):
// SPEC 2's 2x2 differences, right and bottom neighbours clamped as in
// gradient.wgsl (column k's differences take columns k and k + 1).
struct G6 {
    x: Six,
    y: Six,
}
fn grad6(a: D7, c: D7) -> G6 {
    let ar = vec4<i32>(a.a.yzw, a.b.x);
    let cr = vec4<i32>(c.a.yzw, c.b.x);
    let dxa = ar + cr - a.a - c.a;
    let dya = c.a + cr - a.a - ar;
    let dxb = a.b.yz + c.b.yz - a.b.xy - c.b.xy;
    let dyb = c.b.xy + c.b.yz - a.b.xy - a.b.yz;
    return G6(Six(bitcast<vec4<u32>>(dxa), bitcast<vec2<u32>>(dxb)), Six(bitcast<vec4<u32>>(dya), bitcast<vec2<u32>>(dyb)));
}

// S at the six columns of a row whose gradients are `g`: 0 outside the level
// (`valid` says which columns are inside, and whether the row is).
fn s6(g: G6, valid: Six) -> Six {
    let xa = bitcast<vec4<i32>>(g.x.a);
    let ya = bitcast<vec4<i32>>(g.y.a);
    let xb = bitcast<vec2<i32>>(g.x.b);
    let yb = bitcast<vec2<i32>>(g.y.b);
    return Six(
        select(vec4<u32>(0u), bitcast<vec4<u32>>(xa * xa + ya * ya), valid.a != vec4<u32>(0u)),
        select(vec2<u32>(0u), bitcast<vec2<u32>>(xb * xb + yb * yb), valid.b != vec2<u32>(0u)),
    );
}

// Column x0 + k's (gx2, gy2) (position k + 1 of the six; k constant at every call).
fn g_at(g: G6, k: u32) -> vec2<i32> {
    let x = bitcast<vec3<i32>>(tri(g.x, k));
    let y = bitcast<vec3<i32>>(tri(g.y, k));
    return vec2<i32>(x.y, y.y);
}

// The walk's window at row yy: S of rows yy - 1 (up) and yy (mid) and the
// gradients of row yy at columns x0 - 1 .. x0 + 4, D of row yy + 1 at
// columns x0 - 1 .. x0 + 5.
struct Walk {
    up: Six,
    mid: Six,
    g: G6,
    dnext: D7,
}

// Column x0 + k's M8 and NMS flag in row yy's place of their words (0 past
// the walk's end), from the window and S of the row below.
fn out_px(s: Walk, down: Six, k: u32, yy: u32, end: u32) -> vec2<u32> {
    let v = tri(s.mid, k).y;
    let g = g_at(s.g, k);
    // v > first >= 0 keeps only S > 0 (SPEC 3 suppresses S = 0)
    let ab = sector_pair(g.x, g.y, tri(s.up, k), tri(s.mid, k), tri(down, k));
    let keep = select(0u, 1u, v > ab.x && v >= ab.y);
    let m8 = min(magnitude(v), 255u);
    return select(vec2<u32>(0u), vec2<u32>(pk_place(m8, yy), pk_place(keep, yy)), yy < end);
}

// Row yy of the group of rows y..y+3 (words `cur`, the next group's `nxt`):
// the four columns' M8 (`m`) and NMS flags (`nms`) in their places, and the
// window moved down a row. Called four times per group, rows written out: a
// loop over the rows costs a SIMD software rasteriser its mask bookkeeping.
struct Out4 {
    m: vec4<u32>,
    nms: vec4<u32>,
}
fn row_step(s: ptr<function, Walk>, l: u32, y: u32, yy: u32, cur: W7, nxt: W7, h: u32, cols: Six, end: u32) -> Out4 {
    // row yy + 1: its S (0 below the last row) and, next time, its gradients
    let y2 = min(yy + 2u, h - 1u);
    let dnn = d7_at(l, w7_select(nxt, cur, (y2 >> 2u) == (y >> 2u)), y2);
    let gn = grad6((*s).dnext, dnn);
    let below = select(0u, 1u, yy + 1u < h);
    let down = s6(gn, Six(cols.a * below, cols.b * below));
    let p0 = out_px(*s, down, 0u, yy, end);
    let p1 = out_px(*s, down, 1u, yy, end);
    let p2 = out_px(*s, down, 2u, yy, end);
    let p3 = out_px(*s, down, 3u, yy, end);
    (*s).up = (*s).mid;
    (*s).mid = down;
    (*s).g = gn;
    (*s).dnext = dnn;
    return Out4(vec4<u32>(p0.x, p1.x, p2.x, p3.x), vec4<u32>(p0.y, p1.y, p2.y, p3.y));
}

// A quad pass (common.wgsl quad_span): the invocation of columns x0 .. x0 + 3
// walks their rows with D of columns x0 - 1 .. x0 + 5 and S of columns
// x0 - 1 .. x0 + 4 in registers (rows y - 1, y, y + 1), so it reads seven
// words of D per word of rows for four columns, where a column walk read four
// for one (gradient_nms 3.4 -> 2.2 ms per KITTI frame on lavapipe). `step`
// takes a word (four rows): it reads the next group's seven words of D and
// writes four words of `m` and of `nms`, and `row_step` takes its four rows,
// written out. The steps are a loop (written out, they cost lavapipe's
// compile 89 ms instead of 26 and saved nothing measurable). Nothing is
// stored past the walk's end (a level's last, partial tile); past the
// level's right edge, only the padding words of its quad (common.wgsl
// pk_pitch). Four columns' words are one load or store: 1.72-1.89 ->
// 1.46-1.55 ms per KITTI frame on lavapipe, which loads and stores lane by
// lane (a vec4 at about the cost of one word).
@compute @workgroup_size(64, 1, 1)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let span = quad_span(wg, li);
    if (span.y == span.z) { return; }
    let l = span.w;
    let x0 = span.x;
    let h = lh(l);
    let w = lw(l);
    // which of columns x0 - 1 .. x0 + 4 lie in the level
    let cols = six_inside(x0, w);
    // S of row y0 - 1 (none above row 0), gradients and S of row y0
    var cur = d7_words(l, x0, span.y);
    var walk: Walk;
    walk.up = Six(vec4<u32>(0u), vec2<u32>(0u));
    if (span.y > 0u) {
        // row y0 - 1 is the last of the group before
        walk.up = s6(grad6(d7_at(l, d7_words(l, x0, span.y - 1u), span.y - 1u), d7_at(l, cur, span.y)), cols);
    }
    walk.dnext = d7_at(l, cur, span.y + 1u);
    walk.g = grad6(d7_at(l, cur, span.y), walk.dnext);
    walk.mid = s6(walk.g, cols);
    for (var y = span.y; y < span.z; y += 4u) {
        step(&walk, &cur, l, x0, y, h, cols, span.z);
    }
}

// The words of `m` and `nms` of rows y .. y + 3 of the four columns (`cur`:
// D's words of their group); nothing past the walk's end.
fn step(walk: ptr<function, Walk>, cur: ptr<function, W7>, l: u32, x0: u32, y: u32, h: u32, cols: Six, end: u32) {
    // rows y + 4 .. y + 7 (clamped): rows y + 2 .. y + 5 feed this group
    let nxt = d7_words(l, x0, y + 4u);
    let o0 = row_step(walk, l, y, y, *cur, nxt, h, cols, end);
    let o1 = row_step(walk, l, y, y + 1u, *cur, nxt, h, cols, end);
    let o2 = row_step(walk, l, y, y + 2u, *cur, nxt, h, cols, end);
    let o3 = row_step(walk, l, y, y + 3u, *cur, nxt, h, cols, end);
    *cur = nxt;
    let mw = o0.m | o1.m | o2.m | o3.m;
    let nw = o0.nms | o1.nms | o2.nms | o3.nms;
    // `m` and `nms` are column-packed: a word each per four rows and column
    if (y < end) {
        let i = pk_word(l, x0, y) >> 2u;
        m[i] = mw;
        nms[i] = nw;
    }
}
