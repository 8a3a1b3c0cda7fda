//! Brute-force Hamming matcher for 256-bit descriptors, with Lowe's ratio
//! test and a cross-check. Mirrors shaders/matcher.wgsl (src/gpu/matcher.rs),
//! which gives identical results.
//!
//! Definitions (the GPU follows them to the letter):
//! - **nearest** of a query: the train descriptor at the smallest Hamming
//!   distance `d1`; among equal distances the **lowest train index** wins.
//!   `d2` is the second smallest distance over all train descriptors (the
//!   multiset minimum without the winner), so `d2 == d1` when the best
//!   distance is tied; `d2` is [`NO_DISTANCE`] with a single train descriptor.
//! - **ratio test**: with `ratio = r`, quantised to `q = floor(r * 65536)`,
//!   a match is kept when `d1 * 65536 < q * d2` (exact integers: Lowe's
//!   `d1 < r * d2` without float rounding on either device). It passes when
//!   `d2` is absent.
//! - **max distance**: kept when `d1 <= max_distance`.
//! - **cross-check**: the nearest query of the chosen train descriptor (lowest
//!   query index on ties) must be the query itself.
//!
//! Matches come out ordered by query index, at most one per query.

use crate::error::Result;
use crate::keypoint::Descriptor;
use rayon::prelude::*;

pub use crate::spec::matching::{Match, MatchOptions, NO_DISTANCE, NO_INDEX, RATIO_ONE};

/// The nearest train descriptor of one query.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Nearest {
    /// Lowest index at the smallest distance, or [`NO_INDEX`].
    pub best: u32,
    /// Smallest distance, or [`NO_DISTANCE`].
    pub d1: u32,
    /// Second smallest distance (equal to `d1` on a tie), or [`NO_DISTANCE`].
    pub d2: u32,
}

/// Descriptors as four 64-bit words, so one distance is four popcounts.
fn words(d: &[Descriptor]) -> Vec<[u64; 4]> {
    d.iter()
        .map(|b| std::array::from_fn(|k| u64::from_le_bytes(b[8 * k..8 * k + 8].try_into().unwrap_or([0; 8]))))
        .collect()
}

#[inline]
fn dist(a: &[u64; 4], b: &[u64; 4]) -> u32 {
    (a[0] ^ b[0]).count_ones() + (a[1] ^ b[1]).count_ones() + (a[2] ^ b[2]).count_ones() + (a[3] ^ b[3]).count_ones()
}

/// The two-best scan in train order; strict `<` keeps the lowest index on ties.
fn scan(q: &[u64; 4], train: &[[u64; 4]]) -> Nearest {
    let (mut best, mut d1, mut d2) = (NO_INDEX, NO_DISTANCE, NO_DISTANCE);
    for (j, t) in train.iter().enumerate() {
        let d = dist(q, t);
        if d < d1 {
            d2 = d1;
            d1 = d;
            best = j as u32;
        } else if d < d2 {
            d2 = d;
        }
    }
    Nearest { best, d1, d2 }
}

/// For every query, its nearest train descriptor and the two smallest distances.
pub fn nearest(query: &[Descriptor], train: &[Descriptor]) -> Vec<Nearest> {
    let (q, t) = (words(query), words(train));
    q.par_iter().with_min_len(64).map(|a| scan(a, &t)).collect()
}

/// Whether the ratio and distance tests keep a query's nearest neighbour
/// (the cross-check aside). `ratio_q16` as [`MatchOptions::ratio_q16`].
pub fn passes(n: &Nearest, ratio_q16: u32, max_distance: u32) -> bool {
    if n.best == NO_INDEX || n.d1 > max_distance {
        return false;
    }
    // d1, d2 <= 256 and q <= 2^16: both products fit in u32.
    ratio_q16 == 0 || n.d2 == NO_DISTANCE || n.d1 * RATIO_ONE < ratio_q16 * n.d2
}

