// SPEC 8: the L-FAST corner test on the edge map (paper 3.2, Steps 1-5).
// Mirrors src/cpu/lfast.rs. `edges` (+ `mask` when P.use_mask == 1) ->
// `cand` (1 = candidate, 0 otherwise; column-packed, common.wgsl pk_word;
// every word of every level is written).
// A column pass, all levels in one dispatch (over the tile list); the test
// itself runs on the workgroup's compacted edge pixels (see main).
// Tests: tests/gpu_edges_back.rs (this pass alone == src/cpu/lfast.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).

@group(0) @binding(1) var<storage, read> edges: array<u32>;
@group(0) @binding(2) var<storage, read> mask: array<u32>;
@group(0) @binding(3) var<storage, read_write> cand: array<u32>;

const EDGE: u32 = 255u;

// The radius-3 Bresenham circle in FAST order (index 0 straight up, clockwise).
const CIRCLE = array<vec2<i32>, 16>(
    vec2(0, -3), vec2(1, -3), vec2(2, -2), vec2(3, -1), vec2(3, 0), vec2(3, 1), vec2(2, 2), vec2(1, 3),
    vec2(0, 3), vec2(-1, 3), vec2(-2, 2), vec2(-3, 1), vec2(-3, 0), vec2(-3, -1), vec2(-2, -2), vec2(-1, -3));

// 1 iff (x, y) of level l is an edge. Callers stay >= 7 pixels inside p's
// border, so no clamping is needed (as on the CPU).
// `edges` is column-packed (common.wgsl pk_word).
fn is_edge(l: u32, x: i32, y: i32) -> u32 {
    return u32(pk_byte(edges[pk_word(l, u32(x), u32(y))], u32(y)) == EDGE);
}

// Step 4: does circle point t support the corner at p? q = 2t - p supports it
// when it is an edge, or when at least `support` of its 8 neighbours are.
fn supports(l: u32, px: i32, py: i32, t: u32, support: u32) -> bool {
    let q = vec2(px, py) + 2 * CIRCLE[t];
    if (is_edge(l, q.x, q.y) == 1u) { return true; }
    var n = 0u;
    for (var dy = -1; dy <= 1; dy++) {
        for (var dx = -1; dx <= 1; dx++) {
            if (dx != 0 || dy != 0) { n += is_edge(l, q.x + dx, q.y + dy); }
        }
    }
    return n >= support;
}

// The 16-bit mask of edge pixels on the circle around p (bit i = CIRCLE[i]).
fn circle_mask(l: u32, px: i32, py: i32) -> u32 {
    var m = 0u;
    for (var i = 0u; i < 16u; i++) {
        m |= is_edge(l, px + CIRCLE[i].x, py + CIRCLE[i].y) << i;
    }
    return m;
}

// Two circle indices form a straight line at the given tolerance.
fn straight(a: u32, b: u32) -> bool {
    let d = max(a, b) - min(a, b);
    return i32(min(d, 16u - d)) >= 8 - i32(P.straight_tol);
}

