// SPEC 2-3 in one walk: the LSD gradient and non-maximum suppression. Equal to
// gradient.wgsl -> nms.wgsl (which mirror src/cpu/gradient.rs, nms.rs), and
// to the CPU's fused rows (src/cpu/fused.rs, `gradient_row` and the NMS inside
// `classify_row`), without the gx, gy and S planes: those live only in registers.
// denoised -> m (M8 = min(M, 255)), nms (1 = survivor), both column-packed;
// all levels in one dispatch (over the tile list). SPEC 4's histogram of M8 is
// counted by local_threshold.wgsl's cells, which count every pixel anyway.
// Tests: tests/gpu_edges_front.rs (this pass == the three staged passes and the
// CPU) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).

@group(0) @binding(1) var<storage, read> denoised: array<u32>;
@group(0) @binding(2) var<storage, read_write> m: array<u32>;
@group(0) @binding(3) var<storage, read_write> nms: array<u32>;

// D is column-packed (common.wgsl pk_word). The words of columns x-1, x,
// x+1, x+2 holding row y, y clamped into the level (x-1 only feeds S at x-1,
// which is 0 at x = 0 whatever it reads; x+1 and x+2 clamp to the last column).
fn d4_words(l: u32, x: u32, y: u32) -> vec4<u32> {
    let row = pk_word(l, 0u, min(y, lh(l) - 1u));
    let last = lw(l) - 1u;
    return vec4<u32>(
        denoised[row + max(x, 1u) - 1u],
        denoised[row + x],
        denoised[row + min(x + 1u, last)],
        denoised[row + min(x + 2u, last)],
    );
}

// D of row y (clamped into the level) at the four columns, from `words`
// holding it.
fn d4_at(l: u32, words: vec4<u32>, y: u32) -> vec4<i32> {
    return vec4<i32>(pk_byte4(words, min(y, lh(l) - 1u)));
}

// (gx2, gy2) at columns x-1, x, x+1 from D rows y (a) and y + 1 (c): SPEC 2's
// 2x2 differences, right and bottom neighbours clamped as in gradient.wgsl.
fn grad3(a: vec4<i32>, c: vec4<i32>) -> array<vec2<i32>, 3> {
    // columns k and k + 1 of rows a and c give column k's differences
    let dx = a.yzw + c.yzw - a.xyz - c.xyz;
    let dy = c.xyz + c.yzw - a.xyz - a.yzw;
    return array<vec2<i32>, 3>(vec2(dx.x, dy.x), vec2(dx.y, dy.y), vec2(dx.z, dy.z));
}

// S at columns x-1, x, x+1 of a row whose gradients are `g`: 0 outside the
// level (`valid` says which columns are inside, and whether the row is).
fn s3(g: array<vec2<i32>, 3>, valid: vec3<bool>) -> vec3<u32> {
    let s0 = u32(g[0].x * g[0].x + g[0].y * g[0].y);
    let s1 = u32(g[1].x * g[1].x + g[1].y * g[1].y);
    let s2 = u32(g[2].x * g[2].x + g[2].y * g[2].y);
    return select(vec3<u32>(0u), vec3<u32>(s0, s1, s2), valid);
}

// The walk's window at row yy: S of rows yy - 1 (up) and yy (mid) at columns
// x-1..x+1, the gradients of row yy, D of row yy + 1 at columns x-1..x+2.
struct Walk {
    up: vec3<u32>,
    mid: vec3<u32>,
    g: array<vec2<i32>, 3>,
    dnext: vec4<i32>,
}

