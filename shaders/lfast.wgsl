// SPEC 8: the L-FAST corner test on the edge map (paper 3.2, Steps 1-5).
// Mirrors src/cpu/lfast.rs. `edges` (+ `mask` when P.use_mask == 1) ->
// `cand` (1 = candidate, 0 otherwise; column-packed, common.wgsl pk_word;
// zeroed right before the pass, src/gpu/lfast.rs: it shares its memory with
// `classes`, src/gpu/footprint.rs),
// and the candidate list: every candidate's
// atlas index appended to `cand_list` in no particular order, counted in
// counters[CANDS], and the indirect args over it (entry `cand_args`), which
// response.wgsl and corner_nms.wgsl dispatch over. (cand_list.wgsl builds the
// same list from a `cand` plane: the tests' staged reference.)
// All levels in one dispatch each (over the tile list). In Paper mode the
// test runs as bit planes, a quad's 16 rows at once (entry `paper`, mirroring
// src/cpu/lfast/scan.rs's row words), on the edge rows of each tile column
// that hysteresis.wgsl's final_edges stores in `edge_bits`
// (gpu::layout::pack_edge_tiles); `edges` is not read. In Branch mode, whose
// branches need per-pixel work, `windows` (a column pass) makes the edge
// windows and list from `edges`, and `args` and `main` test one listed edge
// pixel per invocation.
// Tests: tests/gpu_edges_back.rs (this pass alone == src/cpu/lfast.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).
//
// Races: windows stores the edge_bits words (tile_word) of its quad's four
// columns (padding past the level's width included) from that quad's
// invocation only, and its edge-list entries into the range its
// workgroup reserved (one atomicAdd on counters[EDGES] by lane 0, lanes' offsets
// from an atomicAdd on the workgroup's count); main sets candidate bits with
// atomicOr (several pixels share a word of `cand`) and takes its cand_list slot
// with atomicAdd; paper stores the `cand` words of its quad's four columns and
// 16 rows (no other invocation has a pixel in them) and takes its cand_list
// slots with one atomicAdd; the args entry points are single invocations.

// Four columns' words a load (a quad walk's x0 .. x0 + 3: common.wgsl pk_pitch).
@group(0) @binding(1) var<storage, read> edges: array<vec4<u32>>;
@group(0) @binding(2) var<storage, read> mask: array<u32>;
@group(0) @binding(3) var<storage, read_write> cand: array<atomic<u32>>;
@group(0) @binding(4) var<storage, read_write> edge_bits: array<u32>;
@group(0) @binding(5) var<storage, read_write> edge_list: array<u32>;
@group(0) @binding(6) var<storage, read_write> counters: array<atomic<u32>>;
@group(0) @binding(7) var<storage, read_write> cand_list: array<u32>;
@group(0) @binding(8) var<storage, read_write> indirect: array<u32>;
// `edge_bits` again, four columns' words a store or load (a quad walk's x0 ..
// x0 + 3: common.wgsl tile_word): `windows` stores its windows (Branch mode);
// `paper` loads the tile words hysteresis stored there (Paper mode)
@group(0) @binding(9) var<storage, read_write> edge_bits4: array<vec4<u32>>;
// `cand` again, four columns' words a store (common.wgsl pk_word), for `paper`
@group(0) @binding(10) var<storage, read_write> cand4: array<vec4<u32>>;

// indirect::EDGES / 4 and indirect::CANDS / 4 in src/gpu/buffers.rs.
const I_EDGES: u32 = 20u;
const I_CANDS: u32 = 16u;

const EDGE: u32 = 255u;

// The radius-3 Bresenham circle in FAST order (index 0 straight up, clockwise;
// CIRCLE in src/cpu/lfast.rs): x offsets 0, 1, 2, 3, 3, 3, 2, 1, then the same
// negated; the y offset of index t is the x offset of index t + 12 (mod 16).
// As arithmetic (offset + 3 in a nibble) rather than a constant array, which
// an index computed per pixel would read lane by lane.
fn circle_dx(t: u32) -> i32 {
    let d = i32((0x45666543u >> ((t & 7u) * 4u)) & 15u) - 3;
    return select(-d, d, t < 8u);
}
fn circle_dy(t: u32) -> i32 { return circle_dx((t + 12u) & 15u); }

