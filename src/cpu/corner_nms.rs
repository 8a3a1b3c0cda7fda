//! SPEC 9: non-maximum suppression among corner candidates. Mirrors shaders/corner_nms.wgsl.

/// True iff candidate `q` beats candidate `p`: a greater response, or an equal
/// one and an earlier (y, x) position, so exactly one of a tied group survives.
#[inline]
pub fn beats(rq: f32, q: [u32; 2], rp: f32, p: [u32; 2]) -> bool {
    rq > rp || (rq == rp && (q[1], q[0]) < (p[1], p[0]))
}

/// Indices of the candidates that no other candidate within the (2r+1)^2
/// square beats. `cands` in any order; the result is in input order. The
/// level size is the shader's dispatch size; this sparse version needs only the candidates.
///
/// ```
/// let keep = lfast::cpu::corner_nms::corner_nms(10, 10, &[[2, 2], [3, 3], [9, 9]], &[1.0, 2.0, 0.5], 1);
/// assert_eq!(keep, vec![1, 2]);
/// ```
pub fn corner_nms(_width: u32, _height: u32, cands: &[[u32; 2]], resp: &[f32], r: u32) -> Vec<usize> {
    // Visit candidates in raster order, a row at a time. The rows within r of
    // the current row form a window that only moves down; in each of them a
    // cursor skips the candidates left of x - r, and only moves right as x
    // grows along the row. So each candidate reads just its (2r+1)^2 square.
    let n = cands.len();
    let mut by_pos: Vec<usize> = (0..n).collect();
    by_pos.sort_unstable_by_key(|&i| (cands[i][1], cands[i][0]));
    let xs: Vec<u32> = by_pos.iter().map(|&i| cands[i][0]).collect();
    // starts[k]..starts[k + 1]: the k-th row of by_pos
    let mut starts: Vec<usize> = (0..n).filter(|&k| k == 0 || cands[by_pos[k - 1]][1] != cands[by_pos[k]][1]).collect();
    starts.push(n);
    let rows = starts.len() - 1;
    let row_y = |k: usize| cands[by_pos[starts[k]]][1];
    let (mut r0, mut r1) = (0, 0);
    let mut cursors = Vec::new();
    let mut keep = Vec::new();
    for k in 0..rows {
        let py = row_y(k);
        while row_y(r0) + r < py {
            r0 += 1;
        }
        while r1 < rows && row_y(r1) <= py + r {
            r1 += 1;
        }
        cursors.clear();
        cursors.extend_from_slice(&starts[r0..r1]);
        for (m, &i) in by_pos.iter().enumerate().take(starts[k + 1]).skip(starts[k]) {
            let px = xs[m];
            let (lo, hi) = (px.saturating_sub(r), px.saturating_add(r));
            let beaten = cursors.iter_mut().zip(&starts[r0 + 1..=r1]).any(|(c, &end)| {
                while *c < end && xs[*c] < lo {
                    *c += 1;
                }
                (*c..end).take_while(|&q| xs[q] <= hi).any(|q| {
                    let j = by_pos[q];
                    j != i && beats(resp[j], cands[j], resp[i], cands[i])
                })
            });
            if !beaten {
                keep.push(i);
            }
        }
    }
    keep.sort_unstable();
    keep
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ties_keep_exactly_one() {
        let c = [[5, 5], [6, 5], [5, 6], [6, 6]];
        assert_eq!(corner_nms(20, 20, &c, &[1.0; 4], 1), vec![0]);
        assert_eq!(corner_nms(20, 20, &c, &[1.0; 4], 0), vec![0, 1, 2, 3]);
    }

    #[test]
    fn radius_is_a_square() {
        // (10,10) strongest; (13,13) is at Chebyshev distance 3: suppressed at r=3, kept at r=2
        let c = [[10, 10], [13, 13], [14, 10]];
        let r = [5.0, 4.0, 3.0];
        assert_eq!(corner_nms(30, 30, &c, &r, 3), vec![0]);
        assert_eq!(corner_nms(30, 30, &c, &r, 2), vec![0, 1, 2]);
    }

    proptest::proptest! {
        #[test]
        fn matches_naive(pts in proptest::collection::vec((0u32..24, 0u32..24), 0..80), r in 0u32..5, seed in 0u64..1000) {
            // any order, duplicate positions allowed
            let cands: Vec<[u32; 2]> = pts.iter().map(|&(x, y)| [x, y]).collect();
            // few distinct responses to force ties
            let resp: Vec<f32> = (0..cands.len()).map(|i| ((i as u64 * 7 + seed) % 5) as f32).collect();
            let got = corner_nms(24, 24, &cands, &resp, r);
            let want: Vec<usize> = (0..cands.len()).filter(|&i| {
                !(0..cands.len()).any(|j| j != i
                    && cands[j][0].abs_diff(cands[i][0]) <= r && cands[j][1].abs_diff(cands[i][1]) <= r
                    && beats(resp[j], cands[j], resp[i], cands[i]))
            }).collect();
            proptest::prop_assert_eq!(got, want);
        }
    }
}
