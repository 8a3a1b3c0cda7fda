//! SPEC 9: non-maximum suppression among corner candidates. Mirrors shaders/corner_nms.wgsl.

use super::simd::dispatch;

/// True iff candidate `q` beats candidate `p`: a greater response, or an equal
/// one and an earlier (y, x) position, so exactly one of a tied group survives.
#[inline]
pub fn beats(rq: f32, q: [u32; 2], rp: f32, p: [u32; 2]) -> bool {
    rq > rp || (rq == rp && (q[1], q[0]) < (p[1], p[0]))
}

/// Indices of the candidates that no other candidate within the (2r+1)^2
/// square beats. `cands` in any order; the result is in input order. The
/// level size is the shader's dispatch size; the CPU needs only the candidates.
/// In raster order (as [`crate::cpu::lfast::lfast`] gives them), at distinct
/// positions and with no NaN response, a dense window of rows decides
/// (`raster_nms`); otherwise a sparse walk over the candidates does.
///
/// ```
/// let keep = lfast::cpu::corner_nms::corner_nms(10, 10, &[[2, 2], [3, 3], [9, 9]], &[1.0, 2.0, 0.5], 1);
/// assert_eq!(keep, vec![1, 2]);
/// ```
pub fn corner_nms(_width: u32, _height: u32, cands: &[[u32; 2]], resp: &[f32], r: u32) -> Vec<usize> {
    let raster = cands.windows(2).all(|w| (w[0][1], w[0][0]) < (w[1][1], w[1][0]));
    if raster && cands.len() < u32::MAX as usize && !resp.iter().any(|v| v.is_nan()) {
        return raster_nms(cands, resp, r);
    }
    corner_nms_sparse(cands, resp, r)
}

/// The corner NMS stage as a [`crate::Config`] sets it: with `reject_edges`,
/// the candidates whose Harris response is not above 0 (Harris and Stephens'
/// edge; NaN too) are dropped first, as the early return of
/// shaders/corner_nms.wgsl `suppress` does. None of them could beat a positive
/// candidate, so the survivors are [`corner_nms`]'s positive ones. Indices into
/// `cands`, in input order.
///
/// ```
/// use lfast::cpu::corner_nms::survivors;
/// let (c, r) = ([[1, 1], [2, 1], [9, 9]], [0.5, 1.0, -1.0]);
/// assert_eq!(survivors(&c, &r, 1, false), vec![1, 2]);
/// assert_eq!(survivors(&c, &r, 1, true), vec![1]);
/// ```
pub fn survivors(cands: &[[u32; 2]], resp: &[f32], r: u32, reject_edges: bool) -> Vec<usize> {
    if !reject_edges {
        return corner_nms(0, 0, cands, resp, r);
    }
    let kept: Vec<usize> = (0..cands.len()).filter(|&i| resp[i] > 0.0).collect();
    let c: Vec<[u32; 2]> = kept.iter().map(|&i| cands[i]).collect();
    let v: Vec<f32> = kept.iter().map(|&i| resp[i]).collect();
    corner_nms(0, 0, &c, &v, r).into_iter().map(|k| kept[k]).collect()
}

/// An order-preserving map of a non-NaN f32 to i32 (-0.0 and 0.0 alike; every
/// value above `i32::MIN`, which stands for "no candidate"), so that comparing
/// responses is comparing integers.
#[inline(always)]
fn ordered_key(v: f32) -> i32 {
    let b = (v + 0.0).to_bits();
    (if b >> 31 == 1 { !b } else { b | 1 << 31 } ^ 1 << 31) as i32
}

/// `y % side`, recomputed only when y changes.
#[derive(Clone, Copy)]
struct RowSlots {
    side: usize,
    y: u32,
    at: usize,
}

impl RowSlots {
    #[inline(always)]
    fn of(&mut self, y: u32) -> usize {
        if y != self.y {
            (self.y, self.at) = (y, y as usize % self.side);
        }
        self.at
    }
}

/// Lanes per compare of [`raster_nms`] (8 x i32: one AVX2 register).
const LANES: usize = 8;

