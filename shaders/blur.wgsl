// SPEC 11: the 7x7 sigma-2 Gaussian (integer Q8 weights, BORDER_REFLECT_101)
// smoothing the levels before description. Mirrors src/cpu/blur.rs
// (`gaussian_blur_into`, `blur_any`): a horizontal pass to Q8 sums in
// `blur_tmp` (< 2^16, as the CPU's u16; two rows per word), then a vertical
// pass to Q16, rounded, into `smoothed` (column-packed, common.wgsl pk_word).
// All levels per dispatch (over the tile list): the horizontal pass takes 4x4
// blocks of tiles, the vertical one walks columns (shaders/common.wgsl).
// Tests: tests/gpu_levels.rs (this pass alone == src/cpu/blur.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).

// `gray` is column-packed (common.wgsl pk_word).
@group(0) @binding(1) var<storage, read> gray: array<u32>;
@group(0) @binding(2) var<storage, read_write> blur_tmp: array<u32>;
// `smoothed` is Buffers::smooth (`smooth` is a WGSL reserved word).
@group(0) @binding(3) var<storage, read_write> smoothed: array<u32>;

// cpu::blur::ORB_KERNEL
const ORB_KERNEL: array<u32, 7> = array<u32, 7>(18u, 34u, 49u, 54u, 49u, 34u, 18u);
const R: i32 = 3;

// BORDER_REFLECT_101 index (gfedcb|abcdefgh|gfedcba) of i in -6 ..= len + 5
// (the taps reach 3 rows or columns past the level, from at most 3 past its
// last); a 1-pixel axis clamps. Folds at 0 and at len - 1: the first fold
// brings i within 2 (len - 1) of the range, the second into it, for len >= 3;
// len 2 alternates (i & 1). Straight-line, no loop and no division: a SIMD
// software rasteriser pays a loop's masks on every call, and divides lane by
// lane.
fn reflected(i: i32, len: i32) -> u32 {
    let p = len - 1;
    let j = p - abs(p - abs(p - abs(p - abs(i))));
    return u32(select(select(j, i & 1, p == 1), 0, p <= 0));
}

// The seven taps of ORB_KERNEL over v0..v6.
fn taps(v0: u32, v1: u32, v2: u32, v3: u32, v4: u32, v5: u32, v6: u32) -> u32 {
    return ORB_KERNEL[0] * v0 + ORB_KERNEL[1] * v1 + ORB_KERNEL[2] * v2 + ORB_KERNEL[3] * v3
        + ORB_KERNEL[4] * v4 + ORB_KERNEL[5] * v5 + ORB_KERNEL[6] * v6;
}

// The seven taps over the four rows of packed words v0..v6 (byte r of each
// word is row r of its column).
fn taps4(v0: u32, v1: u32, v2: u32, v3: u32, v4: u32, v5: u32, v6: u32) -> vec4<u32> {
    return ORB_KERNEL[0] * pk_rows(v0) + ORB_KERNEL[1] * pk_rows(v1) + ORB_KERNEL[2] * pk_rows(v2)
        + ORB_KERNEL[3] * pk_rows(v3) + ORB_KERNEL[4] * pk_rows(v4) + ORB_KERNEL[5] * pk_rows(v5)
        + ORB_KERNEL[6] * pk_rows(v6);
}

// `blur_tmp` holds two rows of a column per word, row 2k in the low half of
// word loff(l) + k * w + x (the first half of the level's atlas range).
//
// The horizontal pass's stores: base word k (column x0, rows y0, y0 + 1),
// the offset `below` of the second pair (0 past the level's last row), the
// column c last stored and its two words.
struct Stores {
    k: u32,
    below: u32,
    c: u32,
    lo: u32,
    hi: u32,
}

// Stores column `col` of the four (taps t of its four rows) when `inside`,
// else column c (the last inside) again: the same words at the same place.
fn store_column(st: ptr<function, Stores>, col: u32, inside: bool, t: vec4<u32>) {
    (*st).c = select((*st).c, col, inside);
    (*st).lo = select((*st).lo, t.x | (t.y << 16u), inside);
    (*st).hi = select((*st).hi, select((*st).lo, t.z | (t.w << 16u), (*st).below != 0u), inside);
    blur_tmp[(*st).k + (*st).c] = (*st).lo;
    blur_tmp[(*st).k + (*st).c + (*st).below] = (*st).hi;
}

