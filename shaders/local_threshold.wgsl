// SPEC 5: the sliding-window statistics behind the local thresholds TL1, TL2.
// Mirrors src/cpu/local_threshold.rs: the windows' histograms of M8 =
// min(M, 255) are sums of the histograms of the cells cut at every window
// edge (spec::cell_cuts), so each pixel is counted once, not once per window
// holding it. m (M8, column-packed, common.wgsl pk_word) + grid -> window_hist -> windows[(first window of l + j*nx + i)
// * 4 + {0: min, 1: max, 2: lower median, 3: V3}], and SPEC 4's per-level
// histogram hist[l * 256 + M8] (the cells partition the level, so summing
// their bins counts every pixel once: histogram.wgsl's result, without a
// count of its own in gradient_nms). Two entry points:
// - cells: one workgroup per cell, workgroup_id = (column, row, level),
//   dispatch (most cells along x, along y, n_levels); it counts the cell in
//   workgroup memory and adds each bin to every window holding the cell and
//   to the level's histogram.
//   CELL_INVOCATIONS (8) invocations: a KITTI cell is ~120x40 pixels at
//   level 0 and ~30x10 at level 7, so a few columns each. Workgroup-wide
//   work (the windows holding the cell, the barrier, the bins' walk) costs
//   every SIMD group of a workgroup on lavapipe: one invocation per bin
//   (256) took 57 ms per frame, 32 took 8.8 ms, 8 (one SIMD group) 7.2.
// - stats: one workgroup per window, workgroup_id = (i, j, level), dispatch
//   (max nx, max ny, n_levels): stats_of over the window's histogram.
// Groups beyond a level's cells or windows return at once. `window_hist` and
// `hist` are cleared by the pass before it runs.
// Tests: tests/gpu_edges_front.rs (this pass alone == src/cpu/local_threshold.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).

@group(0) @binding(1) var<storage, read> m: array<u32>;
@group(0) @binding(2) var<storage, read> grid: array<u32>;
@group(0) @binding(3) var<storage, read_write> windows: array<u32>;
@group(0) @binding(4) var<storage, read_write> window_hist: array<atomic<u32>>;
@group(0) @binding(5) var<storage, read_write> hist: array<atomic<u32>>;

// Zero at the start of a workgroup (WGSL zero-initialises workgroup memory).
var<workgroup> bins: array<atomic<u32>, 256>;
// The windows holding the cell: columns [win.x, win.y), rows [win.z, win.w).
var<workgroup> win: vec4<u32>;

// The windows of origins grid[o..o+n] (size `size`) that hold [c0, c1):
// origins are sorted and sizes equal, so they are one range.
fn holding(o: u32, n: u32, size: u32, c0: u32, c1: u32) -> vec2<u32> {
    var r = vec2<u32>(n, n);
    for (var k = 0u; k < n; k++) {
        let s = grid[o + k];
        if (s <= c0 && c1 <= s + size) {
            r.y = k + 1u;
            if (r.x == n) { r.x = k; }
        }
    }
    return r;
}

// Counts value v (< 32) in the register counters when `yes`: 8-bit counters
// four a word, v in byte v % 4 of component (v / 4) % 4 of c0 (v < 16) or c1.
fn count_small(c0: ptr<function, vec4<u32>>, c1: ptr<function, vec4<u32>>, v: u32, yes: bool) {
    let inc = vec4<u32>(select(0u, 1u << ((v & 3u) * 8u), yes));
    let q = vec4<u32>(v >> 2u);
    *c0 += select(vec4<u32>(0u), inc, q == vec4<u32>(0u, 1u, 2u, 3u));
    *c1 += select(vec4<u32>(0u), inc, q == vec4<u32>(4u, 5u, 6u, 7u));
}