// Edge windows (entry `windows`): one word per column of every tile
// (common.wgsl tile_word), bit j = row 16 ty - 8 + j of that column (1 =
// edge; rows outside the level 0), for the tile row ty: every pixel the test
// of a pixel of that tile row reads (up to 7 rows away) is in its column's
// word, so a column costs one load.

// Rows row .. row + n - 1 of column x (bit j = row row + j), read from the
// window of tile row ty: for a pixel of that tile row, every row its test
// reads (up to 7 away) lies in the window.
fn window_rows(l: u32, x: i32, ty: u32, row: i32, n: u32) -> u32 {
    return (edge_bits[tile_word(l, u32(x), ty)] >> u32(row - i32(ty * TILE) + 8)) & ((1u << n) - 1u);
}

// Step 4: does circle point t support the corner at p? q = 2t - p supports it
// when it is an edge, or when at least `support` of its 8 neighbours are.
fn supports(l: u32, px: i32, py: i32, t: u32, support: u32) -> bool {
    let qx = px + 2 * circle_dx(t);
    let qy = py + 2 * circle_dy(t);
    // rows qy-1..qy+1 of columns qx-1, qx, qx+1, read at p's tile row
    let ty = u32(py) / TILE;
    let left = window_rows(l, qx - 1, ty, qy - 1, 3u);
    let mid = window_rows(l, qx, ty, qy - 1, 3u);
    let right = window_rows(l, qx + 1, ty, qy - 1, 3u);
    return (mid & 2u) != 0u || countOneBits(left) + countOneBits(right) + countOneBits(mid) >= support;
}

// Bit i of the circle mask from bit j of a 7-row column window.
fn cbit(c: u32, j: u32, i: u32) -> u32 { return ((c >> j) & 1u) << i; }

// The 16-bit mask of edge pixels on the circle around p (bit i = circle point
// i): rows py-3..py+3 of columns px-3..px+3, a load each.
fn circle_mask(l: u32, px: i32, py: i32) -> u32 {
    let ty = u32(py) / TILE;
    let c0 = window_rows(l, px - 3, ty, py - 3, 7u);
    let c1 = window_rows(l, px - 2, ty, py - 3, 7u);
    let c2 = window_rows(l, px - 1, ty, py - 3, 7u);
    let c3 = window_rows(l, px, ty, py - 3, 7u);
    let c4 = window_rows(l, px + 1, ty, py - 3, 7u);
    let c5 = window_rows(l, px + 2, ty, py - 3, 7u);
    let c6 = window_rows(l, px + 3, ty, py - 3, 7u);
    // circle point i at (dx, dy) is bit dy + 3 of c[dx + 3]
    return cbit(c3, 0u, 0u) | cbit(c4, 0u, 1u) | cbit(c5, 1u, 2u) | cbit(c6, 2u, 3u)
        | cbit(c6, 3u, 4u) | cbit(c6, 4u, 5u) | cbit(c5, 5u, 6u) | cbit(c4, 6u, 7u)
        | cbit(c3, 6u, 8u) | cbit(c2, 6u, 9u) | cbit(c1, 5u, 10u) | cbit(c0, 4u, 11u)
        | cbit(c0, 3u, 12u) | cbit(c0, 2u, 13u) | cbit(c1, 1u, 14u) | cbit(c2, 0u, 15u);
}

// Two circle indices form a straight line at the given tolerance.
fn straight(a: u32, b: u32) -> bool {
    let d = max(a, b) - min(a, b);
    return i32(min(d, 16u - d)) >= 8 - i32(P.straight_tol);
}

// Whether the two set bits of a two-bit mask form a straight line.
fn straight_pair(m: u32) -> bool { return straight(countTrailingZeros(m), 31u - countLeadingZeros(m)); }