// Horizontal: each invocation takes four columns of one packed word row
// (four rows) of a tile: lane r of the tile's 16 has columns 4 (r % 4) .. + 4
// and rows 4 (r / 4) .. + 4. It reads the ten gray words of columns x0 - 3 ..
// x0 + 6 (reflected) once, and one gray word gives four rows' taps, which two
// blur_tmp words take. The four columns are written out, no loop, and the
// stores are unconditional: a column past the level's edge, or a pair of rows
// past its last row, stores the value before it again at the same place (a
// SIMD software rasteriser runs a store under `if` for every lane).
@compute @workgroup_size(64, 1, 1)
fn horizontal(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let o = workgroup_tile(wg, li.x / TILE);
    if (o.x == NO_TILE) { return; }
    let l = o.z;
    let r = li.x % TILE;
    let x0 = o.x + 4u * (r % 4u);
    let y0 = o.y + 4u * (r / 4u);
    let w = lw(l);
    let h = lh(l);
    if (x0 >= w || y0 >= h) { return; }
    let iw = i32(w);
    let ix = i32(x0);
    let v0 = gray[pk_word(l, reflected(ix - 3, iw), y0)];
    let v1 = gray[pk_word(l, reflected(ix - 2, iw), y0)];
    let v2 = gray[pk_word(l, reflected(ix - 1, iw), y0)];
    let v3 = gray[pk_word(l, x0, y0)];
    let v4 = gray[pk_word(l, reflected(ix + 1, iw), y0)];
    let v5 = gray[pk_word(l, reflected(ix + 2, iw), y0)];
    let v6 = gray[pk_word(l, reflected(ix + 3, iw), y0)];
    let v7 = gray[pk_word(l, reflected(ix + 4, iw), y0)];
    let v8 = gray[pk_word(l, reflected(ix + 5, iw), y0)];
    let v9 = gray[pk_word(l, reflected(ix + 6, iw), y0)];
    var st: Stores;
    st.k = loff(l) + (y0 >> 1u) * w + x0;
    // the second pair of rows only inside the level, else the first again
    st.below = select(0u, w, y0 + 2u < h);
    store_column(&st, 0u, true, taps4(v0, v1, v2, v3, v4, v5, v6));
    // columns x0 + 1 .. x0 + 3 only inside the level, else column x0 + c - 1 again
    store_column(&st, 1u, x0 + 1u < w, taps4(v1, v2, v3, v4, v5, v6, v7));
    store_column(&st, 2u, x0 + 2u < w, taps4(v2, v3, v4, v5, v6, v7, v8));
    store_column(&st, 3u, x0 + 3u < w, taps4(v3, v4, v5, v6, v7, v8, v9));
}

// Row y (inside level l) of column x of `blur_tmp`.
fn tmp_row(l: u32, x: u32, y: u32) -> u32 {
    return (blur_tmp[loff(l) + (y >> 1u) * lw(l) + x] >> ((y & 1u) * 16u)) & 0xffffu;
}

// Row y of the smoothed column from blur_tmp rows y - 3 .. y + 3, in its place
// in the packed word; 0 past the walk's end.
fn smoothed_row(v0: u32, v1: u32, v2: u32, v3: u32, v4: u32, v5: u32, v6: u32, y: u32, end: u32) -> u32 {
    return select(0u, pk_place((taps(v0, v1, v2, v3, v4, v5, v6) + (1u << 15u)) >> 16u, y), y < end);
}