// Adds the register counters to the workgroup's bins and clears them: a
// `while` loop over the non-zero ones.
fn flush_small(c0: ptr<function, vec4<u32>>, c1: ptr<function, vec4<u32>>) {
    let a = *c0;
    let b = *c1;
    let zero = vec4<u32>(0u);
    var nz = bits4(pk_rows(a.x) != zero) | (bits4(pk_rows(a.y) != zero) << 4u) | (bits4(pk_rows(a.z) != zero) << 8u)
        | (bits4(pk_rows(a.w) != zero) << 12u) | (bits4(pk_rows(b.x) != zero) << 16u)
        | (bits4(pk_rows(b.y) != zero) << 20u) | (bits4(pk_rows(b.z) != zero) << 24u)
        | (bits4(pk_rows(b.w) != zero) << 28u);
    while (nz != 0u) {
        let v = firstTrailingBit(nz);
        nz &= nz - 1u;
        // word v / 4 by selects (a private array indexed per lane is a gather)
        let q = v >> 2u;
        let wa = select(select(a.x, a.y, q == 1u), select(a.z, a.w, q == 3u), q >= 2u);
        let wb = select(select(b.x, b.y, q == 5u), select(b.z, b.w, q == 7u), q >= 6u);
        atomicAdd(&bins[v], pk_byte(select(wa, wb, q >= 4u), v));
    }
    *c0 = zero;
    *c1 = zero;
}

// Invocations of a `cells` workgroup (its columns' stride, its bins' stride).
const CELL_INVOCATIONS: u32 = 8u;

@compute @workgroup_size(8, 1, 1)
fn cells(
    @builtin(local_invocation_index) li: u32,
    @builtin(workgroup_id) wg: vec3<u32>,
) {
    let l = wg.z;
    if (l >= P.n_levels) { return; }
    let hdr = P.cells + 4u * l;
    let cxo = grid[hdr];
    let cyo = grid[hdr + 2u];
    // Workgroup-uniform: the barrier below is reached by all or none.
    if (wg.x >= grid[hdr + 1u] || wg.y >= grid[hdr + 3u]) { return; }
    let x0 = grid[cxo + wg.x];
    let x1 = grid[cxo + wg.x + 1u];
    let y0 = grid[cyo + wg.y];
    let y1 = grid[cyo + wg.y + 1u];
    let g = P.grids[l];
    if (li == 0u) {
        let wx = holding(g.z, g.x, g.w & 0xffffu, x0, x1);
        let wy = holding(g.z + g.x, g.y, g.w >> 16u, y0, y1);
        win = vec4<u32>(wx, wy);
    }
    // Columns li, li + 8, ... of the cell, each down its rows a word (four
    // rows, `m` is column-packed) at a time. Values below 32 (~95% of the
    // pixels of a KITTI frame) are counted in registers, 8-bit counters four
    // a word (count_small), and added to the workgroup's bins when a counter
    // could overflow and at the end; the other rows of a word are bits, whose
    // atomics run in a `while` loop as often as the busiest lane of the SIMD
    // group needs (an atomic under a per-row `if` costs every lane every row
    // on a SIMD software rasteriser).
    var c0 = vec4<u32>(0u);
    var c1 = vec4<u32>(0u);
    // pixels counted in registers since the last flush (a word adds <= 4, so
    // an `if` empties them in time: a `while` costs its loop masks every word)
    var pending = 0u;
    for (var x = x0 + li; x < x1; x += CELL_INVOCATIONS) {
        for (var g4 = y0 >> 2u; g4 * 4u < y1; g4++) {
            if (pending > 251u) {
                flush_small(&c0, &c1);
                pending = 0u;
            }
            // rows a..b (of the word's four) inside the cell, a contiguous range
            let a = max(g4 * 4u, y0) - g4 * 4u;
            let b = min(g4 * 4u + 4u, y1) - 1u - g4 * 4u;
            let inside = (0xfu >> (3u - b)) & ~((1u << a) - 1u);
            let word = m[pk_word(l, x, g4 * 4u)];
            let v = pk_rows(word);
            let small = v < vec4<u32>(32u);
            count_small(&c0, &c1, v.x, (inside & 1u) != 0u && small.x);
            count_small(&c0, &c1, v.y, (inside & 2u) != 0u && small.y);
            count_small(&c0, &c1, v.z, (inside & 4u) != 0u && small.z);
            count_small(&c0, &c1, v.w, (inside & 8u) != 0u && small.w);
            pending += 4u;
            var big = inside & ~bits4(small);
            while (big != 0u) {
                let e = firstTrailingBit(big);
                big &= big - 1u;
                atomicAdd(&bins[pk_byte(word, e)], 1u);
            }
        }
    }
    flush_small(&c0, &c1);
    workgroupBarrier();
    let r = win;
    // bins li, li + 8, ...: the non-empty ones as bits, added in a `while`
    // loop (most of a small or flat cell's bins are empty)
    // (256 / CELL_INVOCATIONS = 32 bits). Loops bounded by `li` here and in
    // `stats`: lavapipe's compiler unrolls a loop of constant trip count,
    // and the pass's 32 + 32 unrolled atomics took its compile from 9 to
    // 52 ms (and ran 5% slower).
    var full = 0u;
    for (var k = li; k < 256u; k += CELL_INVOCATIONS) {
        full |= select(0u, 1u << ((k - li) / CELL_INVOCATIONS), atomicLoad(&bins[k]) != 0u);
    }
    while (full != 0u) {
        let k = li + CELL_INVOCATIONS * firstTrailingBit(full);
        full &= full - 1u;
        let c = atomicLoad(&bins[k]);
        atomicAdd(&hist[l * 256u + k], c);
        for (var j = r.z; j < r.w; j++) {
            for (var i = r.x; i < r.y; i++) {
                atomicAdd(&window_hist[(P.levels[l].w + j * g.x + i) * 256u + k], c);
            }
        }
    }
}