dispatch! {
    /// [`corner_nms`] for candidates in strict raster order with no NaN
    /// response. A ring of 2r + 1 dense rows of response keys
    /// ([`ordered_key`]), padded by r on the left, holds the candidates of
    /// the rows within r of the current one. p is beaten by a greater key in
    /// its square, or an equal one at an earlier position (a row above, or
    /// left in its own row): [`beats`], decided by compares 8 lanes at a time
    /// without a branch.
    fn raster_nms(cands: &[[u32; 2]], resp: &[f32], r: u32) -> Vec<usize> {
        let side = 2 * r as usize + 1;
        let chunks = side.div_ceil(LANES);
        let width = cands.iter().map(|c| c[0] as usize).max().map_or(0, |x| x + 1 + chunks * LANES);
        let mut ring = vec![i32::MIN; side * width];
        // row y's ring row is y % side, computed once per row (a division costs more than the compares)
        let mut slots = RowSlots { side, y: u32::MAX, at: 0 };
        let (mut ins, mut del) = (0, 0);
        let mut keep = Vec::new();
        let (mut ins_slots, mut del_slots) = (slots, slots);
        for (p, &[px, py]) in cands.iter().enumerate() {
            // rows y - r..=y + r in the ring, and none other
            while del < ins && cands[del][1] + r < py {
                let [x, y] = cands[del];
                ring[del_slots.of(y) * width + r as usize + x as usize] = i32::MIN;
                del += 1;
            }
            while ins < cands.len() && cands[ins][1] <= py.saturating_add(r) {
                let [x, y] = cands[ins];
                ring[ins_slots.of(y) * width + r as usize + x as usize] = ordered_key(resp[ins]);
                ins += 1;
            }
            let kp = ordered_key(resp[p]);
            // the ring row of y - r (rows above the top hold no key)
            let top = (slots.of(py) + side - r as usize) % side;
            let sq = Square { ring: &ring, width, top, x: px as usize };
            // radius 4 (the default) and 3 (SPEC 9's) with constants, so that the compares unroll
            let beaten = match side {
                9 => sq.beaten(kp, 9, 2),
                7 => sq.beaten(kp, 7, 1),
                _ => sq.beaten(kp, side, chunks),
            };
            if !beaten {
                keep.push(p);
            }
        }
        keep
    }
}

/// The square of one candidate in [`raster_nms`]'s ring.
struct Square<'a> {
    ring: &'a [i32],
    width: usize,
    /// the ring row of the square's top row
    top: usize,
    /// the square's left column in the ring (which is padded by r)
    x: usize,
}

impl Square<'_> {
    /// Whether a key in the square beats `kp`: a greater one, or an equal one
    /// at an earlier position. One compare per lane against a threshold:
    /// `kp - 1` where equal beats (the rows above, the left of p's row), `kp`
    /// where only greater does, `i32::MAX` on lanes past the square. The rows
    /// are read nearest first (p's own, then one above and one below, ...),
    /// and the first row that beats p ends the search: most candidates lose
    /// to a neighbour on the edge they lie on, in their own row or the next.
    #[inline(always)]
    fn beaten(&self, kp: i32, side: usize, chunks: usize) -> bool {
        let r = side / 2;
        // per chunk: the thresholds of the rows above, p's row and the rows below
        let mut t = [[[0i32; LANES]; 3]; 2];
        for (c, tc) in t.iter_mut().enumerate().take(chunks.min(2)) {
            for (k, earlier) in [side, r, 0].into_iter().enumerate() {
                for i in 0..LANES {
                    let lane = c * LANES + i;
                    tc[k][i] = if lane >= side {
                        i32::MAX
                    } else if lane < earlier {
                        kp - 1
                    } else {
                        kp
                    };
                }
            }
        }
        if self.row_beats(&t, kp, side, chunks, r) {
            return true;
        }
        // a loop, not `(1..=r).any(..)`: that closure was called out of line,
        // built without the kernel's target features
        for d in 1..=r {
            if self.row_beats(&t, kp, side, chunks, r - d) || self.row_beats(&t, kp, side, chunks, r + d) {
                return true;
            }
        }
        false
    }

    /// Whether row `j` of the square beats `kp`, with the thresholds `t` of [`Self::beaten`].
    #[inline(always)]
    fn row_beats(&self, t: &[[[i32; LANES]; 3]; 2], kp: i32, side: usize, chunks: usize, j: usize) -> bool {
        let r = side / 2;
        let k = (j >= r) as usize + (j > r) as usize;
        let sl = if self.top + j >= side { self.top + j - side } else { self.top + j };
        let row = &self.ring[sl * self.width + self.x..];
        let mut acc = [0i32; LANES];
        for c in 0..chunks {
            let v: &[i32; LANES] = row[c * LANES..][..LANES].try_into().expect("LANES keys");
            let th = if c < 2 { t[c][k] } else { self.threshold(kp, side, c, [side, r, 0][k]) };
            for i in 0..LANES {
                acc[i] |= (v[i] > th[i]) as i32;
            }
        }
        acc.iter().fold(0, |a, &b| a | b) != 0
    }

    /// The thresholds of chunk `c` of a row whose first `earlier` lanes lie
    /// before p (for squares wider than two chunks, radius 8 and up).
    #[inline(always)]
    fn threshold(&self, kp: i32, side: usize, c: usize, earlier: usize) -> [i32; LANES] {
        let mut t = [kp; LANES];
        for (i, t) in t.iter_mut().enumerate() {
            let lane = c * LANES + i;
            if lane >= side {
                *t = i32::MAX;
            } else if lane < earlier {
                *t = kp - 1;
            }
        }
        t
    }
}

