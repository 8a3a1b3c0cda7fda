// SPEC 4, second half: Otsu's threshold with exact integer arithmetic, so the
// GPU picks exactly the k of the CPU. Mirrors src/cpu/otsu.rs; tests:
// tests/gpu_edges_front.rs (709 random histograms, ties, 2^28 totals).
// hist -> otsu[l] = k + 1 (T1), or 0 when the level has no edges (at most one
// non-empty bin). One workgroup per level (workgroup_id.x) of 64
// invocations; invocation t evaluates the splits at 4t .. 4t + 3, then a
// tree reduction keeps the best k.
//
// WGSL has no u64/u128, so the numbers of src/cpu/otsu.rs are little-endian
// u32 limbs of fixed width, in straight-line code (no dynamically indexed
// arrays: those spill to memory on real GPUs). With n <= 2^28 pixels per level
// (docs/algorithm.md, stage 0): n, n0, n1 < 2^32 (one limb), s0 and sum =
// Σ i*h[i] < 2^36 (two), n*s0 and n0*sum < 2^64 * 2^28 (three),
// d = |n*s0 - n0*sum| < 2^62 (two), num = d^2 < 2^124 (four), den = n0*n1
// < 2^56 (two), and the cross products num*bden < 2^180 (six): all exact.
// n0 and s0 come from a workgroup prefix sum (Hillis-Steele over the 64
// invocations' sums of four bins, 6 steps).
// Tests: tests/gpu_edges_front.rs (this pass alone == src/cpu/otsu.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).
//
// Races: one workgroup per level; the workgroup arrays are written at index t
// by invocation t only, with a barrier between every read of another lane's
// entry and the next write (the scan reads t - off before the barrier and
// writes t after it; the reduction writes t < stride from t + stride >= stride,
// which no lane writes in that round); otsu[l] is stored by invocation 0 only.

@group(0) @binding(1) var<storage, read> hist: array<u32>;
@group(0) @binding(2) var<storage, read_write> otsu: array<u32>;

// a * b as a 64-bit (lo, hi) pair, from 16-bit halves.
fn mul32(a: u32, b: u32) -> vec2<u32> {
    let a0 = a & 0xffffu;
    let a1 = a >> 16u;
    let b0 = b & 0xffffu;
    let b1 = b >> 16u;
    let p00 = a0 * b0;
    let p01 = a0 * b1;
    let p10 = a1 * b0;
    let p11 = a1 * b1;
    // bits 16..48 of the product, < 3 * 2^16: no overflow
    let mid = (p00 >> 16u) + (p01 & 0xffffu) + (p10 & 0xffffu);
    let lo = (p00 & 0xffffu) | (mid << 16u);
    let hi = p11 + (p01 >> 16u) + (p10 >> 16u) + (mid >> 16u);
    return vec2(lo, hi);
}

// a + b + c as (sum mod 2^32, carry); carry <= 2 for c <= 2.
fn add3(a: u32, b: u32, c: u32) -> vec2<u32> {
    let t = a + b;
    let t2 = t + c;
    return vec2(t2, select(0u, 1u, t < a) + select(0u, 1u, t2 < t));
}

// 64-bit a + b (mod 2^64).
fn add64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let lo = add3(a.x, b.x, 0u);
    return vec2(lo.x, a.y + b.y + lo.y);
}

// a * b, a 32-bit, b 64-bit: 96 bits.
fn mul_32x64(a: u32, b: vec2<u32>) -> vec3<u32> {
    let p0 = mul32(a, b.x);
    let p1 = mul32(a, b.y);
    let r1 = add3(p0.y, p1.x, 0u);
    return vec3(p0.x, r1.x, p1.y + r1.y);
}

// -1, 0, 1 as a <, ==, > b (96 bits).
fn cmp96(a: vec3<u32>, b: vec3<u32>) -> i32 {
    if (a.z != b.z) { return select(-1, 1, a.z > b.z); }
    if (a.y != b.y) { return select(-1, 1, a.y > b.y); }
    if (a.x != b.x) { return select(-1, 1, a.x > b.x); }
    return 0;
}

