// SPEC 5: the sliding-window statistics behind the local thresholds TL1, TL2.
// Mirrors src/cpu/local_threshold.rs: the windows' histograms of M8 =
// min(M, 255) are sums of the histograms of the cells cut at every window
// edge (spec::cell_cuts), so each pixel is counted once, not once per window
// holding it. m (M8, column-packed, common.wgsl pk_word) + grid -> cell_hist
// (each cell's bins; gpu::local_threshold::cell_words) -> windows[(first window of l + j*nx + i)
// * 4 + {0: min, 1: max, 2: lower median, 3: V3}], and SPEC 4's per-level
// histogram hist[l * 256 + M8] (the cells partition the level, so summing
// their bins counts every pixel once: histogram.wgsl's result, without a
// count of its own in gradient_nms). Two entry points:
// - cells: one workgroup per cell (FrameLayout::cell_groups): the
//   levels' cells one after another in the order of
//   gpu::layout::halves_order (llvmpipe gives each thread a contiguous share
//   of the workgroups: in level order the first of two had 80% of the
//   pixels), each level's row by row; it counts the cell in workgroup memory,
//   stores its non-empty bins in `cell_hist` (cell t at t * cw: cw = 128
//   words of two 16-bit counts where no cell can pass 65535 pixels, else 256,
//   gpu::layout::cell_bin_words) and each invocation's lowest and highest
//   non-empty bin (after every cell's bins), and adds each bin to the
//   level's histogram. (Added with atomics to each of the up to four windows
//   holding the cell, the bins took a fifth of the pass on lavapipe, which
//   runs an atomic lane by lane.) (Dispatched as most cells along x, along y, and a level per z,
//   a KITTI frame's 2055 cells took 2888 workgroups; each idle one cost
//   lavapipe ~1.2 us, ~1 ms of the pass's ~4.1.)
//   CELL_INVOCATIONS (8) invocations: a KITTI cell is ~120x40 pixels at
//   level 0 and ~30x10 at level 7, so a few columns each. Workgroup-wide
//   work (the windows holding the cell, the barrier, the bins' walk) costs
//   every SIMD group of a workgroup on lavapipe: one invocation per bin
//   (256) took 57 ms per frame, 32 took 8.8 ms, 8 (one SIMD group) 7.2.
// - stats: one invocation per window (64 a workgroup, dispatched over the
//   windows of all levels): stats_of over the sum of the histograms of the
//   cells that make up the window (gpu::layout::covering), walked a load of
//   four or eight bins at a time from the window's lowest bin to its median.
// Groups beyond the last cell and invocations beyond the last window
// return at once. `cell_hist` (the frame's cells' bins) and
// `hist` are cleared by the pass before it runs.
// Tests: tests/gpu_edges_front.rs (this pass alone == src/cpu/local_threshold.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).
//
// Races: the workgroup bins and the level histograms are written with
// atomicAdd only; invocation li of the workgroup of cell t writes only cell
// t's bins li + 8 j (with atomicOr into a zeroed word where two 16-bit counts
// share it, so the other half is kept) and its own extent word; stats, a
// dispatch of its own, only reads `cell_hist` and stores the four words of
// window t from invocation t only.

@group(0) @binding(1) var<storage, read> m: array<u32>;
@group(0) @binding(2) var<storage, read> grid: array<u32>;
@group(0) @binding(3) var<storage, read_write> windows: array<u32>;
@group(0) @binding(4) var<storage, read_write> cell_hist: array<atomic<u32>>;
@group(0) @binding(5) var<storage, read_write> hist: array<atomic<u32>>;
// `cell_hist` again, four words a load (stats)
@group(0) @binding(6) var<storage, read_write> cell_hist4: array<vec4<u32>>;

// Zero at the start of a workgroup (WGSL zero-initialises workgroup memory).
var<workgroup> bins: array<atomic<u32>, 256>;

// Bit-sliced counters of the values below 32: bit v of plane k is bit k of
// value v's count, planes 0..3 in `lo`, 4..7 in `hi` (counts < 256). A
// word's four values are added to all 32 counters at once with ~30
// bitwise operations, where 8-bit counters four a word took ~100 (a
// compare, a select and an add per counter word and value).
struct Slices {
    lo: vec4<u32>,
    hi: vec4<u32>,
}