/// Matches `query` against `train` (see the module documentation for the
/// exact rules). Errors only on invalid options.
///
/// ```
/// use lfast::cpu::matcher::{match_descriptors, Match, MatchOptions};
/// let a = [[0u8; 32], [0xff; 32]];
/// let b = [[0xff; 32], [0x01; 32]];
/// let m = match_descriptors(&a, &b, &MatchOptions { cross_check: true, ratio: None, max_distance: 256 }).unwrap();
/// // [0x01; 32] has one bit per byte set: 32 from zero, 224 from 0xff
/// assert_eq!(m, vec![Match { query: 0, train: 1, distance: 32 }, Match { query: 1, train: 0, distance: 0 }]);
/// ```
pub fn match_descriptors(query: &[Descriptor], train: &[Descriptor], opts: &MatchOptions) -> Result<Vec<Match>> {
    let q16 = opts.ratio_q16()?;
    let (q, t) = (words(query), words(train));
    let fwd: Vec<Nearest> = q.par_iter().with_min_len(64).map(|a| scan(a, &t)).collect();
    let back: Vec<u32> =
        if opts.cross_check { t.par_iter().with_min_len(64).map(|b| scan(b, &q).best).collect() } else { Vec::new() };
    Ok(fwd
        .iter()
        .enumerate()
        .filter(|(i, n)| passes(n, q16, opts.max_distance) && (!opts.cross_check || back[n.best as usize] == *i as u32))
        .map(|(i, n)| Match { query: i as u32, train: n.best, distance: n.d1 })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn d(bits: &[usize]) -> Descriptor {
        let mut x = [0u8; 32];
        for &b in bits {
            x[b / 8] |= 1 << (b % 8);
        }
        x
    }

    #[test]
    fn ties_take_the_lowest_index_and_d2_equals_d1() {
        let train = [d(&[1, 2]), d(&[0]), d(&[3]), d(&[0, 1, 2, 3])];
        // query {} : distances 2, 1, 1, 4 -> best 1 (lowest of the tie), d2 = 1
        let n = nearest(&[d(&[])], &train);
        assert_eq!(n, vec![Nearest { best: 1, d1: 1, d2: 1 }]);
        // the tie fails any ratio test (d1 < r * d1 is false for r <= 1)
        assert!(!passes(&n[0], RATIO_ONE, 256));
        assert!(passes(&n[0], 0, 256));
    }

    #[test]
    fn single_train_has_no_second_distance() {
        let n = nearest(&[d(&[5])], &[d(&[5, 6, 7])]);
        assert_eq!(n, vec![Nearest { best: 0, d1: 2, d2: NO_DISTANCE }]);
        assert!(passes(&n[0], 1, 2));
        assert!(!passes(&n[0], 1, 1));
        assert_eq!(nearest(&[d(&[])], &[]), vec![Nearest { best: NO_INDEX, d1: NO_DISTANCE, d2: NO_DISTANCE }]);
    }

    #[test]
    fn ratio_is_strict_and_exact() {
        // d1 = 4, d2 = 5: kept at r = 0.81 (4 < 4.05), dropped at r = 0.8 (4 < 4.0 is false)
        let q = [d(&[])];
        let t = [d(&[0, 1, 2, 3]), d(&[10, 11, 12, 13, 14])];
        let o = |r| MatchOptions { cross_check: false, ratio: Some(r), max_distance: 256 };
        assert_eq!(match_descriptors(&q, &t, &o(0.81)).unwrap(), vec![Match { query: 0, train: 0, distance: 4 }]);
        assert!(match_descriptors(&q, &t, &o(0.8)).unwrap().is_empty());
        assert!(match_descriptors(&q, &t, &o(0.0)).is_err());
        assert!(match_descriptors(&q, &t, &o(f32::NAN)).is_err());
        assert!(match_descriptors(&q, &t, &o(1.5)).is_err());
    }

    #[test]
    fn cross_check_drops_one_sided_matches() {
        // both queries are nearest to train 0; train 0's nearest query is 1
        let q = [d(&[0, 1, 2]), d(&[0])];
        let t = [d(&[]), d(&[100, 101, 102, 103, 104, 105])];
        let o = MatchOptions { cross_check: true, ratio: None, max_distance: 256 };
        assert_eq!(match_descriptors(&q, &t, &o).unwrap(), vec![Match { query: 1, train: 0, distance: 1 }]);
        let o = MatchOptions { cross_check: false, ..o };
        assert_eq!(match_descriptors(&q, &t, &o).unwrap().len(), 2);
    }

    #[test]
    fn cross_check_ties_on_the_train_side_take_the_lowest_query() {
        // two identical queries: train 0's nearest query is 0, so query 1 loses
        let q = [d(&[3]), d(&[3])];
        let t = [d(&[3, 4])];
        let o = MatchOptions { cross_check: true, ratio: None, max_distance: 256 };
        assert_eq!(match_descriptors(&q, &t, &o).unwrap(), vec![Match { query: 0, train: 0, distance: 1 }]);
    }

    proptest::proptest! {
        #[test]
        fn matches_the_naive_definition(
            q in proptest::collection::vec(proptest::array::uniform32(0u8..4), 0..40),
            t in proptest::collection::vec(proptest::array::uniform32(0u8..4), 0..40),
            cross in proptest::bool::ANY, ratio in proptest::option::of(0.5f32..1.0), maxd in 0u32..300,
        ) {
            let opts = MatchOptions { cross_check: cross, ratio, max_distance: maxd };
            let q16 = opts.ratio_q16().unwrap();
            let h = crate::hamming;
            let mut want = Vec::new();
            for (i, a) in q.iter().enumerate() {
                let Some(j) = (0..t.len()).min_by_key(|&j| (h(a, &t[j]), j)) else { continue };
                let d1 = h(a, &t[j]);
                let d2 = (0..t.len()).filter(|&k| k != j).map(|k| h(a, &t[k])).min();
                let back = (0..q.len()).min_by_key(|&k| (h(&q[k], &t[j]), k)).unwrap();
                let ratio_ok = match d2 { Some(d2) if q16 > 0 => (d1 as u64) * 65536 < (q16 as u64) * (d2 as u64), _ => true };
                if ratio_ok && d1 <= maxd && (!cross || back == i) {
                    want.push(Match { query: i as u32, train: j as u32, distance: d1 });
                }
            }
            proptest::prop_assert_eq!(match_descriptors(&q, &t, &opts).unwrap(), want);
        }
    }
}