// The L-FAST decision for edge pixel p (>= 7 pixels from every side).
// Written without early returns, each loop with its test at the top: a SIMD
// software rasteriser keeps an exec mask per exit and runs both sides of
// every `if`; the loops run as often as the busiest lane needs.
fn is_corner(l: u32, px: i32, py: i32) -> bool {
    let mask = circle_mask(l, px, py);
    let n = countOneBits(mask);
    if (P.mode == 0u) {
        // Paper: every circle edge pixel is its own t_i; two opposite points
        // alone put p on their line. Two supported points make a corner.
        let opposite = n == 2u && (31u - countLeadingZeros(mask)) - countTrailingZeros(mask) == 8u;
        var m = select(0u, mask, n >= 2u && !opposite);
        var supported = 0u;
        while (m != 0u && supported < 2u) {
            let t = countTrailingZeros(m);
            m &= m - 1u;
            supported += u32(supports(l, px, py, t, P.support));
        }
        return supported >= 2u;
    }
    // Branch: for_each_branch of the CPU module. No branch for 0 and all-16.
    // The branch middles are distinct circle indices, so a 16-bit mask holds
    // them (bit t = a branch's middle is t) instead of a list.
    var mids = 0u;
    // bit s of `starts` is set where a run begins: s set, s-1 (cyclically) clear
    let prev = ((mask << 1u) | (mask >> 15u)) & 0xffffu;
    var starts = select(0u, mask & ~prev, mask != 0xffffu);
    let doubled = mask | (mask << 16u);
    while (starts != 0u) {
        let s = countTrailingZeros(starts);
        // run length: trailing ones of the mask rotated to start at s
        let len = min(countTrailingZeros(~(doubled >> s)), 16u);
        mids |= 1u << ((s + (len - 1u) / 2u) % 16u);
        starts &= starts - 1u;
    }
    // Fewer than two branches, or exactly two on a straight line, can never
    // make a corner, whatever Step 4 says: skip its reads.
    let nb = countOneBits(mids);
    var m = select(mids, 0u, nb < 2u || (nb == 2u && straight_pair(mids)));
    var ts = 0u;
    while (m != 0u) {
        let t = countTrailingZeros(m);
        m &= m - 1u;
        ts |= select(0u, 1u << t, supports(l, px, py, t, P.support));
    }
    let k = countOneBits(ts);
    return k > 2u || (k == 2u && !straight_pair(ts));
}

// Bits 4k .. 4k + 3 of the edge windows of columns x0 .. x0 + 3: the edge
// rows of their packed words of group g + k (one aligned load, the group
// clamped into the level), 0 outside the level.
fn window_nibbles(l: u32, x0: u32, g: i32, k: i32, h: u32) -> vec4<u32> {
    let i = g + k;
    let inside = i >= 0 && u32(i) * 4u < h;
    let words = edges[pk_word(l, x0, 4u * min(u32(max(i, 0)), (h - 1u) >> 2u)) >> 2u];
    let e = vec4<u32>(EDGE);
    let n = vec4<u32>(bits4(pk_rows(words.x) == e), bits4(pk_rows(words.y) == e), bits4(pk_rows(words.z) == e), bits4(pk_rows(words.w) == e));
    return select(vec4<u32>(0u), n << vec4<u32>(4u * u32(k)), inside);
}

// Entry `windows`, the pass's first dispatch: a column pass whose invocation
// writes its column's edge window (tile_word) from the eight packed words of
// rows y0 - 8 .. y0 + 23 (y0, a multiple of 16, is its tile's top row), and
// appends the column's tested edge pixels (at least `border` (>= 7) from
// every side) to `edge_list`: their rows as bits, then a `while` loop over
// those only (an if-body in the walk would run every row, masked, on a SIMD
// software rasteriser).
//
// A quad pass (common.wgsl quad_span): four columns per invocation, their
// tested rows in two loops of two columns (bit 16 k + r: row r of column
// x0 + k, resp. x0 + 2 + k); one column per invocation, the invocations' own
// work was a good part of the pass on lavapipe.
@compute @workgroup_size(64, 1, 1)
fn windows(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let span = quad_span(wg, li);
    var rows = vec2<u32>(0u);
    if (span.y < span.z) { rows = walk_windows(span); }
    // The tested rows' list entries, reserved once per workgroup: an atomic
    // per entry on the one counter (tens of thousands a KITTI frame, its
    // cache line bouncing between the cores) cost lavapipe ~0.2 ms more.
    var at = 0u;
    let n = countOneBits(rows.x) + countOneBits(rows.y);
    if (n != 0u) { at = atomicAdd(&wg_edges, n); }
    workgroupBarrier();
    if (li.x == 0u) { wg_base = atomicAdd(&counters[C_EDGES], atomicLoad(&wg_edges)); }
    workgroupBarrier();
    at += wg_base;
    let w = lw(span.w);
    let base = loff(span.w) + span.y * w + span.x;
    var r = rows.x;
    while (r != 0u) {
        let k = countTrailingZeros(r);
        r &= r - 1u;
        edge_list[at] = base + (k & 15u) * w + (k >> 4u);
        at++;
    }
    r = rows.y;
    while (r != 0u) {
        let k = countTrailingZeros(r);
        r &= r - 1u;
        edge_list[at] = base + (k & 15u) * w + 2u + (k >> 4u);
        at++;
    }
}