// a - b for a >= b (96 bits).
fn sub96(a: vec3<u32>, b: vec3<u32>) -> vec3<u32> {
    let b0 = select(0u, 1u, a.x < b.x);
    let y = a.y - b.y - b0;
    let b1 = select(0u, 1u, a.y < b.y || (a.y == b.y && b0 == 1u));
    return vec3(a.x - b.x, y, a.z - b.z - b1);
}

// a * b, both 64-bit: 128 bits.
fn mul_64x64(a: vec2<u32>, b: vec2<u32>) -> vec4<u32> {
    let p00 = mul32(a.x, b.x);
    let p01 = mul32(a.x, b.y);
    let p10 = mul32(a.y, b.x);
    let p11 = mul32(a.y, b.y);
    let r1a = add3(p00.y, p01.x, 0u);
    let r1 = add3(r1a.x, p10.x, 0u);
    let r2a = add3(p01.y, p10.y, r1a.y + r1.y);
    let r2 = add3(r2a.x, p11.x, 0u);
    return vec4(p00.x, r1.x, r2.x, p11.y + r2a.y + r2.y);
}

// a * b, a 128-bit, b 32-bit: 160 bits as (low 128, high 32).
struct U160 { lo: vec4<u32>, hi: u32 }

fn mul_128x32(a: vec4<u32>, b: u32) -> U160 {
    let p0 = mul32(a.x, b);
    let p1 = mul32(a.y, b);
    let p2 = mul32(a.z, b);
    let p3 = mul32(a.w, b);
    let r1 = add3(p0.y, p1.x, 0u);
    let r2 = add3(p1.y, p2.x, r1.y);
    let r3 = add3(p2.y, p3.x, r2.y);
    return U160(vec4(p0.x, r1.x, r2.x, r3.x), p3.y + r3.y);
}

// a * b, a 128-bit, b 64-bit: 192 bits as (low 96, high 96).
struct U192 { lo: vec3<u32>, hi: vec3<u32> }

fn mul_128x64(a: vec4<u32>, b: vec2<u32>) -> U192 {
    // a*b.x + (a*b.y << 32)
    let x = mul_128x32(a, b.x);
    let y = mul_128x32(a, b.y);
    let r1 = add3(x.lo.y, y.lo.x, 0u);
    let r2 = add3(x.lo.z, y.lo.y, r1.y);
    let r3 = add3(x.lo.w, y.lo.z, r2.y);
    let r4 = add3(x.hi, y.lo.w, r3.y);
    let r5 = y.hi + r4.y;
    return U192(vec3(x.lo.x, r1.x, r2.x), vec3(r3.x, r4.x, r5));
}

// -1, 0, 1 as a <, ==, > b (192 bits).
fn cmp192(a: U192, b: U192) -> i32 {
    let c = cmp96(a.hi, b.hi);
    if (c != 0) { return c; }
    return cmp96(a.lo, b.lo);
}

// Per invocation t (bins 4t .. 4t + 3): the count and moment (64-bit) of
// its bins, then (after the scan) of bins 0 .. 4t - 1.
var<workgroup> scan_n: array<u32, 64>;
var<workgroup> scan_s: array<vec2<u32>, 64>;
// Per slot of the reduction: the candidate's k (NO_K = none), num (4 limbs), den (2 limbs).
var<workgroup> red_k: array<u32, 64>;
var<workgroup> red_num: array<vec4<u32>, 64>;
var<workgroup> red_den: array<vec2<u32>, 64>;

const NO_K: u32 = 0xffffffffu;

// Does candidate (kj, num_j, den_j) beat (ki, num_i, den_i)? Larger num/den
// (as num_j*den_i > num_i*den_j, src/cpu/otsu.rs's cross products), then the
// smaller k: the CPU's scan keeps the first maximum, i.e. the smallest k
// among exact ties.
fn beats(kj: u32, num_j: vec4<u32>, den_j: vec2<u32>, ki: u32, num_i: vec4<u32>, den_i: vec2<u32>) -> bool {
    if (kj == NO_K) { return false; }
    if (ki == NO_K) { return true; }
    let c = cmp192(mul_128x64(num_j, den_i), mul_128x64(num_i, den_j));
    return c > 0 || (c == 0 && kj < ki);
}

