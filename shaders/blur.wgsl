// SPEC 11: the 7x7 sigma-2 Gaussian (integer Q8 weights, BORDER_REFLECT_101)
// smoothing the levels before description. Mirrors src/cpu/blur.rs
// (`gaussian_blur_into`, `blur_any`): horizontal taps to Q8 sums (< 2^16, the
// CPU's u16), then vertical taps to Q16, rounded, into `smoothed`
// (column-packed, common.wgsl pk_word). One quad pass over all levels (over
// the tile list, common.wgsl quad_span): each invocation walks four columns
// of a tile and keeps the horizontal sums of the rows its vertical taps need
// in registers, so they never reach memory (two passes through a u32 plane,
// `blur_tmp`, took 4.3 ms per KITTI frame on lavapipe; this one pass 2.2).
// Only the tiles marked in `blur_tiles` are smoothed: those holding a pixel
// a descriptor reads (select.wgsl's place marks them, for every final
// keypoint; ~60% of a KITTI frame's). The rest of `smoothed` is left as it was, and
// nothing reads it.
// Tests: tests/gpu_levels.rs (this pass alone, every tile marked ==
// src/cpu/blur.rs), tests/gpu_blur_tiles.rs (some marked: those == the CPU's,
// the others untouched) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).
//
// Races: no atomics. Each invocation stores only the `smoothed` words of its
// own four columns of its tile (quad_span; past the level's width, the
// padding words its quad covers); a tile's 16 rows are 4 whole words
// of a column (common.wgsl pk_word) and the quads of the tile list do not
// overlap, so no two invocations write one word.

// `gray` is column-packed (common.wgsl pk_word).
@group(0) @binding(1) var<storage, read> gray: array<u32>;
// `smoothed` is Buffers::smooth (`smooth` is a WGSL reserved word).
// Four columns' words a store (common.wgsl pk_pitch), padding included.
@group(0) @binding(2) var<storage, read_write> smoothed: array<vec4<u32>>;
// A word per tile of the tile list: non-zero = smooth it (select.wgsl).
@group(0) @binding(3) var<storage, read> blur_tiles: array<u32>;

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

// The seven taps over the four rows of packed words v0..v6 (byte r of each
// word is row r of its column).
fn taps4(v0: u32, v1: u32, v2: u32, v3: u32, v4: u32, v5: u32, v6: u32) -> vec4<u32> {
    return ORB_KERNEL[0] * pk_rows(v0) + ORB_KERNEL[1] * pk_rows(v1) + ORB_KERNEL[2] * pk_rows(v2)
        + ORB_KERNEL[3] * pk_rows(v3) + ORB_KERNEL[4] * pk_rows(v4) + ORB_KERNEL[5] * pk_rows(v5)
        + ORB_KERNEL[6] * pk_rows(v6);
}

// The seven vertical taps over rows v0..v6 of the four columns (component k
// is column x0 + k), rounded from Q16: the smoothed values.
fn vtaps(v0: vec4<u32>, v1: vec4<u32>, v2: vec4<u32>, v3: vec4<u32>, v4: vec4<u32>, v5: vec4<u32>, v6: vec4<u32>) -> vec4<u32> {
    let t = ORB_KERNEL[0] * v0 + ORB_KERNEL[1] * v1 + ORB_KERNEL[2] * v2 + ORB_KERNEL[3] * v3 + ORB_KERNEL[4] * v4
        + ORB_KERNEL[5] * v5 + ORB_KERNEL[6] * v6;
    return (t + vec4<u32>(1u << 15u)) >> vec4<u32>(16u);
}

// The ten columns x0 - 3 .. x0 + 6 of a walk, reflected into the level.
struct Cols10 {
    a: vec4<u32>,
    b: vec4<u32>,
    c: vec2<u32>,
}

// Horizontal Q8 sums of four rows at the walk's four columns (component k is
// column x0 + k).
struct Rows4 {
    r0: vec4<u32>,
    r1: vec4<u32>,
    r2: vec4<u32>,
    r3: vec4<u32>,
}