// The workgroup's tested edge pixels, and where they start in `edge_list`.
var<workgroup> wg_edges: atomic<u32>;
var<workgroup> wg_base: u32;

// The rows of the quad walk `span` (quad_span) that are tested, per column
// (bit r: row y0 + r): rows b .. h - b - 1 of columns b .. w - b - 1 (a level
// with w or h <= 2 * border has none; written so nothing underflows).
fn tested_rows(span: vec4<u32>) -> vec4<u32> {
    let w = lw(span.w);
    let h = lh(span.w);
    let b = max(P.border, 7u);
    let lo = u32(clamp(i32(b) - i32(span.y), 0, 16));
    let hi = u32(clamp(i32(h) - i32(b) - i32(span.y), 0, 16));
    let tested = select(0u, ((1u << hi) - 1u) & ~((1u << lo) - 1u), hi > lo);
    let x = vec4<u32>(span.x) + vec4<u32>(0u, 1u, 2u, 3u);
    return select(vec4<u32>(0u), vec4<u32>(tested), (x >= vec4<u32>(b)) & (x + vec4<u32>(b) < vec4<u32>(w)));
}

// The edge windows of the quad walk `span` (quad_span), stored; its tested
// edge rows as bits 16 k + r (row r of column x0 + k) for columns x0, x0 + 1
// (.x) and x0 + 2, x0 + 3 (.y).
fn walk_windows(span: vec4<u32>) -> vec2<u32> {
    let l = span.w;
    let h = lh(l);
    let x0 = span.x;
    // rows y0 - 8 .. y0 + 23 of the four columns: eight groups of four rows
    // (y0, a multiple of 16, is its tile's top row), a load each for all four
    let g = i32(span.y >> 2u) - 2;
    var bits = window_nibbles(l, x0, g, 0, h);
    bits |= window_nibbles(l, x0, g, 1, h);
    bits |= window_nibbles(l, x0, g, 2, h);
    bits |= window_nibbles(l, x0, g, 3, h);
    bits |= window_nibbles(l, x0, g, 4, h);
    bits |= window_nibbles(l, x0, g, 5, h);
    bits |= window_nibbles(l, x0, g, 6, h);
    bits |= window_nibbles(l, x0, g, 7, h);
    // the four columns' windows, stored (columns past the level's width are
    // padding words of the tile row, never read), and their tested edge rows
    edge_bits4[tile_word(l, x0, span.y / TILE) >> 2u] = bits;
    let r = (bits >> vec4<u32>(8u)) & tested_rows(span);
    return vec2<u32>(r.x | (r.y << 16u), r.z | (r.w << 16u));
}

// The indirect args over the list counted in counters[c] into indirect[i ..
// i + 3]: ceil(n / 64) workgroups as (x, y, 1), x <= 65535.
fn write_list_args(c: u32, i: u32) {
    let g = list_args(atomicLoad(&counters[c]));
    indirect[i] = g.x;
    indirect[i + 1u] = g.y;
    indirect[i + 2u] = g.z;
}

// Entry `args`, one invocation: the indirect args of `main` over the edge list.
@compute @workgroup_size(1, 1, 1)
fn args() {
    write_list_args(C_EDGES, I_EDGES);
}

// Entry `main`, work-efficient: one invocation per listed edge pixel, by
// indirect dispatch over the edge list, so the test runs in as few SIMD lanes
// / warps as there are edge pixels and nothing scans the levels' pixels. A
// corner sets its byte of `cand` (column-packed, zeroed right before the
// pass) with an atomic OR (other pixels of its word may be corners too)
// and appends its index to `cand_list`: the candidates are few (a few
// thousand per KITTI frame), and a dense scan of `cand` to list them cost
// lavapipe ~0.8 ms per KITTI frame.
@compute @workgroup_size(64, 1, 1)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let k = list_index(wg, li);
    if (k >= atomicLoad(&counters[C_EDGES])) { return; }
    let i = edge_list[k];
    let p = atlas_pixel(i);
    if ((P.use_mask == 0u || mask[i] != 0u) && is_corner(p.z, i32(p.x), i32(p.y))) {
        atomicOr(&cand[pk_word(p.z, p.x, p.y)], pk_place(1u, p.y));
        cand_list[atomicAdd(&counters[C_CANDS], 1u)] = i;
    }
}

