// SPEC 9: Harris corner response on D (7x7 block, 3x3 Sobel, k = 0.04), as
// OpenCV ORB's HARRIS_SCORE. Mirrors src/cpu/response.rs.
// The candidate list (`cand_list`, atlas indices; cand_list.wgsl) + `denoised` -> `resp` (f32 bits) at
// the candidates, one invocation per candidate, all levels in one indirect
// dispatch over the list. The other words of `resp` are left as they were
// (it shares its memory with `labels` and `edge_list`, which earlier stages
// of the frame used: src/gpu/footprint.rs): corner_nms.wgsl, the only
// reader, reads candidates' responses only (src/gpu/response.rs).
//
// Bit-identical to the CPU: the structure sums are exact integers, and the
// final formula (harris_from_sums) is f32 in the CPU's operation order, with
// every i32 -> f32 conversion rounded explicitly (to_f32) and every
// intermediate passed through `opaque`, so that no compiler can contract
// a*b + c into an fma or reassociate (Rust does neither).
// Tests: tests/gpu_keypoints.rs (this pass alone == src/cpu/response.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).
//
// Races: no atomics. Invocation k stores resp at its candidate's atlas index
// only; the candidate list holds each pixel at most once (lfast.wgsl appends a
// pixel once, from its one edge-list entry), so no two invocations write one
// word.

@group(0) @binding(1) var<storage, read> cand_list: array<u32>;
@group(0) @binding(2) var<storage, read> counters: array<u32>;
@group(0) @binding(3) var<storage, read> denoised: array<u32>;
@group(0) @binding(4) var<storage, read_write> resp: array<u32>;

// BLOCK / 2.
const R: i32 = 3;
// HARRIS_K = 0.04f32.
const HARRIS_K_BITS: u32 = 0x3d23d70au;
// scale^4 with scale = 1 / (4 * BLOCK * 255) in f32, multiplied left to right
// as the CPU does (3.8477533e-16; tests/gpu_keypoints.rs checks the bits).
const SCALE_SQ_SQ_BITS: u32 = 0x25ddced1u;

// x, opaque to the compiler: OR-ing its bits with a runtime zero
// (Params.scales[l].w is always 0.0, see src/gpu/layout.rs) makes it a value
// the compiler knows nothing about. Every intermediate of the formula goes
// through it, so each operation is rounded on its own as written: no a*b + c
// contracted into an fma, no reassociation (lavapipe, for one, reassociates
// products with a constant: without this, K * (s * s) gave (K * s) * s's bits).
fn opaque(x: f32) -> f32 {
    return bitcast<f32>(bitcast<u32>(x) | bitcast<u32>(P.scales[0].w));
}

// i32 -> f32 rounded to nearest, ties to even (Rust's `as f32`), done in
// integers so that it does not depend on the device's conversion rounding.
// |v| < 2^31 (the sums are below 49 * 1020^2 < 2^26).
fn to_f32(v: i32) -> f32 {
    let m = u32(abs(v));
    var r = m;
    if (m >= (1u << 24u)) {
        let sh = firstLeadingBit(m) - 23u; // bits below the 24-bit significand
        let q = m >> sh;
        let rem = m & ((1u << sh) - 1u);
        let half = 1u << (sh - 1u);
        var up = q;
        if (rem > half || (rem == half && (q & 1u) == 1u)) { up = q + 1u; }
        r = up << sh; // at most 2^26: exactly representable
    }
    let f = f32(r); // exact: r has at most 24 significant bits
    return select(f, -f, v < 0);
}

// OpenCV's Harris response from the integer sums, as harris_from_sums:
// (a * b - c * c - K * (a + b) * (a + b)) * scale_sq_sq, left to right.
fn harris_from_sums(ai: i32, bi: i32, ci: i32) -> f32 {
    let a = to_f32(ai);
    let b = to_f32(bi);
    let c = to_f32(ci);
    let k = opaque(bitcast<f32>(HARRIS_K_BITS));
    let scale_sq_sq = opaque(bitcast<f32>(SCALE_SQ_SQ_BITS));
    let ab = opaque(a * b);
    let cc = opaque(c * c);
    let d = opaque(ab - cc);
    let s = opaque(a + b);
    let ks = opaque(k * s);
    let kss = opaque(ks * s);
    let e = opaque(d - kss);
    return e * scale_sq_sq;
}

