// SPEC 9: non-maximum suppression among corner candidates. Mirrors
// src/cpu/corner_nms.rs. `cand` (column-packed, common.wgsl pk_word) + `resp` -> survivors appended to `corners`
// (GpuKeypoint, src/gpu/buffers.rs) with counters[CORNERS] as the cursor.
// One invocation per candidate, all levels in one indirect dispatch over the
// candidate list (cand_list.wgsl). The append order is nondeterministic;
// select.wgsl puts the list in SPEC 9 order.
// Tests: tests/gpu_keypoints.rs (this pass alone == src/cpu/corner_nms.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).
//
// Races: each survivor takes its own slot of `corners` with an atomicAdd on
// counters[CORNERS] (slots past the capacity are not written); resp is only read,
// and only at candidates (`cand` bits): response.wgsl writes those words only.

// Four columns' words a load (x a multiple of 4: common.wgsl pk_pitch).
@group(0) @binding(1) var<storage, read> cand: array<vec4<u32>>;
@group(0) @binding(2) var<storage, read> cand_list: array<u32>;
@group(0) @binding(3) var<storage, read> resp: array<u32>;
@group(0) @binding(4) var<storage, read_write> corners: array<Kp>;
@group(0) @binding(5) var<storage, read_write> counters: array<atomic<u32>>;

// True iff candidate q beats candidate p: a greater response, or an equal one
// and an earlier (y, x) position, so exactly one of a tied group survives.
fn beats(rq: f32, q: vec2<u32>, rp: f32, p: vec2<u32>) -> bool {
    return rq > rp || (rq == rp && (q.y < p.y || (q.y == p.y && q.x < p.x)));
}

// Candidate p of level l: appended to `corners`
// iff no other candidate of its (2r+1)^2 square beats it.
fn suppress(l: u32, p: vec2<u32>) {
    let w = lw(l);
    let h = lh(l);
    let i = loff(l) + p.y * w + p.x;
    let rp = bitcast<f32>(resp[i]);
    // Config::reject_edges: Harris's edge (or NaN) is no corner. It could not
    // beat a positive candidate, so dropping it here changes no other survivor.
    if (P.reject_edges != 0u && !(rp > 0.0)) { return; }
    // The (2r+1)^2 square, cut to the level (outside it there are no candidates).
    let r = P.nms_radius;
    let x0 = select(0u, p.x - r, p.x >= r);
    let y0 = select(0u, p.y - r, p.y >= r);
    let x1 = min(p.x + r, w - 1u);
    let y1 = min(p.y + r, h - 1u);
    // Four columns and four rows at a time, one aligned load of `cand`
    // words: the other candidates among them in the square as bits (bit
    // 4k + r: column xc + k, row 4g + r), then a `while` loop over those
    // only reads their responses (candidates are sparse; which beats p first
    // changes nothing). Loops test at the top and stop once p is beaten: no
    // early return inside (a SIMD software rasteriser keeps an exec mask per
    // exit). Four columns a load: 1.86-1.90 -> 1.25-1.42 ms per KITTI frame on lavapipe
    // (radius 4: 9 loads a candidate instead of 27).
    var beaten = false;
    for (var g = y0 >> 2u; g <= (y1 >> 2u) && !beaten; g++) {
        let lo = u32(max(i32(y0) - i32(4u * g), 0));
        let hi = u32(min(i32(y1) - i32(4u * g), 3));
        let rows = vec4<u32>(((2u << hi) - 1u) & ~((1u << lo) - 1u));
        for (var xc = x0 & ~3u; xc <= x1 && !beaten; xc += 4u) {
            let words = cand[pk_word(l, xc, 4u * g) >> 2u];
            let cols = vec4<u32>(xc) + vec4<u32>(0u, 1u, 2u, 3u);
            let b = select(vec4<u32>(0u), vec4<u32>(
                bits4(pk_rows(words.x) != vec4<u32>(0u)), bits4(pk_rows(words.y) != vec4<u32>(0u)),
                bits4(pk_rows(words.z) != vec4<u32>(0u)), bits4(pk_rows(words.w) != vec4<u32>(0u))) & rows,
                (cols >= vec4<u32>(x0)) & (cols <= vec4<u32>(x1)));
            var bits = b.x | (b.y << 4u) | (b.z << 8u) | (b.w << 12u);
            // not p itself
            let own = p.x >= xc && p.x < xc + 4u && (p.y >> 2u) == g;
            bits &= ~select(0u, 1u << (4u * (p.x - xc) + (p.y & 3u)), own);
            while (bits != 0u && !beaten) {
                let t = countTrailingZeros(bits);
                bits &= bits - 1u;
                let x = xc + (t >> 2u);
                let y = 4u * g + (t & 3u);
                beaten = beats(bitcast<f32>(resp[loff(l) + y * w + x]), vec2(x, y), rp, p);
            }
        }
    }
    if (beaten) { return; }
    // A survivor. P.capacity bounds the survivors (docs/algorithm.md), the
    // guard only keeps a broken bound from writing out of the list.
    let slot = atomicAdd(&counters[C_CORNERS], 1u);
    if (slot >= P.capacity) { return; }
    let s = P.scales[l];
    var k: Kp;
    k.x = (f32(p.x) + 0.5) * s.x;
    k.y = (f32(p.y) + 0.5) * s.x;
    k.size = s.y;
    k.angle = 0.0;
    k.response = rp;
    k.level = l;
    k.px = p.x;
    k.py = p.y;
    k.m10 = 0;
    k.m01 = 0;
    k.bin = 0u;
    k.sub = 0u;
    corners[slot] = k;
}

// Work-efficient: an indirect dispatch over the candidate list, one
// invocation per candidate (cand_list.wgsl).
@compute @workgroup_size(64, 1, 1)
fn main(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(local_invocation_id) li: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    // the list's runs interleaved between the dispatch's halves (common.wgsl)
    let k = list_index_spread(wg, li, nwg);
    if (k >= atomicLoad(&counters[C_CANDS])) { return; }
    let p = atlas_pixel(cand_list[k]);
    suppress(p.z, p.xy);
}
