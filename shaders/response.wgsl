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

// The integer structure-tensor sums (a, b, c) = (ΣIx², ΣIy², ΣIxIy) over the
// 7x7 block centred on (x, y), reads clamped, as structure_sums. The 9x9
// footprint is read once into `win` (win[j][i] = D(x - 4 + i, y - 4 + j)).
fn structure_sums(l: u32, x: i32, y: i32) -> vec3<i32> {
    var win: array<array<i32, 9>, 9>;
    for (var j = 0; j < 9; j++) {
        for (var i = 0; i < 9; i++) {
            win[j][i] = px(l, x - R - 1 + i, y - R - 1 + j);
        }
    }
    var a = 0;
    var b = 0;
    var c = 0;
    for (var by = 1; by <= 2 * R + 1; by++) {
        for (var bx = 1; bx <= 2 * R + 1; bx++) {
            let ix = (win[by][bx + 1] - win[by][bx - 1]) * 2 + (win[by - 1][bx + 1] - win[by - 1][bx - 1])
                + (win[by + 1][bx + 1] - win[by + 1][bx - 1]);
            let iy = (win[by + 1][bx] - win[by - 1][bx]) * 2 + (win[by + 1][bx - 1] - win[by - 1][bx - 1])
                + (win[by + 1][bx + 1] - win[by - 1][bx + 1]);
            a += ix * ix;
            b += iy * iy;
            c += ix * iy;
        }
    }
    return vec3(a, b, c);
}

// Work-efficient: a column pass (tile_column) that lists its four tiles'
// candidates in `todo` (workgroup memory) as it walks them (the pass clears
// `resp` before it runs, so every other pixel holds 0); after one barrier the workgroup's invocations take the list
// side by side and write the responses, so the 9x9 window and the formula run
// in as few SIMD lanes / warps as there are candidates. Entries:
// list_entry (common.wgsl).
var<workgroup> todo: array<u32, 1024>;
// zero at the start of the workgroup (WGSL zero-initialises workgroup memory)
var<workgroup> todo_n: atomic<u32>;

@compute @workgroup_size(64, 1, 1)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let span = column_span(wg, li);
    let l = span.w;
    var word = 0u;
    for (var y = span.y; y < span.z; y++) {
        // `cand` is column-packed: its word once per four rows
        if ((y & 3u) == 0u) { word = cand[pk_word(l, span.x, y)]; }
        if (pk_byte(word, y) != 0u) {
            todo[atomicAdd(&todo_n, 1u)] = list_entry(li.x, y - span.y);
        }
    }
    workgroupBarrier();
    let n = atomicLoad(&todo_n);
    for (var k = li.x; k < n; k += 64u) {
        let p = list_pixel(wg, todo[k]);
        let s = structure_sums(p.z, i32(p.x), i32(p.y));
        resp[loff(p.z) + p.y * lw(p.z) + p.x] = bitcast<u32>(harris_from_sums(s.x, s.y, s.z));
    }
}
