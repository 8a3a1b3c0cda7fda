// SPEC 2: LSD 2x2 gradient (paper Eq. 2) in integers. Mirrors src/cpu/gradient.rs.
// denoised -> gx (gx2 as i32), gy (gy2 as i32), s (S = gx2^2 + gy2^2), m (M8 =
// min(M, 255), M = isqrt(S) >> 1; column-packed, common.wgsl pk_word).
// A column pass, all levels in one dispatch (over the tile list).
// Tests: tests/gpu_edges_front.rs (this pass alone == src/cpu/gradient.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).
//
// Races: no atomics. Each invocation owns one column of one tile (column_span):
// gx, gy and s are a word per pixel, and m's words of that column cover its
// 16 rows exactly (4 whole words, common.wgsl pk_word), so no two invocations
// write one word.

@group(0) @binding(1) var<storage, read> denoised: array<u32>;
@group(0) @binding(2) var<storage, read_write> gx: array<i32>;
@group(0) @binding(3) var<storage, read_write> gy: array<i32>;
@group(0) @binding(4) var<storage, read_write> s: array<u32>;
@group(0) @binding(5) var<storage, read_write> m: array<u32>;

// D at (x, y) of level l (column-packed, common.wgsl pk_word).
fn dval(l: u32, x: u32, y: u32) -> i32 { return i32(pk_byte(denoised[pk_word(l, x, y)], y)); }

// A column pass (tile_column): rows y and y + 1 of columns x and x + 1 walk
// down in registers (two reads per pixel instead of four). Right and bottom
// reads clamp (x, y themselves are inside).
@compute @workgroup_size(64, 1, 1)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let span = column_span(wg, li);
    if (span.y == span.z) { return; }
    let l = span.w;
    let w = lw(l);
    let h = lh(l);
    let x = span.x;
    let xr = min(x + 1u, w - 1u);
    var row = loff(l) + span.y * w;
    var a = dval(l, x, span.y);   // (x, y)
    var b = dval(l, xr, span.y);  // (x+1, y)
    var word = 0u;
    for (var y = span.y; y < span.z; y++) {
        let yb = min(y + 1u, h - 1u);
        let c = dval(l, x, yb);   // (x, y+1)
        let e = dval(l, xr, yb);  // (x+1, y+1)
        let dx = b + e - a - c;
        let dy = c + e - a - b;
        let sq = u32(dx * dx + dy * dy);
        let i = row + x;
        gx[i] = dx;
        gy[i] = dy;
        s[i] = sq;
        word |= pk_place(min(magnitude(sq), 255u), y);
        if (pk_complete(y, span.z)) {
            m[pk_word(l, x, y)] = word;
            word = 0u;
        }
        a = c;
        b = e;
        row += w;
    }
}
