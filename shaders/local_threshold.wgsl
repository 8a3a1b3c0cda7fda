// SPEC 5: the sliding-window statistics behind the local thresholds TL1, TL2.
// Mirrors src/cpu/local_threshold.rs (`stats_of`; the CPU sums per-cell
// histograms, here each window counts its own pixels: the same histogram).
// m + grid -> windows[(first window of l + j*nx + i) * 4 + {0: min, 1: max,
// 2: lower median, 3: V3}] over M8 = min(M, 255).
// One workgroup per window: workgroup_id = (i, j, level); dispatch
// (max nx, max ny, n_levels), groups beyond a level's grid return at once.
// Tests: tests/gpu_edges_front.rs (this pass alone == src/cpu/local_threshold.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).

@group(0) @binding(1) var<storage, read> m: array<u32>;
@group(0) @binding(2) var<storage, read> grid: array<u32>;
@group(0) @binding(3) var<storage, read_write> windows: array<u32>;

var<workgroup> bins: array<atomic<u32>, 256>;

@compute @workgroup_size(16, 16, 1)
fn main(
    @builtin(local_invocation_id) lid: vec3<u32>,
    @builtin(local_invocation_index) li: u32,
    @builtin(workgroup_id) wg: vec3<u32>,
) {
    let l = wg.z;
    let g = P.grids[l];
    let nx = g.x;
    let ny = g.y;
    let i = wg.x;
    let j = wg.y;
    // Workgroup-uniform: the barriers below are reached by all or none.
    if (l >= P.n_levels || i >= nx || j >= ny) { return; }
    let a = g.w & 0xffffu;
    let b = g.w >> 16u;
    let x0 = grid[g.z + i];       // xs[i]
    let y0 = grid[g.z + nx + j];  // ys[j]

    atomicStore(&bins[li], 0u);
    workgroupBarrier();
    // Rows lid.y, lid.y + 16, ...; columns lid.x, lid.x + 16, ... of the window.
    // Runs of equal values (flat regions) are counted locally and added once.
    var run_v = 0u;
    var run_n = 0u;
    for (var y = lid.y; y < b; y += 16u) {
        let row = loff(l) + (y0 + y) * lw(l) + x0;
        for (var x = lid.x; x < a; x += 16u) {
            let v = min(m[row + x], 255u);
            if (v != run_v && run_n != 0u) {
                atomicAdd(&bins[run_v], run_n);
                run_n = 0u;
            }
            run_v = v;
            run_n += 1u;
        }
    }
    if (run_n != 0u) { atomicAdd(&bins[run_v], run_n); }
    workgroupBarrier();

    if (li == 0u) {
        // stats_of in src/cpu/local_threshold.rs: n = a*b > 0 pixels.
        let n = a * b;
        var lo = 0u;
        var found_lo = false;
        var hi = 0u;
        for (var v = 0u; v < 256u; v++) {
            let c = atomicLoad(&bins[v]);
            if (c > 0u) {
                if (!found_lo) { lo = v; found_lo = true; }
                hi = v;
            }
        }
        let half = (max(n, 1u) - 1u) / 2u;  // `target` on the CPU (a WGSL keyword)
        var acc = 0u;
        var median = 0u;
        for (var v = 0u; v < 256u; v++) {
            acc += atomicLoad(&bins[v]);
            if (acc > half) {
                median = v;
                break;
            }
        }
        let o = (P.levels[l].w + j * nx + i) * 4u;
        windows[o] = lo;
        windows[o + 1u] = hi;
        windows[o + 2u] = median;
        windows[o + 3u] = hi + median + lo;  // V3 = max + median + min
    }
}