// Entry `cand_args`, one invocation after `main`: the indirect args over the
// candidate list.
@compute @workgroup_size(1, 1, 1)
fn cand_args() {
    write_list_args(C_CANDS, I_CANDS);
}

// Paper mode (entry `paper`, in place of `windows`, `args` and `main`): the test as bit
// planes. Circle point t supports p when it is an edge pixel and q = 2t - p is
// an edge pixel or has at least `support` edge neighbours (SUP(q), a property
// of q alone); p is a corner when at least two circle points support it,
// unless its circle holds exactly two edge pixels and they are opposite (then
// both supporting is the only way to two). No per-pixel control flow: one
// invocation tests the 16 rows of its quad's four columns at once, a bit per
// row (bit r: row y0 + r), vec4 = the four columns. It makes the edge windows
// (as `windows`: bit j = row y0 - 8 + j) of columns x0 - 8 .. x0 + 11 from
// hysteresis' tile words of three tile rows, five aligned quads each;
// computes SUP of columns x0 - 6 .. x0 + 9 from a bit-sliced count of
// each row's eight neighbours; and takes the circle's points as shifts of
// those words. The CPU counts the same way along rows (src/cpu/lfast/scan.rs).
// Columns outside the level (quads clamped into it) feed only untested
// pixels' bits: a tested pixel's reads stay within 7 of it (border >= 7).

// The edge windows (bit j = row y0 - 8 + j, as `windows` makes them) of the
// four columns of quad k of a tile row, from the edge_tiles words of that
// tile row (mid) and the ones above and below (none past the level).
fn window_quad(above: u32, mid: u32, below: u32, up: bool, down: bool, k: u32) -> vec4<u32> {
    let a = select(vec4<u32>(0u), edge_bits4[above + k], up);
    let b = select(vec4<u32>(0u), edge_bits4[below + k], down);
    return (a >> vec4<u32>(8u)) | (edge_bits4[mid + k] << vec4<u32>(8u)) | (b << vec4<u32>(24u));
}

// Columns p .. p + 3 of the twenty columns of `q` (p constant once inlined).
fn window4(q: array<vec4<u32>, 5>, p: u32) -> vec4<u32> {
    let a = q[p / 4u];
    let b = q[min(p / 4u + 1u, 4u)];
    let s = p % 4u;
    let s1 = vec4<u32>(a.y, a.z, a.w, b.x);
    let s2 = vec4<u32>(a.z, a.w, b.x, b.y);
    let s3 = vec4<u32>(a.w, b.x, b.y, b.z);
    return select(select(select(a, s1, s == 1u), s2, s == 2u), s3, s == 3u);
}

// A bit-sliced count 0..8: bit j of each plane, of row j's count.
struct Count8 {
    b0: vec4<u32>,
    b1: vec4<u32>,
    b2: vec4<u32>,
    b3: vec4<u32>,
}

// The count of eight bit planes, by full and half adders.
fn count8(x1: vec4<u32>, x2: vec4<u32>, x3: vec4<u32>, x4: vec4<u32>, x5: vec4<u32>, x6: vec4<u32>, x7: vec4<u32>, x8: vec4<u32>) -> Count8 {
    let s1 = x1 ^ x2 ^ x3;
    let k1 = (x1 & x2) | (x3 & (x1 ^ x2));
    let s2 = x4 ^ x5 ^ x6;
    let k2 = (x4 & x5) | (x6 & (x4 ^ x5));
    let s3 = s1 ^ s2 ^ x7;
    let k3 = (s1 & s2) | (x7 & (s1 ^ s2));
    let k4 = s3 & x8;
    // twos: k1 + k2 + k3 + k4 = b1 + 2 (m1 + m2); fours: m1 + m2 = b2 + 2 b3
    let t1 = k1 ^ k2 ^ k3;
    let m1 = (k1 & k2) | (k3 & (k1 ^ k2));
    let m2 = t1 & k4;
    return Count8(s3 ^ x8, t1 ^ k4, m1 ^ m2, m1 & m2);
}