// stats' reductions: 256 - (lowest non-empty bin), 1 + (highest), the sums
// of the 16 runs of 16 bins.
var<workgroup> lo_inv: atomic<u32>;
var<workgroup> hi_1: atomic<u32>;
var<workgroup> part: array<u32, 16>;

// 8 invocations (one SIMD group of lavapipe), as cells: 32 took 0.3 ms more
// per KITTI frame there.
@compute @workgroup_size(8, 1, 1)
fn stats(@builtin(local_invocation_index) li: u32, @builtin(workgroup_id) wg: vec3<u32>) {
    let l = wg.z;
    let g = P.grids[l];
    let nx = g.x;
    let ny = g.y;
    let i = wg.x;
    let j = wg.y;
    // Workgroup-uniform: the barriers below are reached by all or none.
    if (l >= P.n_levels || i >= nx || j >= ny) { return; }
    let base = (P.levels[l].w + j * nx + i) * 256u;
    // runs 2 li and 2 li + 1 of 16 bins into workgroup memory (loops bounded
    // by li: see cells); this invocation's lowest non-empty bin and 1 + its
    // highest (0: none)
    var lo = 256u;
    var hi = 0u;
    for (var r = 2u * li; r < 2u * li + 2u; r++) {
        var sum = 0u;
        for (var k = r * 16u; k < r * 16u + 16u; k++) {
            let c = atomicLoad(&window_hist[base + k]);
            atomicStore(&bins[k], c);
            sum += c;
            if (c != 0u) {
                lo = min(lo, k);
                hi = k + 1u;
            }
        }
        part[r] = sum;
    }
    if (hi != 0u) {
        atomicMax(&lo_inv, 256u - lo);
        atomicMax(&hi_1, hi);
    }
    workgroupBarrier();
    if (li == 0u) {
        // stats_of in src/cpu/local_threshold.rs over n = a*b > 0 pixels: the
        // lower median is the first bin where the running count passes
        // (n - 1) / 2, found run by run, then bin by bin.
        let n = (g.w & 0xffffu) * (g.w >> 16u);
        let half = (max(n, 1u) - 1u) / 2u;  // `target` on the CPU (a WGSL keyword)
        var acc = 0u;
        var run = 0u;
        while (run < 15u && acc + part[run] <= half) {
            acc += part[run];
            run++;
        }
        // a window holds a*b >= 1 pixels, so the count passes `half` by bin 255
        var median = run * 16u;
        loop {
            acc += atomicLoad(&bins[median]);
            if (acc > half || median == 255u) { break; }
            median++;
        }
        let lo = 256u - atomicLoad(&lo_inv);
        let hi = atomicLoad(&hi_1) - 1u;
        let o = (P.levels[l].w + j * nx + i) * 4u;
        windows[o] = lo;
        windows[o + 1u] = hi;
        windows[o + 2u] = median;
        windows[o + 3u] = hi + median + lo;  // V3 = max + median + min
    }
}
