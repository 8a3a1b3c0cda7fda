// The work list of the candidate passes, response.wgsl and corner_nms.wgsl:
// src/gpu/response.rs and src/gpu/corner_nms.rs append this file to their
// shader, which declares `cand`. One definition, so the two cannot drift.
//
// A column pass's invocation lists its column's candidates in `todo`
// (workgroup memory); after one barrier the workgroup's invocations take the
// list side by side, so the per-candidate work runs in as few SIMD lanes /
// warps as there are candidates. Entries: list_entry (common.wgsl); their
// order is unspecified (each is processed on its own).

var<workgroup> todo: array<u32, 1024>;
// zero at the start of the workgroup (WGSL zero-initialises workgroup memory)
var<workgroup> todo_n: atomic<u32>;

// Appends the candidates of the column span `span` (column_span) of lane
// `lane`: its rows as bits first (`cand` is column-packed: a word per four
// rows), then a loop over the set bits only (an if-body in the walk would run
// every row, masked, on a SIMD software rasteriser).
fn list_candidates(span: vec4<u32>, lane: u32) {
    var rows = 0u;
    for (var y = span.y; y < span.z; y += 4u) {
        rows |= bits4(pk_rows(cand[pk_word(span.w, span.x, y)]) != vec4<u32>(0u)) << (y - span.y);
    }
    while (rows != 0u) {
        let r = countTrailingZeros(rows);
        rows &= rows - 1u;
        todo[atomicAdd(&todo_n, 1u)] = list_entry(lane, r);
    }
}