// The L-FAST decision for edge pixel p (>= 7 pixels from every side).
fn is_corner(l: u32, px: i32, py: i32) -> bool {
    let mask = circle_mask(l, px, py);
    if (P.mode == 0u) {
        // Paper: every circle edge pixel is its own t_i.
        let n = countOneBits(mask);
        if (n < 2u) { return false; }
        if (n == 2u) {
            let a = countTrailingZeros(mask);
            let b = 31u - countLeadingZeros(mask);
            if (b - a == 8u) { return false; } // p on the line of the only two points
        }
        var supported = 0u;
        var m = mask;
        while (m != 0u) {
            let t = countTrailingZeros(m);
            m &= m - 1u;
            if (supports(l, px, py, t, P.support)) {
                supported++;
                if (supported >= 2u) { return true; }
            }
        }
        return false;
    }
    // Branch: for_each_branch of the CPU module. No branch for 0 and all-16.
    if (mask == 0u || mask == 0xffffu) { return false; }
    var mids: array<u32, 8>;
    var nb = 0u;
    // bit s of `starts` is set where a run begins: s set, s-1 (cyclically) clear
    let prev = ((mask << 1u) | (mask >> 15u)) & 0xffffu;
    var starts = mask & ~prev;
    let doubled = mask | (mask << 16u);
    while (starts != 0u) {
        let s = countTrailingZeros(starts);
        // run length: trailing ones of the mask rotated to start at s
        let len = min(countTrailingZeros(~(doubled >> s)), 16u);
        mids[nb] = (s + (len - 1u) / 2u) % 16u;
        nb++;
        starts &= starts - 1u;
    }
    // Fewer than two branches, or exactly two on a straight line, can never
    // make a corner, whatever Step 4 says: skip its reads.
    if (nb < 2u || (nb == 2u && straight(mids[0], mids[1]))) { return false; }
    // at most 8 branches fit on 16 positions
    var ts: array<u32, 8>;
    var n = 0u;
    for (var k = 0u; k < nb; k++) {
        if (supports(l, px, py, mids[k], P.support)) {
            ts[n] = mids[k];
            n++;
        }
    }
    if (n < 2u) { return false; }
    if (n == 2u) { return !straight(ts[0], ts[1]); }
    return true;
}

// Work-efficient: a column pass (tile_column) that lists its four tiles'
// tested edge pixels in `todo` (workgroup memory) as it walks them; after one
// barrier the workgroup's invocations take the list side by side, so the test
// runs in as few SIMD lanes / warps as there are edge pixels, and mark the
// corners in `found`; after a second barrier each invocation writes its
// column's packed words of `cand`. Entries: list_entry (common.wgsl).
var<workgroup> todo: array<u32, 1024>;
// zero at the start of the workgroup (WGSL zero-initialises workgroup memory)
var<workgroup> todo_n: atomic<u32>;
// bit r of found[lane]: row r of the lane's column is a candidate (zero at the start)
var<workgroup> found: array<atomic<u32>, 64>;

@compute @workgroup_size(64, 1, 1)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let span = column_span(wg, li);
    let l = span.w;
    let w = lw(l);
    let h = lh(l);
    // Only pixels at least `border` (>= 7) from every side are tested; a
    // level with w or h <= 2 * border has none. Written this way (no
    // w - border) so nothing underflows.
    let b = max(P.border, 7u);
    let col = span.x >= b && span.x + b < w;
    var word = 0u;
    for (var y = span.y; y < span.z; y++) {
        // the column's packed word, once per four rows
        if ((y & 3u) == 0u) { word = edges[pk_word(l, span.x, y)]; }
        let tested = col && y >= b && y + b < h;
        if (tested && pk_byte(word, y) == EDGE && (P.use_mask == 0u || mask[loff(l) + y * w + span.x] != 0u)) {
            todo[atomicAdd(&todo_n, 1u)] = list_entry(li.x, y - span.y);
        }
    }
    workgroupBarrier();
    let n = atomicLoad(&todo_n);
    for (var k = li.x; k < n; k += 64u) {
        let e = todo[k];
        let p = list_pixel(wg, e);
        if (is_corner(p.z, i32(p.x), i32(p.y))) { atomicOr(&found[e >> 4u], 1u << (e & 15u)); }
    }
    workgroupBarrier();
    // Row r's bit becomes byte r % 4 of word r / 4 (a 0/1 byte).
    let bits = atomicLoad(&found[li.x]);
    for (var y = span.y; y < span.z; y += 4u) {
        let q = bits >> (y - span.y);
        cand[pk_word(l, span.x, y)] = (q & 1u) | ((q & 2u) << 7u) | ((q & 4u) << 14u) | ((q & 8u) << 21u);
    }
}
