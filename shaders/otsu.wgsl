// SPEC 4, second half: Otsu's threshold with exact integer arithmetic, so the
// GPU picks exactly the k of the CPU. Mirrors src/cpu/otsu.rs.
// hist -> otsu[l] = k + 1 (T1), or 0 when the level has no edges (at most one
// non-empty bin). One workgroup per level (workgroup_id.x), invocation k
// evaluates the split at k, then a tree reduction keeps the best k.
//
// WGSL has no u64/u128, so the numbers of src/cpu/otsu.rs are little-endian
// u32 limbs. With n <= 2^28 pixels per level (docs/algorithm.md, stage 0):
// sum = Σ i*h[i] < 2^36, d = |n*s0 - n0*sum| < 2^62, num = d^2 < 2^124,
// den = n0*n1 < 2^56, and the cross products num*bden < 2^180: every value
// fits the 192-bit `Wide` below, so all arithmetic here is exact.
// Tests: tests/gpu_edges_front.rs (this pass alone == src/cpu/otsu.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).

@group(0) @binding(1) var<storage, read> hist: array<u32>;
@group(0) @binding(2) var<storage, read_write> otsu: array<u32>;

const LIMBS: u32 = 6u;
// A 192-bit unsigned number, limb 0 least significant.
alias Wide = array<u32, 6>;

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

fn wide(lo: u32, hi: u32) -> Wide {
    return Wide(lo, hi, 0u, 0u, 0u, 0u);
}

// a + b (mod 2^192).
fn add(a_in: Wide, b_in: Wide) -> Wide {
    var a = a_in;
    var b = b_in;
    var r: Wide;
    var carry = 0u;
    for (var i = 0u; i < LIMBS; i++) {
        let t = a[i] + b[i];
        let c1 = select(0u, 1u, t < a[i]);
        let t2 = t + carry;
        let c2 = select(0u, 1u, t2 < t);
        r[i] = t2;
        carry = c1 + c2;
    }
    return r;
}

// a - b for a >= b.
fn sub(a_in: Wide, b_in: Wide) -> Wide {
    var a = a_in;
    var b = b_in;
    var r: Wide;
    var borrow = 0u;
    for (var i = 0u; i < LIMBS; i++) {
        let t = a[i] - b[i];
        let b1 = select(0u, 1u, a[i] < b[i]);
        let t2 = t - borrow;
        let b2 = select(0u, 1u, t < borrow);
        r[i] = t2;
        borrow = b1 + b2;
    }
    return r;
}

// a * b (mod 2^192), schoolbook. Each step adds r + p + carry < 2^64.
fn mul(a_in: Wide, b_in: Wide) -> Wide {
    var a = a_in;
    var b = b_in;
    var r: Wide;
    for (var i = 0u; i < LIMBS; i++) {
        var carry = 0u;
        for (var j = 0u; i + j < LIMBS; j++) {
            let p = mul32(a[i], b[j]);
            let t = r[i + j] + p.x;
            let c1 = select(0u, 1u, t < p.x);
            let t2 = t + carry;
            let c2 = select(0u, 1u, t2 < t);
            r[i + j] = t2;
            carry = p.y + c1 + c2;
        }
    }
    return r;
}

// -1, 0, 1 as a <, ==, > b.
fn cmp(a_in: Wide, b_in: Wide) -> i32 {
    var a = a_in;
    var b = b_in;
    for (var i = 0; i < i32(LIMBS); i++) {
        let k = LIMBS - 1u - u32(i);
        if (a[k] != b[k]) { return select(-1, 1, a[k] > b[k]); }
    }
    return 0;
}

var<workgroup> h: array<u32, 256>;
// Per slot of the reduction: the candidate's k (NO_K = none), num (4 limbs), den (2 limbs).
var<workgroup> red_k: array<u32, 256>;
var<workgroup> red_num: array<vec4<u32>, 256>;
var<workgroup> red_den: array<vec2<u32>, 256>;

const NO_K: u32 = 0xffffffffu;

// Does candidate slot j beat slot i? Larger num/den (as num_j*den_i > num_i*den_j,
// src/cpu/otsu.rs's cross products), then the smaller k: the CPU's scan keeps
// the first maximum, i.e. the smallest k among exact ties.
fn beats(j: u32, i: u32) -> bool {
    if (red_k[j] == NO_K) { return false; }
    if (red_k[i] == NO_K) { return true; }
    let nj = red_num[j];
    let ni = red_num[i];
    let dj = red_den[j];
    let di = red_den[i];
    let lhs = mul(Wide(nj.x, nj.y, nj.z, nj.w, 0u, 0u), wide(di.x, di.y));
    let rhs = mul(Wide(ni.x, ni.y, ni.z, ni.w, 0u, 0u), wide(dj.x, dj.y));
    let c = cmp(lhs, rhs);
    return c > 0 || (c == 0 && red_k[j] < red_k[i]);
}

@compute @workgroup_size(256, 1, 1)
fn main(@builtin(local_invocation_index) k: u32, @builtin(workgroup_id) wg: vec3<u32>) {
    let l = wg.x;
    if (l >= P.n_levels) { return; }
    h[k] = hist[l * 256u + k];
    workgroupBarrier();

    // n, sum over all bins and n0, s0 over bins 0..=k (each invocation sums
    // its own prefix: 256 steps, no scan to get wrong).
    var n = wide(0u, 0u);
    var sum = wide(0u, 0u);
    var n0 = wide(0u, 0u);
    var s0 = wide(0u, 0u);
    for (var i = 0u; i < 256u; i++) {
        let c = wide(h[i], 0u);
        let ic = mul32(i, h[i]);
        n = add(n, c);
        sum = add(sum, wide(ic.x, ic.y));
        if (i <= k) {
            n0 = add(n0, c);
            s0 = add(s0, wide(ic.x, ic.y));
        }
    }
    let n1 = sub(n, n0);
    let zero = wide(0u, 0u);
    // k runs over 0..255 (exclusive) on the CPU; 255 always has n1 == 0.
    var my_k = NO_K;
    var num = zero;
    var den = zero;
    if (k < 255u && cmp(n0, zero) != 0 && cmp(n1, zero) != 0) {
        // d = |n*s0 - n0*sum|, num = d^2, den = n0*n1
        let p = mul(n, s0);
        let q = mul(n0, sum);
        var d: Wide;
        if (cmp(p, q) >= 0) { d = sub(p, q); } else { d = sub(q, p); }
        num = mul(d, d);
        den = mul(n0, n1);
        my_k = k;
    }
    red_k[k] = my_k;
    red_num[k] = vec4(num[0], num[1], num[2], num[3]);
    red_den[k] = vec2(den[0], den[1]);
    workgroupBarrier();

    for (var stride = 128u; stride > 0u; stride >>= 1u) {
        if (k < stride && beats(k + stride, k)) {
            red_k[k] = red_k[k + stride];
            red_num[k] = red_num[k + stride];
            red_den[k] = red_den[k + stride];
        }
        workgroupBarrier();
    }
    if (k == 0u) {
        otsu[l] = select(red_k[0] + 1u, 0u, red_k[0] == NO_K);
    }
}