// Row yy of the group of rows y..y+3 (words `cur`, the next group's `nxt`):
// its M8 and NMS flag in their places (0 past the walk's end), and the window
// moved down a row. Called four times per group, rows written out: a loop
// over the rows costs a SIMD software rasteriser its mask bookkeeping.
fn row_step(s: ptr<function, Walk>, l: u32, y: u32, yy: u32, cur: vec4<u32>, nxt: vec4<u32>, h: u32, cols: vec3<bool>, end: u32) -> vec2<u32> {
    // row yy + 1: its S (0 below the last row) and, next time, its gradients
    let y2 = min(yy + 2u, h - 1u);
    let dnn = d4_at(l, select(nxt, cur, (y2 >> 2u) == (y >> 2u)), y2);
    let gn = grad3((*s).dnext, dnn);
    let down = s3(gn, select(vec3<bool>(false), cols, yy + 1u < h));
    let v = (*s).mid.y;
    // v > first >= 0 keeps only S > 0 (SPEC 3 suppresses S = 0)
    let ab = sector_pair((*s).g[1].x, (*s).g[1].y, (*s).up, (*s).mid, down);
    let keep = select(0u, 1u, v > ab.x && v >= ab.y);
    let m8 = min(magnitude(v), 255u);
    (*s).up = (*s).mid;
    (*s).mid = down;
    (*s).g = gn;
    (*s).dnext = dnn;
    // rows past the walk's end stay 0 (rows past the level's last are 0)
    return select(vec2<u32>(0u), vec2<u32>(pk_place(m8, yy), pk_place(keep, yy)), yy < end);
}

// A column pass (tile_column): the invocation of column x walks its rows with
// D of columns x-1..x+2 and S of columns x-1..x+1 in registers (rows y-1, y,
// y+1). `step` takes a word (four rows): it reads the next group's four words
// of D and writes one word of `m` and of `nms`, all unconditionally, and
// `row_step` takes its four rows. (Loads cached under `if` and
// stores under `if`, the earlier form, ran every row on a SIMD software
// rasteriser, which executes an if-body masked for every lane.)
@compute @workgroup_size(64, 1, 1)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let span = column_span(wg, li);
    if (span.y == span.z) { return; }
    let l = span.w;
    let x = span.x;
    let h = lh(l);
    let cols = vec3<bool>(x > 0u, true, x + 1u < lw(l));
    // S of row y0 - 1 (none above row 0), gradients and S of row y0
    var cur = d4_words(l, x, span.y);
    var walk: Walk;
    walk.up = vec3<u32>(0u);
    if (span.y > 0u) {
        // row y0 - 1 is the last of the group before
        walk.up = s3(grad3(d4_at(l, d4_words(l, x, span.y - 1u), span.y - 1u), d4_at(l, cur, span.y)), cols);
    }
    walk.dnext = d4_at(l, cur, span.y + 1u);
    walk.g = grad3(d4_at(l, cur, span.y), walk.dnext);
    walk.mid = s3(walk.g, cols);
    // the walk's four words (TILE rows), written out: a loop costs a SIMD
    // software rasteriser its masks every iteration
    var st = vec3<u32>(0u);
    step(&walk, &cur, l, x, span.y, h, cols, span.z, &st);
    step(&walk, &cur, l, x, span.y + 4u, h, cols, span.z, &st);
    step(&walk, &cur, l, x, span.y + 8u, h, cols, span.z, &st);
    step(&walk, &cur, l, x, span.y + 12u, h, cols, span.z, &st);
}

// The words of `m` and `nms` of rows y .. y + 3 (`cur`: D's words of their
// group); `st` is the last store (index, m word, nms word), stored again
// when y is past the walk's end (a level's last, partial tile): no store
// under `if`.
fn step(
    walk: ptr<function, Walk>,
    cur: ptr<function, vec4<u32>>,
    l: u32,
    x: u32,
    y: u32,
    h: u32,
    cols: vec3<bool>,
    end: u32,
    st: ptr<function, vec3<u32>>,
) {
    // rows y + 4 .. y + 7 (clamped): rows y + 2 .. y + 5 feed this group
    let nxt = d4_words(l, x, y + 4u);
    var out = row_step(walk, l, y, y, *cur, nxt, h, cols, end);
    out |= row_step(walk, l, y, y + 1u, *cur, nxt, h, cols, end);
    out |= row_step(walk, l, y, y + 2u, *cur, nxt, h, cols, end);
    out |= row_step(walk, l, y, y + 3u, *cur, nxt, h, cols, end);
    *cur = nxt;
    // `m` and `nms` are column-packed: a word each per four rows
    *st = select(*st, vec3<u32>(pk_word(l, x, y), out), y < end);
    m[(*st).x] = (*st).y;
    nms[(*st).x] = (*st).z;
}