// Adds the one-hot masks o (bit v for value v, 0 for none) of a word's four
// values to the counters.
fn count_word(s: ptr<function, Slices>, o: vec4<u32>) {
    // the four masks' sum per bin in three planes b0 + 2 b1 + 4 b2 (a full
    // adder of o.x, o.y, o.z, a half adder with o.w, a half adder of the carries)
    let x01 = o.x ^ o.y;
    let s3 = x01 ^ o.z;
    let c3 = (o.x & o.y) | (x01 & o.z);
    let b0 = s3 ^ o.w;
    let c4 = s3 & o.w;
    let b1 = c3 ^ c4;
    let b2 = c3 & c4;
    // ripple-carry add into the eight planes
    var a = (*s).lo;
    var h = (*s).hi;
    let k1 = a.x & b0;
    a.x ^= b0;
    var t = a.y ^ b1;
    let k2 = (a.y & b1) | (t & k1);
    a.y = t ^ k1;
    t = a.z ^ b2;
    var k = (a.z & b2) | (t & k2);
    a.z = t ^ k2;
    t = a.w & k;
    a.w ^= k;
    k = t;
    t = h.x & k;
    h.x ^= k;
    k = t;
    t = h.y & k;
    h.y ^= k;
    k = t;
    t = h.z & k;
    h.z ^= k;
    h.w ^= t;  // no carry out: the counters are flushed before one reaches 256
    (*s).lo = a;
    (*s).hi = h;
}

// Adds the counters to the workgroup's bins and clears them: a `while` loop
// over the non-zero ones.
fn flush_slices(s: ptr<function, Slices>) {
    let a = (*s).lo;
    let h = (*s).hi;
    var nz = a.x | a.y | a.z | a.w | h.x | h.y | h.z | h.w;
    while (nz != 0u) {
        let v = firstTrailingBit(nz);
        nz &= nz - 1u;
        let lo = (a >> vec4<u32>(v)) & vec4<u32>(1u);
        let hi = (h >> vec4<u32>(v)) & vec4<u32>(1u);
        atomicAdd(&bins[v], dot(lo, vec4<u32>(1u, 2u, 4u, 8u)) + dot(hi, vec4<u32>(16u, 32u, 64u, 128u)));
    }
    (*s).lo = vec4<u32>(0u);
    (*s).hi = vec4<u32>(0u);
}

// Each lane's bit-sliced counters after its last word (Slices lo, hi at 2
// li, 2 li + 1), for small_counts.
var<workgroup> planes: array<vec4<u32>, 16>;

// The counts of bins li + 8 j (j = 0..3) of the values below 32, summed over
// the workgroup's lanes' counters in `planes`: bits li + 8 j of a lane's
// planes are those bins' counts (< 256) as bits, which shifted into bytes j
// of one word give all four counts at once; bytes 0, 2 and 1, 3 are summed
// in 16-bit halves (eight lanes' counts < 2048). Every lane loads the same
// 16 words.
fn small_counts(li: u32) -> vec4<u32> {
    var even = 0u;
    var odd = 0u;
    for (var s = 0u; s < CELL_INVOCATIONS; s++) {
        let lo = (planes[2u * s] >> vec4<u32>(li)) & vec4<u32>(0x01010101u);
        let hi = (planes[2u * s + 1u] >> vec4<u32>(li)) & vec4<u32>(0x01010101u);
        let c = dot(lo, vec4<u32>(1u, 2u, 4u, 8u)) + dot(hi, vec4<u32>(16u, 32u, 64u, 128u));
        even += c & 0x00ff00ffu;
        odd += (c >> 8u) & 0x00ff00ffu;
    }
    return vec4<u32>(even & 0xffffu, odd & 0xffffu, even >> 16u, odd >> 16u);
}

// Rows a..b of word g (rows 4g .. 4g + 3) inside the cell's rows [y0, y1),
// a contiguous range, as bits; none for a word below the cell.
fn word_rows(g: u32, y0: u32, y1: u32) -> u32 {
    if (g * 4u >= y1) { return 0u; }
    let a = max(g * 4u, y0) - g * 4u;
    let b = min(g * 4u + 4u, y1) - 1u - g * 4u;
    return (0xfu >> (3u - b)) & ~((1u << a) - 1u);
}