// Rows y - 4 .. y + 4 (clamped into the level) of column x (clamped) of D,
// as three vec3 (rows y-4..y-2, y-1..y+1, y+2..y+4). D is column-packed
// (common.wgsl pk_word): nine clamped rows lie in three consecutive words, so
// the column costs three loads, not nine.
struct Col9 {
    a: vec3<i32>,
    b: vec3<i32>,
    c: vec3<i32>,
}

fn col9(l: u32, x: i32, y: i32) -> Col9 {
    let cx = u32(clamp(x, 0, i32(lw(l)) - 1));
    let hm = i32(lh(l)) - 1;
    let top = u32(clamp(y - 4, 0, hm));
    let base = pk_word(l, cx, top);
    let last = pk_word(l, cx, u32(hm));
    let w0 = denoised[base];
    let w1 = denoised[min(base + pk_pitch(l), last)];
    let w2 = denoised[min(base + 2u * pk_pitch(l), last)];
    let g = top >> 2u;
    return Col9(
        vec3(d_row(w0, w1, w2, g, y - 4, hm), d_row(w0, w1, w2, g, y - 3, hm), d_row(w0, w1, w2, g, y - 2, hm)),
        vec3(d_row(w0, w1, w2, g, y - 1, hm), d_row(w0, w1, w2, g, y, hm), d_row(w0, w1, w2, g, y + 1, hm)),
        vec3(d_row(w0, w1, w2, g, y + 2, hm), d_row(w0, w1, w2, g, y + 3, hm), d_row(w0, w1, w2, g, y + 4, hm)));
}

// D at row y (clamped to 0 ..= hm) from the words of groups g, g + 1, g + 2.
fn d_row(w0: u32, w1: u32, w2: u32, g: u32, y: i32, hm: i32) -> i32 {
    let yc = u32(clamp(y, 0, hm));
    let k = (yc >> 2u) - g;
    return i32(pk_byte(select(select(w0, w1, k >= 1u), w2, k >= 2u), yc));
}

// (Ix², Iy², IxIy) of the 3x3 Sobel at the centre of the 3x3 a (row above),
// b (centre row: only its ends count), c (row below), each (left, centre, right).
fn sobel_terms(a: vec3<i32>, b0: i32, b2: i32, c: vec3<i32>) -> vec3<i32> {
    let ix = (b2 - b0) * 2 + (a.z - a.x) + (c.z - c.x);
    let iy = (c.y - a.y) * 2 + (c.x - a.x) + (c.z - a.z);
    return vec3(ix * ix, iy * iy, ix * iy);
}

// The seven Sobel terms of block row b (rows a above and c below), summed.
// Written out with constant indices: an array indexed in a loop is gathered
// lane by lane on lavapipe (and may leave registers on real GPUs).
fn row_terms(a: array<vec3<i32>, 3>, b: array<vec3<i32>, 3>, c: array<vec3<i32>, 3>) -> vec3<i32> {
    let a0 = a[0];
    let a1 = a[1];
    let a2 = a[2];
    let b0 = b[0];
    let b1 = b[1];
    let b2 = b[2];
    let c0 = c[0];
    let c1 = c[1];
    let c2 = c[2];
    // centre columns x - 3 .. x + 3 (window columns 1 .. 7)
    return sobel_terms(a0, b0.x, b0.z, c0)
        + sobel_terms(vec3(a0.yz, a1.x), b0.y, b1.x, vec3(c0.yz, c1.x))
        + sobel_terms(vec3(a0.z, a1.xy), b0.z, b1.y, vec3(c0.z, c1.xy))
        + sobel_terms(a1, b1.x, b1.z, c1)
        + sobel_terms(vec3(a1.yz, a2.x), b1.y, b2.x, vec3(c1.yz, c2.x))
        + sobel_terms(vec3(a1.z, a2.xy), b1.z, b2.y, vec3(c1.z, c2.xy))
        + sobel_terms(a2, b2.x, b2.z, c2);
}

