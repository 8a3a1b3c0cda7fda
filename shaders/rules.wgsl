// SPEC 7 rules 1 and 2: isolated-edge suppression (paper Algorithm 3).
// Mirrors src/cpu/rules.rs. `classes` (SPEC 6) -> `ruled`, one invocation per
// pixel, all levels in one dispatch (over the tile list). Both rules read the classes
// of SPEC 6 only, so the result does not depend on the order of invocations.
// Tests: tests/gpu_edges_back.rs (this pass alone == src/cpu/rules.rs) and tests/gpu_end_to_end.rs (whole pipeline); tests/gpu_shaders.rs (naga, bindings).

@group(0) @binding(1) var<storage, read> classes: array<u32>;
@group(0) @binding(2) var<storage, read_write> ruled: array<u32>;

// Classes of src/cpu/classify.rs.
const NONE: u32 = 0u;
const WEAK_WEAK: u32 = 1u;
const WEAK: u32 = 2u;
const WEAK_STRONG: u32 = 3u;
const STRONG: u32 = 4u;

// True iff one of the 8 neighbours of (x, y) inside the level has class `c`.
// Neighbours outside the level do not exist (no replicate border here).
fn has_neighbour(l: u32, x: i32, y: i32, c: u32) -> bool {
    let w = i32(lw(l));
    let h = i32(lh(l));
    for (var dy = -1; dy <= 1; dy++) {
        for (var dx = -1; dx <= 1; dx++) {
            let nx = x + dx;
            let ny = y + dy;
            if ((dx != 0 || dy != 0) && nx >= 0 && ny >= 0 && nx < w && ny < h
                && classes[loff(l) + u32(ny) * lw(l) + u32(nx)] == c) {
                return true;
            }
        }
    }
    return false;
}

// The class of (x, y) after rules 1 and 2 (rule_at in the CPU module).
fn rule_at(l: u32, x: i32, y: i32) -> u32 {
    let c = classes[loff(l) + u32(y) * lw(l) + u32(x)];
    if (c == WEAK_STRONG) {
        return select(WEAK, STRONG, has_neighbour(l, x, y, WEAK_STRONG));
    }
    if (c == WEAK_WEAK) {
        return select(WEAK, NONE, has_neighbour(l, x, y, WEAK_WEAK));
    }
    return c;
}

@compute @workgroup_size(16, 16, 1)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) li: vec3<u32>) {
    let id = tile_pixel(wg, li);
    let l = id.z;
    if (id.x >= lw(l) || id.y >= lh(l)) { return; }
    ruled[loff(l) + id.y * lw(l) + id.x] = rule_at(l, i32(id.x), i32(id.y));
}