// Invocations of a `cells` workgroup (its columns' stride, its bins' stride).
const CELL_INVOCATIONS: u32 = 8u;

@compute @workgroup_size(8, 1, 1)
fn cells(
    @builtin(local_invocation_index) li: u32,
    @builtin(workgroup_id) wg: vec3<u32>,
) {
    // The cell of this workgroup: slot z of the levels' order (two halves of
    // about equal pixels, gpu::layout::halves_order) is the last whose first
    // cell (`before`, n_levels + 1 running counts) is <= t, the workgroup's
    // index (rows of P.tile_row workgroups). Selects with constant indices for
    // the usual levels, a loop only past 8.
    let order = P.cells + 4u * P.n_levels;
    let before = order + P.n_levels;
    let t = wg.x + wg.y * P.tile_row;
    // Workgroup-uniform: the barrier below is reached by all or none.
    if (t >= grid[before + P.n_levels]) { return; }
    var z = 0u;
    z = select(z, 1u, 1u < P.n_levels && t >= grid[before + 1u]);
    z = select(z, 2u, 2u < P.n_levels && t >= grid[before + 2u]);
    z = select(z, 3u, 3u < P.n_levels && t >= grid[before + 3u]);
    z = select(z, 4u, 4u < P.n_levels && t >= grid[before + 4u]);
    z = select(z, 5u, 5u < P.n_levels && t >= grid[before + 5u]);
    z = select(z, 6u, 6u < P.n_levels && t >= grid[before + 6u]);
    z = select(z, 7u, 7u < P.n_levels && t >= grid[before + 7u]);
    for (var k = 8u; k < P.n_levels; k++) {
        if (t >= grid[before + k]) { z = k; }
    }
    let l = grid[order + z];
    let hdr = P.cells + 4u * l;
    let cxo = grid[hdr];
    let ncx = grid[hdr + 1u];
    let cyo = grid[hdr + 2u];
    let c = t - grid[before + z];
    let cy = c / ncx;
    let cx = c - cy * ncx;
    let x0 = grid[cxo + cx];
    let x1 = grid[cxo + cx + 1u];
    let y0 = grid[cyo + cy];
    let y1 = grid[cyo + cy + 1u];
    // Columns li, li + 8, ... of the cell, each down its rows a word (four
    // rows, `m` is column-packed) at a time. Values below 32 (~96% of the
    // pixels of a KITTI frame) are counted in registers, bit-sliced
    // (count_word), and added to the workgroup's bins when a counter could
    // overflow and at the end (flush_slices); 32 more bins in a second set of
    // planes were 20% slower (register spills); the other rows of a word are bits, whose
    // atomics run in a `while` loop as often as the busiest lane of the SIMD
    // group needs (an atomic under a per-row `if` costs every lane every row
    // on a SIMD software rasteriser).
    var sl: Slices;
    // pixels counted in registers since the last flush (a word adds <= 4, so
    // an `if` empties them in time: a `while` costs its loop masks every word)
    var pending = 0u;
    for (var x = x0 + li; x < x1; x += CELL_INVOCATIONS) {
        // two words (eight rows) a step: the loop's own work (its test, the
        // flush check, the `while` over values >= 32) once per two, 6.08 ->
        // 5.58 ms per KITTI frame on lavapipe
        for (var g4 = y0 >> 2u; g4 * 4u < y1; g4 += 2u) {
            if (pending > 247u) {
                flush_slices(&sl);
                pending = 0u;
            }
            let in0 = word_rows(g4, y0, y1);
            let in1 = word_rows(g4 + 1u, y0, y1);
            let last = pk_word(l, x, y1 - 1u);
            let word0 = m[pk_word(l, x, g4 * 4u)];
            let word1 = m[min(pk_word(l, x, g4 * 4u + 4u), last)];
            let v0 = pk_rows(word0);
            let v1 = pk_rows(word1);
            let small0 = v0 < vec4<u32>(32u);
            let small1 = v1 < vec4<u32>(32u);
            let r0 = (vec4<u32>(in0) & vec4<u32>(1u, 2u, 4u, 8u)) != vec4<u32>(0u);
            let r1 = (vec4<u32>(in1) & vec4<u32>(1u, 2u, 4u, 8u)) != vec4<u32>(0u);
            count_word(&sl, select(vec4<u32>(0u), vec4<u32>(1u) << v0, r0 & small0));
            count_word(&sl, select(vec4<u32>(0u), vec4<u32>(1u) << v1, r1 & small1));
            pending += 8u;
            var big = (in0 & ~bits4(small0)) | ((in1 & ~bits4(small1)) << 4u);
            while (big != 0u) {
                let e = firstTrailingBit(big);
                big &= big - 1u;
                atomicAdd(&bins[pk_byte(select(word0, word1, e >= 4u), e & 3u)], 1u);
            }
        }
    }
    // The counters left in registers are not flushed bin by bin (an atomic
    // per non-zero counter and lane): each lane's eight planes go to
    // workgroup memory, and lane li sums every lane's counts of its own bins
    // below 32 (small_counts). The pass 4.42-4.84 -> 4.11-4.50 ms per KITTI
    // frame on lavapipe (four alternated rounds).
    planes[2u * li] = sl.lo;
    planes[2u * li + 1u] = sl.hi;
    workgroupBarrier();
    let small = small_counts(li);
    // bins li, li + 8, ...: the non-empty ones as bits, added in a `while`
    // loop (most of a small or flat cell's bins are empty)
    // (256 / CELL_INVOCATIONS = 32 bits). Loops bounded by `li` here and in
    // `stats`: lavapipe's compiler unrolls a loop of constant trip count,
    // and the pass's 32 + 32 unrolled atomics took its compile from 9 to
    // 52 ms (and ran 5% slower).
    var full = select(0u, 1u, small.x != 0u) | select(0u, 2u, small.y != 0u) | select(0u, 4u, small.z != 0u)
        | select(0u, 8u, small.w != 0u);
    for (var k = li; k < 256u; k += CELL_INVOCATIONS) {
        full |= select(0u, 1u << ((k - li) / CELL_INVOCATIONS), atomicLoad(&bins[k]) != 0u);
    }
    // this invocation's lowest and highest non-empty bin (256 and 0: none),
    // after the bins of every cell of the frame (cw words each)
    let cw = grid[before + P.n_levels + 1u];
    let lo = select(256u, li + CELL_INVOCATIONS * firstTrailingBit(full), full != 0u);
    let hi = select(0u, li + CELL_INVOCATIONS * firstLeadingBit(full), full != 0u);
    atomicStore(&cell_hist[grid[before + P.n_levels] * cw + t * CELL_INVOCATIONS + li], lo | (hi << 16u));
    while (full != 0u) {
        let j = firstTrailingBit(full);
        let k = li + CELL_INVOCATIONS * j;
        full &= full - 1u;
        let c = atomicLoad(&bins[k]) + select(0u, small[min(j, 3u)], j < 4u);
        atomicAdd(&hist[l * 256u + k], c);
        if (cw == 256u) {
            atomicStore(&cell_hist[t * 256u + k], c);
        } else {
            atomicOr(&cell_hist[t * 128u + (k >> 1u)], c << (16u * (k & 1u)));
        }
    }
}