// The horizontal sums of rows 4g .. 4g + 3 (word row g, clamped to the
// level's last) at the four columns: ten gray words, one per column of the
// taps, each giving four rows.
fn hsums(l: u32, c: Cols10, g: u32) -> Rows4 {
    let row = pk_word(l, 0u, min(4u * g, lh(l) - 1u));
    let v0 = gray[row + c.a.x];
    let v1 = gray[row + c.a.y];
    let v2 = gray[row + c.a.z];
    let v3 = gray[row + c.a.w];
    let v4 = gray[row + c.b.x];
    let v5 = gray[row + c.b.y];
    let v6 = gray[row + c.b.z];
    let v7 = gray[row + c.b.w];
    let v8 = gray[row + c.c.x];
    let v9 = gray[row + c.c.y];
    // column k's four rows
    let k0 = taps4(v0, v1, v2, v3, v4, v5, v6);
    let k1 = taps4(v1, v2, v3, v4, v5, v6, v7);
    let k2 = taps4(v2, v3, v4, v5, v6, v7, v8);
    let k3 = taps4(v3, v4, v5, v6, v7, v8, v9);
    return Rows4(vec4(k0.x, k1.x, k2.x, k3.x), vec4(k0.y, k1.y, k2.y, k3.y), vec4(k0.z, k1.z, k2.z, k3.z), vec4(k0.w, k1.w, k2.w, k3.w));
}

// Row i (< 4) of four.
fn row_of(r: Rows4, i: u32) -> vec4<u32> {
    return select(select(r.r0, r.r1, i == 1u), select(r.r2, r.r3, i == 3u), i >= 2u);
}

// The horizontal sums of rows y - 3 .. y + 3 (reflected) of the walk's
// columns: the vertical taps' window for row y.
struct Window {
    r0: vec4<u32>,
    r1: vec4<u32>,
    r2: vec4<u32>,
    r3: vec4<u32>,
    r4: vec4<u32>,
    r5: vec4<u32>,
    r6: vec4<u32>,
}

// Position i (< 11) of the window followed by four more rows `n`.
fn pick11(w: Window, n: Rows4, i: u32) -> vec4<u32> {
    let lo = select(select(w.r0, w.r1, i == 1u), select(w.r2, w.r3, i == 3u), i >= 2u);
    let mid = select(select(w.r4, w.r5, i == 5u), select(w.r6, n.r0, i == 7u), i >= 6u);
    let hi = select(n.r1, select(n.r2, n.r3, i == 10u), i >= 9u);
    return select(select(lo, mid, i >= 4u), hi, i >= 8u);
}

// Row t of a step's four new rows (window rows y - 3 .. y + 3, new rows
// y + 4 .. y + 7 in `n`, position 7 + j for row y + 4 + j): itself inside
// the level, else its reflection, a row of the window or of `n` for every
// row a stored output needs (rows past the level's last that the walk's
// last valid output reaches reflect at most 4 rows up, to h - 4 >= y - 3).
fn new_row(w: Window, n: Rows4, t: u32, y: u32, h: u32) -> vec4<u32> {
    let i = min(u32(i32(reflected(i32(t), i32(h))) - (i32(y) - 3)), 10u);
    return select(row_of(n, t - y - 4u), pick11(w, n, i), t >= h);
}

