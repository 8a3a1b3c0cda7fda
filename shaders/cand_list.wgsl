// The candidate list (between SPEC 8 and SPEC 9) from a `cand` plane: the
// atlas index of every L-FAST candidate, appended to `cand_list` in no
// particular order, counted in counters[CANDS], and the indirect dispatch
// args over it (64 candidates per workgroup). response.wgsl and
// corner_nms.wgsl run over the list by indirect dispatch. A standalone
// shader: the pipeline's lfast.wgsl appends the list as it finds the
// candidates; this dense scan lets the tests run those passes on a given
// plane.
// Entries: `main`, a column pass (tile_column) over the tile list, all levels
// in one dispatch; then `args`, one invocation.
// Tests: tests/gpu_keypoints.rs (response and corner NMS alone run after it);
// tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).
//
// Races: each candidate takes its own slot of `cand_list` with an atomicAdd on
// counters[CANDS]; `indirect` is stored by the single invocation of `args`.

@group(0) @binding(1) var<storage, read> cand: array<u32>;
@group(0) @binding(2) var<storage, read_write> cand_list: array<u32>;
@group(0) @binding(3) var<storage, read_write> counters: array<atomic<u32>>;
@group(0) @binding(4) var<storage, read_write> indirect: array<u32>;

// indirect::CANDS / 4 in src/gpu/buffers.rs.
const I_CANDS: u32 = 16u;

// Appends the column's candidates: its rows as bits first (`cand` is
// column-packed: a word per four rows, read unconditionally), then a loop
// over the set bits only (an if-body in the walk would run every row, masked,
// on a SIMD software rasteriser).
@compute @workgroup_size(64, 1, 1)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let span = column_span(wg, li);
    if (span.y == span.z) { return; }
    let l = span.w;
    let last = pk_word(l, span.x, lh(l) - 1u);
    let k0 = cand[pk_word(l, span.x, span.y)];
    let k1 = cand[min(pk_word(l, span.x, span.y + 4u), last)];
    let k2 = cand[min(pk_word(l, span.x, span.y + 8u), last)];
    let k3 = cand[min(pk_word(l, span.x, span.y + 12u), last)];
    let zero = vec4<u32>(0u);
    var rows = bits4(pk_rows(k0) != zero) | (bits4(pk_rows(k1) != zero) << 4u)
        | (bits4(pk_rows(k2) != zero) << 8u) | (bits4(pk_rows(k3) != zero) << 12u);
    // rows past the walk's end (a clamped word read again)
    rows &= (1u << (span.z - span.y)) - 1u;
    let base = loff(l) + span.y * lw(l) + span.x;
    while (rows != 0u) {
        let r = countTrailingZeros(rows);
        rows &= rows - 1u;
        cand_list[atomicAdd(&counters[C_CANDS], 1u)] = base + r * lw(l);
    }
}

// The indirect args over the list: ceil(n / 64) workgroups as (x, y, 1),
// x <= 65535.
@compute @workgroup_size(1, 1, 1)
fn args() {
    let g = list_args(atomicLoad(&counters[C_CANDS]));
    indirect[I_CANDS] = g.x;
    indirect[I_CANDS + 1u] = g.y;
    indirect[I_CANDS + 2u] = g.z;
}