// 64 invocations, four bins each (256 with one bin each waited at ~26
// barriers, which lavapipe pays per SIMD group of 8: 32 groups a level).
@compute @workgroup_size(64, 1, 1)
fn main(@builtin(local_invocation_index) t: u32, @builtin(workgroup_id) wg: vec3<u32>) {
    let l = wg.x;
    if (l >= P.n_levels) { return; }
    let h = vec4<u32>(hist[l * 256u + 4u * t], hist[l * 256u + 4u * t + 1u], hist[l * 256u + 4u * t + 2u], hist[l * 256u + 4u * t + 3u]);
    // this invocation's bins' count and moment (k * h[k] < 2^36: 64-bit sums)
    var sn = h.x + h.y + h.z + h.w;
    var ss = add64(add64(mul32(4u * t, h.x), mul32(4u * t + 1u, h.y)), add64(mul32(4u * t + 2u, h.z), mul32(4u * t + 3u, h.w)));
    scan_n[t] = sn;
    scan_s[t] = ss;
    workgroupBarrier();
    // inclusive prefix sums over the 64 (Hillis-Steele, 6 steps): no carry
    // out of 32 bits for n (<= 2^28) nor of 64 for s
    for (var off = 1u; off < 64u; off <<= 1u) {
        var vn = scan_n[t];
        var vs = scan_s[t];
        if (t >= off) {
            vn += scan_n[t - off];
            vs = add64(vs, scan_s[t - off]);
        }
        workgroupBarrier();
        scan_n[t] = vn;
        scan_s[t] = vs;
        workgroupBarrier();
    }
    let n = scan_n[63];
    let sum = scan_s[63];
    // bins 0 .. 4t - 1
    var n0 = select(0u, scan_n[max(t, 1u) - 1u], t > 0u);
    var s0 = select(vec2<u32>(0u), scan_s[max(t, 1u) - 1u], t > 0u);
    // the best of this invocation's four splits (a loop bounded by t, so the
    // compiler keeps one copy of the arithmetic)
    var best_k = NO_K;
    var best_num = vec4(0u);
    var best_den = vec2(0u);
    for (var k = 4u * t; k < 4u * t + 4u; k++) {
        let hk = hist[l * 256u + k];
        n0 += hk;
        s0 = add64(s0, mul32(k, hk));
        let n1 = n - n0;
        // k runs over 0..255 (exclusive) on the CPU; 255 always has n1 == 0.
        if (k < 255u && n0 != 0u && n1 != 0u) {
            // d = |n*s0 - n0*sum| < 2^62, num = d^2, den = n0*n1
            let p = mul_32x64(n, s0);
            let q = mul_32x64(n0, sum);
            var d: vec3<u32>;
            if (cmp96(p, q) >= 0) { d = sub96(p, q); } else { d = sub96(q, p); }
            let num = mul_64x64(d.xy, d.xy);
            let den = mul32(n0, n1);
            if (beats(k, num, den, best_k, best_num, best_den)) {
                best_k = k;
                best_num = num;
                best_den = den;
            }
        }
    }
    red_k[t] = best_k;
    red_num[t] = best_num;
    red_den[t] = best_den;
    workgroupBarrier();
    for (var stride = 32u; stride > 0u; stride >>= 1u) {
        if (t < stride && beats(red_k[t + stride], red_num[t + stride], red_den[t + stride], red_k[t], red_num[t], red_den[t])) {
            red_k[t] = red_k[t + stride];
            red_num[t] = red_num[t + stride];
            red_den[t] = red_den[t + stride];
        }
        workgroupBarrier();
    }
    if (t == 0u) {
        otsu[l] = select(red_k[0] + 1u, 0u, red_k[0] == NO_K);
    }
}
