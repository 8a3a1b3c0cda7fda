// SPEC 9: Harris corner response on D (7x7 block, 3x3 Sobel, k = 0.04), as
// OpenCV ORB's HARRIS_SCORE. Mirrors src/cpu/response.rs.
// `cand` (1 = candidate; column-packed, common.wgsl pk_word) + `denoised` -> `resp` (f32 bits) at candidates, 0
// elsewhere (the pass clears `resp` first). A column pass, all levels in one dispatch (over the tile list); the
// response itself runs on the workgroup's compacted candidates (see main).
//
// Bit-identical to the CPU: the structure sums are exact integers, and the
// final formula (harris_from_sums) is f32 in the CPU's operation order, with
// every i32 -> f32 conversion rounded explicitly (to_f32) and every
// intermediate passed through `opaque`, so that no compiler can contract
// a*b + c into an fma or reassociate (Rust does neither).
// Tests: tests/gpu_keypoints.rs (this pass alone == src/cpu/response.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).

@group(0) @binding(1) var<storage, read> cand: array<u32>;
@group(0) @binding(2) var<storage, read> denoised: array<u32>;
@group(0) @binding(3) var<storage, read_write> resp: array<u32>;

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

fn px(l: u32, x: i32, y: i32) -> i32 {
    // D is column-packed (common.wgsl pk_word); coordinates clamped as `clamped`
    let cx = u32(clamp(x, 0, i32(lw(l)) - 1));
    let cy = u32(clamp(y, 0, i32(lh(l)) - 1));
    return i32(pk_byte(denoised[pk_word(l, cx, cy)], cy));
}

// (Ix², Iy², IxIy) of the 3x3 Sobel at the centre of the 3x3 a (row above),
// b (centre row: only its ends count), c (row below), each (left, centre, right).
fn sobel_terms(a: vec3<i32>, b0: i32, b2: i32, c: vec3<i32>) -> vec3<i32> {
    let ix = (b2 - b0) * 2 + (a.z - a.x) + (c.z - c.x);
    let iy = (c.y - a.y) * 2 + (c.x - a.x) + (c.z - a.z);
    return vec3(ix * ix, iy * iy, ix * iy);
}

// Row y's nine pixels x - 4 .. x + 4 of level l, clamped, as three vec3.
fn row9(l: u32, x: i32, y: i32) -> array<vec3<i32>, 3> {
    return array<vec3<i32>, 3>(
        vec3(px(l, x - 4, y), px(l, x - 3, y), px(l, x - 2, y)),
        vec3(px(l, x - 1, y), px(l, x, y), px(l, x + 1, y)),
        vec3(px(l, x + 2, y), px(l, x + 3, y), px(l, x + 4, y)));
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
// footprint is read a row at a time, three rows kept (sums of exact integers,
// so the order does not matter).
fn structure_sums(l: u32, x: i32, y: i32) -> vec3<i32> {
    var up = row9(l, x, y - R - 1);
    var mid = row9(l, x, y - R);
    var sums = vec3(0);
    for (var by = -R; by <= R; by++) {
        let down = row9(l, x, y + by + 1);
        sums += row_terms(up, mid, down);
        up = mid;
        mid = down;
    }
    return sums;
}

// Work-efficient: the column's candidates are listed (list_candidates,
// cand_list.wgsl, appended to this shader), then taken side by side.
@compute @workgroup_size(64, 1, 1)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    list_candidates(column_span(wg, li), li.x);
    workgroupBarrier();
    let n = atomicLoad(&todo_n);
    for (var k = li.x; k < n; k += 64u) {
        let p = list_pixel(wg, todo[k]);
        let s = structure_sums(p.z, i32(p.x), i32(p.y));
        resp[loff(p.z) + p.y * lw(p.z) + p.x] = bitcast<u32>(harris_from_sums(s.x, s.y, s.z));
    }
}