// A quad pass (common.wgsl quad_span): each invocation walks columns x0 ..
// x0 + 3 of a tile with the horizontal sums of rows y - 3 .. y + 3 in
// registers. The window starts from word rows y0 / 4 - 1 and y0 / 4 (20 gray
// loads; rows above the level reflected by selects among them); each step
// (a word of rows, in a loop) computes the next four rows' sums from ten
// gray words (columns x0 - 3 .. x0 + 6, reflected), reflects those past the
// level's last by selects, and writes the four words of `smoothed` in one
// store (none past the walk's end; past the level's right edge, the padding
// words of its quad: common.wgsl pk_pitch).
@compute @workgroup_size(64, 1, 1)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    // the walk's tile: unmarked, nothing to do
    let t = quad_tile(wg, li);
    if (t >= P.total_tiles || blur_tiles[t] == 0u) { return; }
    let span = quad_span(wg, li);
    if (span.y == span.z) { return; }
    let l = span.w;
    let x0 = span.x;
    let w = lw(l);
    let h = lh(l);
    let iw = i32(w);
    let ix = i32(x0);
    let cols = Cols10(
        vec4<u32>(reflected(ix - 3, iw), reflected(ix - 2, iw), reflected(ix - 1, iw), x0),
        vec4<u32>(reflected(ix + 1, iw), reflected(ix + 2, iw), reflected(ix + 3, iw), reflected(ix + 4, iw)),
        vec2<u32>(reflected(ix + 5, iw), reflected(ix + 6, iw)),
    );
    // word rows ga (the one above y0, or row 0's at the top) and y0 / 4: the
    // window's rows reflected (a row above the level, or below it in a short
    // level) index them from row 4 ga
    let y0 = span.y;
    let ga = max(y0 >> 2u, 1u) - 1u;
    let a = hsums(l, cols, ga);
    let b = hsums(l, cols, y0 >> 2u);
    let base = i32(4u * ga);
    let ih = i32(h);
    let iy = i32(y0);
    var win = Window(
        pick8(a, b, u32(i32(reflected(iy - 3, ih)) - base)),
        pick8(a, b, u32(i32(reflected(iy - 2, ih)) - base)),
        pick8(a, b, u32(i32(reflected(iy - 1, ih)) - base)),
        pick8(a, b, u32(i32(reflected(iy, ih)) - base)),
        pick8(a, b, u32(i32(reflected(iy + 1, ih)) - base)),
        pick8(a, b, u32(i32(reflected(iy + 2, ih)) - base)),
        pick8(a, b, u32(i32(reflected(iy + 3, ih)) - base)),
    );
    for (var y = y0; y < span.z; y += 4u) {
        // rows y + 4 .. y + 7, those past the level's last reflected
        let n = hsums(l, cols, (y >> 2u) + 1u);
        let n4 = new_row(win, n, y + 4u, y, h);
        let n5 = new_row(win, n, y + 5u, y, h);
        let n6 = new_row(win, n, y + 6u, y, h);
        let n7 = new_row(win, n, y + 7u, y, h);
        let valid = vec4<u32>(y) + vec4<u32>(0u, 1u, 2u, 3u) < vec4<u32>(span.z);
        let s0 = select(vec4<u32>(0u), vtaps(win.r0, win.r1, win.r2, win.r3, win.r4, win.r5, win.r6), valid.x);
        let s1 = select(vec4<u32>(0u), vtaps(win.r1, win.r2, win.r3, win.r4, win.r5, win.r6, n4), valid.y);
        let s2 = select(vec4<u32>(0u), vtaps(win.r2, win.r3, win.r4, win.r5, win.r6, n4, n5), valid.z);
        let s3 = select(vec4<u32>(0u), vtaps(win.r3, win.r4, win.r5, win.r6, n4, n5, n6), valid.w);
        // column k's word: rows y .. y + 3 in its bytes
        let words = s0 | (s1 << vec4<u32>(8u)) | (s2 << vec4<u32>(16u)) | (s3 << vec4<u32>(24u));
        smoothed[pk_word(l, x0, y) >> 2u] = words;
        win = Window(win.r4, win.r5, win.r6, n4, n5, n6, n7);
    }
}

// Row i (< 8) of word rows a (0 .. 3) and b (4 .. 7).
fn pick8(a: Rows4, b: Rows4, i: u32) -> vec4<u32> {
    return select(row_of(a, i & 3u), row_of(b, i & 3u), i >= 4u);
}