// A column pass (tile_column): each invocation walks one column of a tile and
// writes `smoothed` column-packed, a word per four rows. It keeps blur_tmp
// rows y - 3 .. y + 3 in registers; each of the walk's four steps (written
// out) reads rows y + 4 .. y + 7, two pair words, unconditionally (pair index
// clamped into the level), and the four rows are written out. Rows past the level's last (at
// most three are needed, reflected) are read again in a `while` loop that
// only runs in the walks at the bottom of a level.
@compute @workgroup_size(64, 1, 1)
fn vertical(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let span = column_span(wg, li);
    if (span.y == span.z) { return; }
    let l = span.w;
    let x = span.x;
    let h = lh(l);
    let ih = i32(h);
    let y0 = i32(span.y);
    var a: Rows7;
    a.r0 = tmp_row(l, x, reflected(y0 - 3, ih));
    a.r1 = tmp_row(l, x, reflected(y0 - 2, ih));
    a.r2 = tmp_row(l, x, reflected(y0 - 1, ih));
    a.r3 = tmp_row(l, x, span.y);
    a.r4 = tmp_row(l, x, reflected(y0 + 1, ih));
    a.r5 = tmp_row(l, x, reflected(y0 + 2, ih));
    a.r6 = tmp_row(l, x, reflected(y0 + 3, ih));
    // the walk's four words (TILE rows), written out: a loop costs a SIMD
    // software rasteriser its masks every iteration
    let c = VColumn(l, x, lw(l), h, loff(l) + x, span.z);
    var st = vec2<u32>(0u);
    vstep(&a, c, span.y, &st);
    vstep(&a, c, span.y + 4u, &st);
    vstep(&a, c, span.y + 8u, &st);
    vstep(&a, c, span.y + 12u, &st);
}

// blur_tmp rows y - 3 .. y + 3 of a walk's column.
struct Rows7 {
    r0: u32,
    r1: u32,
    r2: u32,
    r3: u32,
    r4: u32,
    r5: u32,
    r6: u32,
}

// A vertical walk's column x of level l: the level's width and height, the
// column's atlas index in row 0 of `blur_tmp`, the walk's end row.
struct VColumn {
    l: u32,
    x: u32,
    w: u32,
    h: u32,
    col: u32,
    end: u32,
}

// The word of `smoothed` of rows y .. y + 3 of column x (a: blur_tmp rows
// y - 3 .. y + 3, moved down four rows); `st` is the last store (index,
// word), stored again when y is past the walk's end (a level's last,
// partial tile): no store under `if`.
fn vstep(a: ptr<function, Rows7>, c: VColumn, y: u32, st: ptr<function, vec2<u32>>) {
    let l = c.l;
    let x = c.x;
    let h = c.h;
    let w = c.w;
    let end = c.end;
    let last_pair = (h - 1u) >> 1u;
    let col = c.col;
    let p = blur_tmp[col + min((y + 4u) >> 1u, last_pair) * w];
    let q = blur_tmp[col + min((y + 6u) >> 1u, last_pair) * w];
    var b4 = p & 0xffffu;
    var b5 = p >> 16u;
    var b6 = q & 0xffffu;
    var b7 = q >> 16u;
    // rows past the level's last: their reflection (bottom walks only; none
    // for a step past the walk's end, whose word is not stored)
    let inside = min(select(0u, h - (y + 4u), h > y + 4u), 4u);
    var past = select(0u, 0xfu & ~((1u << inside) - 1u), y < end);
    while (past != 0u) {
        let k = firstTrailingBit(past);
        past &= past - 1u;
        let v = tmp_row(l, x, reflected(i32(y + 4u + k), i32(h)));
        b4 = select(b4, v, k == 0u);
        b5 = select(b5, v, k == 1u);
        b6 = select(b6, v, k == 2u);
        b7 = select(b7, v, k == 3u);
    }
    let r = *a;
    let word = smoothed_row(r.r0, r.r1, r.r2, r.r3, r.r4, r.r5, r.r6, y, end)
        | smoothed_row(r.r1, r.r2, r.r3, r.r4, r.r5, r.r6, b4, y + 1u, end)
        | smoothed_row(r.r2, r.r3, r.r4, r.r5, r.r6, b4, b5, y + 2u, end)
        | smoothed_row(r.r3, r.r4, r.r5, r.r6, b4, b5, b6, y + 3u, end);
    *a = Rows7(r.r4, r.r5, r.r6, b4, b5, b6, b7);
    *st = select(*st, vec2<u32>(pk_word(l, x, y), word), y < end);
    smoothed[(*st).x] = (*st).y;
}