/// [`corner_nms`] for candidates in any order, with duplicate positions or NaN responses.
fn corner_nms_sparse(cands: &[[u32; 2]], resp: &[f32], r: u32) -> Vec<usize> {
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

    /// The definition: a candidate survives iff no other within its (2r+1)^2 square beats it.
    fn naive(cands: &[[u32; 2]], resp: &[f32], r: u32) -> Vec<usize> {
        (0..cands.len())
            .filter(|&i| {
                !(0..cands.len()).any(|j| {
                    j != i
                        && cands[j][0].abs_diff(cands[i][0]) <= r
                        && cands[j][1].abs_diff(cands[i][1]) <= r
                        && beats(resp[j], cands[j], resp[i], cands[i])
                })
            })
            .collect()
    }

    proptest::proptest! {
        #[test]
        fn matches_naive(pts in proptest::collection::vec((0u32..24, 0u32..24), 0..80), r in 0u32..5, seed in 0u64..1000) {
            // any order, duplicate positions allowed
            let cands: Vec<[u32; 2]> = pts.iter().map(|&(x, y)| [x, y]).collect();
            // few distinct responses to force ties
            let resp: Vec<f32> = (0..cands.len()).map(|i| ((i as u64 * 7 + seed) % 5) as f32).collect();
            let got = corner_nms(24, 24, &cands, &resp, r);
            proptest::prop_assert_eq!(got, naive(&cands, &resp, r));
        }

        #[test]
        fn matches_naive_in_raster_order(pts in proptest::collection::vec((0u32..70, 0u32..40), 0..300), r in 0u32..10,
                                         seed in 0u64..1000) {
            // the fast case: raster order as L-FAST gives it, duplicates allowed;
            // responses with ties, -0.0 against 0.0, and NaN (which never beats nor loses)
            // (distinct positions and no NaN, 2 cases in 3: the dense path)
            let mut cands: Vec<[u32; 2]> = pts.iter().map(|&(x, y)| [x, y]).collect();
            cands.sort_unstable_by_key(|c| (c[1], c[0]));
            let dense = seed % 3 != 0;
            if dense {
                cands.dedup();
            }
            let vals = [0.0, -0.0, 1.0, 2.0, -1.0, f32::INFINITY, f32::NEG_INFINITY, f32::NAN];
            let nv = if dense { 7 } else { 8 };
            let resp: Vec<f32> = (0..cands.len()).map(|i| vals[((i as u64 * 13 + seed) % nv) as usize]).collect();
            let got = corner_nms(70, 40, &cands, &resp, r);
            proptest::prop_assert_eq!(got, naive(&cands, &resp, r));
        }

        #[test]
        fn rejecting_edges_first_keeps_the_positive_survivors(pts in proptest::collection::vec((0u32..70, 0u32..40), 0..300),
                                                              r in 0u32..8, seed in 0u64..1000) {
            // reject_edges (drop responses <= 0 and NaN, then NMS) == NMS on every
            // candidate, then keep the positive survivors; raster order or not
            let mut cands: Vec<[u32; 2]> = pts.iter().map(|&(x, y)| [x, y]).collect();
            if seed % 2 == 0 {
                cands.sort_unstable_by_key(|c| (c[1], c[0]));
                cands.dedup();
            }
            let vals = [0.0, -0.0, 1.0, 2.0, -1.0, 3.5e-7, -2.0e-9, f32::INFINITY, f32::NEG_INFINITY, f32::NAN];
            let resp: Vec<f32> = (0..cands.len()).map(|i| vals[((i as u64 * 13 + seed) % 10) as usize]).collect();
            let want: Vec<usize> = naive(&cands, &resp, r).into_iter().filter(|&i| resp[i] > 0.0).collect();
            proptest::prop_assert_eq!(survivors(&cands, &resp, r, true), want);
            proptest::prop_assert_eq!(survivors(&cands, &resp, r, false), naive(&cands, &resp, r));
        }
    }
}