// The integer structure-tensor sums (a, b, c) = (ΣIx², ΣIy², ΣIxIy) over the
// 7x7 block centred on (x, y), reads clamped, as structure_sums: the 9x9
// footprint is read a column at a time (col9), and the seven block rows are
// written out with constant indices (sums of exact integers, so the order
// does not matter).
fn structure_sums(l: u32, x: i32, y: i32) -> vec3<i32> {
    let c0 = col9(l, x + -4, y);
    let c1 = col9(l, x + -3, y);
    let c2 = col9(l, x + -2, y);
    let c3 = col9(l, x + -1, y);
    let c4 = col9(l, x + 0, y);
    let c5 = col9(l, x + 1, y);
    let c6 = col9(l, x + 2, y);
    let c7 = col9(l, x + 3, y);
    let c8 = col9(l, x + 4, y);
    let r0 = array<vec3<i32>, 3>(vec3(c0.a.x, c1.a.x, c2.a.x), vec3(c3.a.x, c4.a.x, c5.a.x), vec3(c6.a.x, c7.a.x, c8.a.x));
    let r1 = array<vec3<i32>, 3>(vec3(c0.a.y, c1.a.y, c2.a.y), vec3(c3.a.y, c4.a.y, c5.a.y), vec3(c6.a.y, c7.a.y, c8.a.y));
    let r2 = array<vec3<i32>, 3>(vec3(c0.a.z, c1.a.z, c2.a.z), vec3(c3.a.z, c4.a.z, c5.a.z), vec3(c6.a.z, c7.a.z, c8.a.z));
    let r3 = array<vec3<i32>, 3>(vec3(c0.b.x, c1.b.x, c2.b.x), vec3(c3.b.x, c4.b.x, c5.b.x), vec3(c6.b.x, c7.b.x, c8.b.x));
    let r4 = array<vec3<i32>, 3>(vec3(c0.b.y, c1.b.y, c2.b.y), vec3(c3.b.y, c4.b.y, c5.b.y), vec3(c6.b.y, c7.b.y, c8.b.y));
    let r5 = array<vec3<i32>, 3>(vec3(c0.b.z, c1.b.z, c2.b.z), vec3(c3.b.z, c4.b.z, c5.b.z), vec3(c6.b.z, c7.b.z, c8.b.z));
    let r6 = array<vec3<i32>, 3>(vec3(c0.c.x, c1.c.x, c2.c.x), vec3(c3.c.x, c4.c.x, c5.c.x), vec3(c6.c.x, c7.c.x, c8.c.x));
    let r7 = array<vec3<i32>, 3>(vec3(c0.c.y, c1.c.y, c2.c.y), vec3(c3.c.y, c4.c.y, c5.c.y), vec3(c6.c.y, c7.c.y, c8.c.y));
    let r8 = array<vec3<i32>, 3>(vec3(c0.c.z, c1.c.z, c2.c.z), vec3(c3.c.z, c4.c.z, c5.c.z), vec3(c6.c.z, c7.c.z, c8.c.z));
    return row_terms(r0, r1, r2) + row_terms(r1, r2, r3) + row_terms(r2, r3, r4) + row_terms(r3, r4, r5)
        + row_terms(r4, r5, r6) + row_terms(r5, r6, r7) + row_terms(r6, r7, r8);
}

// Work-efficient: an indirect dispatch over the candidate list, one
// invocation per candidate (cand_list.wgsl lists them, for this pass and
// corner NMS), so nothing scans the levels' pixels here.
@compute @workgroup_size(64, 1, 1)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let k = list_index(wg, li);
    if (k >= counters[C_CANDS]) { return; }
    let i = cand_list[k];
    let p = atlas_pixel(i);
    let s = structure_sums(p.z, i32(p.x), i32(p.y));
    resp[i] = bitcast<u32>(harris_from_sums(s.x, s.y, s.z));
}