// One bit of the comparison of a count with k, from the top: `gt` the rows
// whose higher bits already exceed k's, `eq` those equal so far.
fn ge_bit(gt: ptr<function, vec4<u32>>, eq: ptr<function, vec4<u32>>, c: vec4<u32>, kb: u32) {
    let m = vec4<u32>(select(0u, 0xffffffffu, kb == 1u));
    *gt |= *eq & c & ~m;
    *eq &= ~(c ^ m);
}

// Rows whose count is at least k (uniform).
fn at_least(n: Count8, k: u32) -> vec4<u32> {
    var gt = vec4<u32>(0u);
    var eq = vec4<u32>(0xffffffffu);
    ge_bit(&gt, &eq, n.b3, (k >> 3u) & 1u);
    ge_bit(&gt, &eq, n.b2, (k >> 2u) & 1u);
    ge_bit(&gt, &eq, n.b1, (k >> 1u) & 1u);
    ge_bit(&gt, &eq, n.b0, k & 1u);
    return gt | eq;
}

// SUP of the four columns at p .. p + 3 of the windows `q` (same rows):
// edge, or at least `support` of the eight neighbours edge.
fn sup4(q: array<vec4<u32>, 5>, p: u32) -> vec4<u32> {
    let lft = window4(q, p - 1u);
    let c = window4(q, p);
    let r = window4(q, p + 1u);
    let one = vec4<u32>(1u);
    // bit j of `x << 1` is row j - 1's, of `x >> 1` row j + 1's
    let n = count8(lft << one, lft, lft >> one, c << one, c >> one, r << one, r, r >> one);
    return c | at_least(n, P.support);
}

// Running counts over the circle's points, bit per row.
struct Circle {
    e1: vec4<u32>,  // at least one circle edge pixel
    e2: vec4<u32>,  // at least two
    e3: vec4<u32>,  // at least three
    s1: vec4<u32>,  // at least one supporting point
    s2: vec4<u32>,  // at least two
    opp: vec4<u32>, // an opposite pair of circle edge pixels
}

// Circle points t and t + 8 (opposite) added to the counts: `q` the edge
// windows of columns x0 - 8 .., `s` SUP of columns x0 - 6 ...
fn add_pair(c: ptr<function, Circle>, q: array<vec4<u32>, 5>, s: array<vec4<u32>, 5>, t: u32) {
    let ea = window4(q, u32(8 + circle_dx(t))) >> vec4<u32>(u32(8 + circle_dy(t)));
    let eb = window4(q, u32(8 + circle_dx(t + 8u))) >> vec4<u32>(u32(8 + circle_dy(t + 8u)));
    let xa = ea & (window4(s, u32(6 + 2 * circle_dx(t))) >> vec4<u32>(u32(8 + 2 * circle_dy(t))));
    let xb = eb & (window4(s, u32(6 + 2 * circle_dx(t + 8u))) >> vec4<u32>(u32(8 + 2 * circle_dy(t + 8u))));
    (*c).opp |= ea & eb;
    (*c).e3 |= (*c).e2 & ea;
    (*c).e2 |= (*c).e1 & ea;
    (*c).e1 |= ea;
    (*c).e3 |= (*c).e2 & eb;
    (*c).e2 |= (*c).e1 & eb;
    (*c).e1 |= eb;
    (*c).s2 |= (*c).s1 & xa;
    (*c).s1 |= xa;
    (*c).s2 |= (*c).s1 & xb;
    (*c).s1 |= xb;
}

// `bits` (rows of a column from atlas index i0, a row every w) without the
// rows the mask is off at.
fn unmasked(bits: u32, i0: u32, w: u32) -> u32 {
    var m = bits;
    var out = bits;
    while (m != 0u) {
        let r = countTrailingZeros(m);
        m &= m - 1u;
        out = select(out & ~(1u << r), out, mask[i0 + r * w] != 0u);
    }
    return out;
}

// The rows of `bits` as atlas indices (from i0, a row every w) at
// cand_list[at ..]; the next free entry.
fn append_rows(bits: u32, i0: u32, w: u32, at: u32) -> u32 {
    var m = bits;
    var a = at;
    while (m != 0u) {
        let r = countTrailingZeros(m);
        m &= m - 1u;
        cand_list[a] = i0 + r * w;
        a++;
    }
    return a;
}