// One invocation per window, t = the window's index over all levels
// (P.levels[l].w is level l's first), 64 a workgroup, no workgroup memory
// and no barrier: stats_of in src/cpu/local_threshold.rs over the sum of the
// histograms of the cells that make up the window (cells rx.x .. rx.y along
// x, ry.x .. ry.y along y, gpu::layout::covering). Its lowest and highest
// bin are those of its cells' invocations (their extent words); the walk for
// the lower median takes a load (four or eight bins) of each cell at a time,
// from the load of the lowest bin on, and stops at the median. (A workgroup per window, its 8
// invocations summing runs of bins for one to walk, took ~0.7 ms per KITTI
// frame on lavapipe: each of ~720 workgroups paid its barrier and workgroup
// memory.)
@compute @workgroup_size(64, 1, 1)
fn stats(@builtin(global_invocation_id) id: vec3<u32>) {
    let t = id.x;
    var l = 0u;
    for (var k = 1u; k < P.n_levels; k++) {
        if (t >= P.levels[k].w) { l = k; }
    }
    let g = P.grids[l];
    if (l >= P.n_levels || t >= P.levels[l].w + g.x * g.y) { return; }
    // over n = a*b > 0 pixels the lower median is the first bin where the
    // running count passes (n - 1) / 2
    let n = (g.w & 0xffffu) * (g.w >> 16u);
    let half = (max(n, 1u) - 1u) / 2u;  // `target` on the CPU (a WGSL keyword)
    let wi = t - P.levels[l].w;
    let iy = wi / g.x;
    let ix = wi - iy * g.x;
    let hdr = P.cells + 4u * l;
    let ncx = grid[hdr + 1u];
    let rx = grid[grid[hdr] + ncx + 1u + ix];
    let ry = grid[grid[hdr + 2u] + grid[hdr + 3u] + 1u + iy];
    let x0 = rx & 0xffffu;
    let x1 = rx >> 16u;
    let y0 = ry & 0xffffu;
    let y1 = ry >> 16u;
    // level l's first cell in the order of the `cells` dispatch
    let order = P.cells + 4u * P.n_levels;
    let before = order + P.n_levels;
    var first = 0u;
    for (var z = 0u; z < P.n_levels; z++) {
        if (grid[order + z] == l) { first = grid[before + z]; }
    }
    // the extent words, two loads a cell, after the frame's cells' bins (cw
    // words, q4 = cw / 4 loads, a cell)
    let cw = grid[before + P.n_levels + 1u];
    let q4 = cw / 4u;
    let ext = grid[before + P.n_levels] * q4;
    var lo = 256u;
    var hi = 0u;
    for (var cy = y0; cy < y1; cy++) {
        for (var cx = x0; cx < x1; cx++) {
            let c = first + cy * ncx + cx;
            let e = cell_hist4[ext + 2u * c];
            let f = cell_hist4[ext + 2u * c + 1u];
            let a = min(e & vec4<u32>(0xffffu), f & vec4<u32>(0xffffu));
            let b = max(e >> vec4<u32>(16u), f >> vec4<u32>(16u));
            lo = min(lo, min(min(a.x, a.y), min(a.z, a.w)));
            hi = max(hi, max(max(b.x, b.y), max(b.z, b.w)));
        }
    }
    // a window holds a*b >= 1 pixels, so lo <= 255 and the count passes
    // `half` by bin 255; the bins of lo's load below lo are empty. A load
    // holds bins 4 q .. 4 q + 3 (cw = 256) or 8 q .. 8 q + 7 as 16-bit
    // counts, the even bins in the low halves (summed apart: a window's sum
    // may pass 65535).
    let per = 256u / q4;  // bins a load
    var acc = 0u;
    var median = 256u;
    for (var q = min(lo, 255u) / per; q < q4 && median == 256u; q++) {
        var s = vec4<u32>(0u);  // bins per, per + 1 (cw = 128), per + 2, per + 3 of the load
        var u = vec4<u32>(0u);  // the odd bins of a load of 16-bit counts
        for (var cy = y0; cy < y1; cy++) {
            for (var cx = x0; cx < x1; cx++) {
                let v = cell_hist4[(first + cy * ncx + cx) * q4 + q];
                if (cw == 256u) {
                    s += v;
                } else {
                    s += v & vec4<u32>(0xffffu);
                    u += v >> vec4<u32>(16u);
                }
            }
        }
        // the counts in bin order: c[i] is bin per * q + i
        var c: array<u32, 8>;
        if (cw == 256u) {
            c = array<u32, 8>(s.x, s.y, s.z, s.w, 0u, 0u, 0u, 0u);
        } else {
            c = array<u32, 8>(s.x, u.x, s.y, u.y, s.z, u.z, s.w, u.w);
        }
        for (var i = 0u; i < per; i++) {
            acc += c[i];
            median = select(median, per * q + i, acc > half && median == 256u);
        }
    }
    median = min(median, 255u);
    lo = min(lo, 255u);
    let o = t * 4u;
    windows[o] = lo;
    windows[o + 1u] = hi;
    windows[o + 2u] = median;
    windows[o + 3u] = hi + median + lo;  // V3 = max + median + min
}