// The `cand` words of rows y0 + 4 g .. y0 + 4 g + 3 of the four columns
// (bits 4 g .. 4 g + 3 of each), stored where any is set: `cand` is zeroed
// before the pass and no other invocation has a pixel in them.
fn store_cand(l: u32, x0: u32, y0: u32, c: vec4<u32>, g: u32) {
    let q = (c >> vec4<u32>(4u * g)) & vec4<u32>(15u);
    if (any(q != vec4<u32>(0u))) {
        cand4[pk_word(l, x0, y0 + 4u * g) >> 2u] = vec4<u32>(pk_from_bits(q.x), pk_from_bits(q.y), pk_from_bits(q.z), pk_from_bits(q.w));
    }
}

// Entry `paper` (Paper mode), a quad pass (common.wgsl quad_span) after
// hysteresis: the corners among the quad's tested pixels, their bytes of
// `cand` set and their atlas indices appended to `cand_list`.
@compute @workgroup_size(64, 1, 1)
fn paper(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let span = quad_span(wg, li);
    if (span.y == span.z) { return; }
    let l = span.w;
    let w = lw(l);
    let h = lh(l);
    let x0 = span.x;
    let y0 = span.y;
    // the tested edge pixels (this tile row's edge rows, hysteresis'
    // edge_tiles words); none in most quads
    let ty = y0 / TILE;
    let mid = tile_word(l, 0u, ty) >> 2u;
    let qx = x0 >> 2u;
    let p = edge_bits4[mid + qx] & tested_rows(span);
    if (all(p == vec4<u32>(0u))) { return; }
    // the edge windows of columns x0 - 8 .. x0 + 11 (quads clamped into the
    // level), rows y0 - 8 .. y0 + 23 from the tile rows above and below
    let above = tile_word(l, 0u, max(ty, 1u) - 1u) >> 2u;
    let below = tile_word(l, 0u, min(ty + 1u, (h - 1u) / TILE)) >> 2u;
    let up = ty > 0u;
    let down = (ty + 1u) * TILE < h;
    let last = (w - 1u) >> 2u;
    var q: array<vec4<u32>, 5>;
    q[0] = window_quad(above, mid, below, up, down, max(qx, 2u) - 2u);
    q[1] = window_quad(above, mid, below, up, down, max(qx, 1u) - 1u);
    q[2] = window_quad(above, mid, below, up, down, qx);
    q[3] = window_quad(above, mid, below, up, down, min(qx + 1u, last));
    q[4] = window_quad(above, mid, below, up, down, min(qx + 2u, last));
    // SUP of columns x0 - 6 .. x0 + 9 (positions 2 .. 17 of q)
    var s: array<vec4<u32>, 5>;
    s[0] = sup4(q, 2u);
    s[1] = sup4(q, 6u);
    s[2] = sup4(q, 10u);
    s[3] = sup4(q, 14u);
    var c: Circle;
    add_pair(&c, q, s, 0u);
    add_pair(&c, q, s, 1u);
    add_pair(&c, q, s, 2u);
    add_pair(&c, q, s, 3u);
    add_pair(&c, q, s, 4u);
    add_pair(&c, q, s, 5u);
    add_pair(&c, q, s, 6u);
    add_pair(&c, q, s, 7u);
    var corner = p & c.s2 & ~(c.e2 & ~c.e3 & c.opp);
    if (all(corner == vec4<u32>(0u))) { return; }
    let i0 = loff(l) + y0 * w + x0;
    if (P.use_mask != 0u) {
        corner = vec4<u32>(unmasked(corner.x, i0, w), unmasked(corner.y, i0 + 1u, w), unmasked(corner.z, i0 + 2u, w), unmasked(corner.w, i0 + 3u, w));
    }
    let n = countOneBits(corner.x) + countOneBits(corner.y) + countOneBits(corner.z) + countOneBits(corner.w);
    if (n == 0u) { return; }
    var at = atomicAdd(&counters[C_CANDS], n);
    at = append_rows(corner.x, i0, w, at);
    at = append_rows(corner.y, i0 + 1u, w, at);
    at = append_rows(corner.z, i0 + 2u, w, at);
    at = append_rows(corner.w, i0 + 3u, w, at);
    store_cand(l, x0, y0, corner, 0u);
    store_cand(l, x0, y0, corner, 1u);
    store_cand(l, x0, y0, corner, 2u);
    store_cand(l, x0, y0, corner, 3u);
}
