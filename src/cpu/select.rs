//! SPEC 9: the `n_features` cap — per-level quotas proportional to level area,
//! optional ORB-SLAM quadtree distribution — and the deterministic output order.
//! Mirrors shaders/select.wgsl.

use std::cmp::Ordering;

/// A corner that survived corner NMS, in level coordinates.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Corner {
    /// Pyramid level.
    pub level: u32,
    /// Column at that level.
    pub x: u32,
    /// Row at that level.
    pub y: u32,
    /// Harris response.
    pub response: f32,
    /// Sub-pixel offset of the snapped corner, in 1/[`SUBPIXEL`](crate::spec::SUBPIXEL)
    /// of a level pixel, each in `-7..=7` ([`crate::cpu::snap`]); `[0, 0]` without snap.
    pub sub: [i8; 2],
    /// A FAST corner of the fill (`Config::fill_fast_ini`), not an L-FAST one.
    pub fill: bool,
}

/// SPEC 9's output order: response descending, then level, y, x ascending.
pub fn order(a: &Corner, b: &Corner) -> Ordering {
    b.response.total_cmp(&a.response).then(a.level.cmp(&b.level)).then(a.y.cmp(&b.y)).then(a.x.cmp(&b.x))
}

pub use crate::spec::quotas::level_quotas;

/// [`order`] as one integer: response (as `total_cmp` orders it,
/// descending), level, y, x packed in a u128, ascending.
#[inline]
fn order_key(c: &Corner) -> u128 {
    let b = c.response.to_bits() as i32;
    // total_cmp's order as a signed integer, then unsigned and descending
    let t = b ^ ((((b >> 31) as u32) >> 1) as i32);
    let r = !((t as u32) ^ 0x8000_0000);
    (r as u128) << 96 | (c.level as u128) << 64 | (c.y as u128) << 32 | c.x as u128
}

/// Sorts `v` as `v.sort_by(order)` does (stably), by `order_key`, the
/// index breaking ties: a key compare is one instruction pair where `order`
/// chains a float compare and three more.
pub fn sort_by_order(v: &mut [Corner]) {
    if v.len() < 2 {
        return;
    }
    let mut keyed: Vec<(u128, u32)> = v.iter().enumerate().map(|(i, c)| (order_key(c), i as u32)).collect();
    keyed.sort_unstable();
    let sorted: Vec<Corner> = keyed.iter().map(|&(_, i)| v[i as usize]).collect();
    v.copy_from_slice(&sorted);
}

/// The lists concatenated and sorted as `sort_by(order)` would sort them
/// (stably): each list sorted on its own, then merged pairwise, halves in
/// parallel, the earlier list first where keys tie. The sort of all
/// corners had been serial work between the parallel detection and
/// description (~2 ms of a 3840x2160 frame's 20,000 corners).
pub fn merge_in_order(lists: Vec<Vec<Corner>>) -> Vec<Corner> {
    use rayon::prelude::*;
    let mut keyed: Vec<Vec<(u128, Corner)>> = lists
        .into_par_iter()
        .map(|mut v| {
            sort_by_order(&mut v);
            v.into_iter().map(|c| (order_key(&c), c)).collect()
        })
        .collect();
    merge_all(&mut keyed).into_iter().map(|(_, c)| c).collect()
}

/// [`merge_in_order`]'s merge of sorted keyed lists, earlier lists first on equal keys.
fn merge_all(lists: &mut [Vec<(u128, Corner)>]) -> Vec<(u128, Corner)> {
    match lists.len() {
        0 => Vec::new(),
        1 => std::mem::take(&mut lists[0]),
        n => {
            let (a, b) = lists.split_at_mut(n / 2);
            let (a, b) = rayon::join(|| merge_all(a), || merge_all(b));
            let mut out = Vec::with_capacity(a.len() + b.len());
            let (mut i, mut j) = (0, 0);
            while i < a.len() && j < b.len() {
                // b's first only when strictly smaller: ties keep a's (earlier) first
                if b[j].0 < a[i].0 {
                    out.push(b[j]);
                    j += 1;
                } else {
                    out.push(a[i]);
                    i += 1;
                }
            }
            out.extend_from_slice(&a[i..]);
            out.extend_from_slice(&b[j..]);
            out
        }
    }
}

/// ORB-SLAM's `DistributeOctTree` on one level: split the region into nodes
/// (initially `round(W/H)` vertical strips), split every node holding more
/// than one corner into four until there are at least `n` nodes or nothing
/// can split, then keep the best corner of each node. Splits in the last
/// round go to the fullest nodes first (ties by creation order).
pub fn distribute_quadtree(corners: &[Corner], width: u32, height: u32, n: usize) -> Vec<Corner> {
    if corners.len() <= n || n == 0 {
        let mut v = if n == 0 { Vec::new() } else { corners.to_vec() };
        v.sort_by(order);
        return v;
    }
    #[derive(Clone)]
    struct Node {
        x0: u32,
        y0: u32,
        x1: u32,
        y1: u32,
        pts: Vec<usize>,
    }
    impl Node {
        fn can_split(&self) -> bool {
            self.pts.len() > 1 && (self.x1 - self.x0 > 1 || self.y1 - self.y0 > 1)
        }
        fn split(&self, c: &[Corner]) -> Vec<Node> {
            let (mx, my) = ((self.x0 + self.x1).div_ceil(2), (self.y0 + self.y1).div_ceil(2));
            let mut kids = vec![
                Node { x0: self.x0, y0: self.y0, x1: mx, y1: my, pts: vec![] },
                Node { x0: mx, y0: self.y0, x1: self.x1, y1: my, pts: vec![] },
                Node { x0: self.x0, y0: my, x1: mx, y1: self.y1, pts: vec![] },
                Node { x0: mx, y0: my, x1: self.x1, y1: self.y1, pts: vec![] },
            ];
            for &i in &self.pts {
                let k = (c[i].x >= mx) as usize + 2 * (c[i].y >= my) as usize;
                kids[k].pts.push(i);
            }
            kids.retain(|k| !k.pts.is_empty());
            kids
        }
    }
    let n_ini = ((width as f64 / height as f64).round() as u32).clamp(1, width);
    let mut nodes: Vec<Node> = (0..n_ini)
        .map(|i| Node { x0: i * width / n_ini, x1: (i + 1) * width / n_ini, y0: 0, y1: height, pts: vec![] })
        .collect();
    for (i, c) in corners.iter().enumerate() {
        let k = ((c.x as u64 * n_ini as u64) / width as u64) as usize;
        nodes[k.min(n_ini as usize - 1)].pts.push(i);
    }
    nodes.retain(|nd| !nd.pts.is_empty());
    loop {
        let splittable = nodes.iter().filter(|nd| nd.can_split()).count();
        if nodes.len() >= n || splittable == 0 {
            break;
        }
        if nodes.len() + 3 * splittable < n {
            nodes =
                nodes.iter().flat_map(|nd| if nd.can_split() { nd.split(corners) } else { vec![nd.clone()] }).collect();
            continue;
        }
        // Last round: split the fullest nodes one at a time until there are enough.
        let mut idx: Vec<usize> = (0..nodes.len()).filter(|&i| nodes[i].can_split()).collect();
        idx.sort_by(|&a, &b| nodes[b].pts.len().cmp(&nodes[a].pts.len()).then(a.cmp(&b)));
        let mut count = nodes.len();
        let mut replace: Vec<Option<Vec<Node>>> = vec![None; nodes.len()];
        for i in idx {
            if count >= n {
                break;
            }
            let kids = nodes[i].split(corners);
            count += kids.len() - 1;
            replace[i] = Some(kids);
        }
        nodes = nodes.into_iter().zip(replace).flat_map(|(nd, r)| r.unwrap_or_else(|| vec![nd])).collect();
        break;
    }
    let mut best: Vec<Corner> =
        nodes.iter().map(|nd| nd.pts.iter().map(|&i| corners[i]).min_by(order).expect("nodes are non-empty")).collect();
    best.sort_by(order);
    best.truncate(n);
    best
}

/// Applies the cap to the corners of all levels and returns them in SPEC 9
/// order. Without a cap (`n == 0`) everything is kept. With one, each level
/// keeps up to its quota (strongest first, or spread by the quadtree); quota
/// left unused by a level is filled from the best remaining corners of any level.
///
/// Fill corners ([`Corner::fill`]) only take what the L-FAST corners leave:
/// the L-FAST corners are selected first, exactly as without them (so the
/// result without fill corners is a subset of the result with them); then,
/// while fewer than `n` are taken, each level short of its quota takes fill
/// corners up to the shortfall (strongest, or spread by the quadtree over the
/// fill corners), the best of those (SPEC 9 order) up to the slots left, and
/// any slots still left go to the best remaining fill corners of any level.
pub fn select(per_level: Vec<Vec<Corner>>, sizes: &[(u32, u32)], n: u32, distribution: bool) -> Vec<Corner> {
    if n == 0 {
        return merge_in_order(per_level);
    }
    let quotas = level_quotas(n, sizes);
    let (mut taken, mut rest) = (Vec::new(), Vec::new());
    let mut fills = Vec::with_capacity(per_level.len());
    for (l, cs) in per_level.into_iter().enumerate() {
        let q = quotas.get(l).copied().unwrap_or(0) as usize;
        let (mut main, fill): (Vec<Corner>, Vec<Corner>) = cs.into_iter().partition(|c| !c.fill);
        take_up_to(&mut main, q, sizes[l], distribution, &mut taken, &mut rest);
        fills.push(fill);
    }
    let spare = (n as usize).saturating_sub(taken.len());
    rest.sort_by(order);
    taken.extend(rest.into_iter().take(spare));
    let slots = (n as usize).saturating_sub(taken.len());
    if slots > 0 && fills.iter().any(|f| !f.is_empty()) {
        let mut per_level_taken = vec![0usize; fills.len()];
        for c in &taken {
            per_level_taken[c.level as usize] += 1;
        }
        let (mut chosen, mut left) = (Vec::new(), Vec::new());
        for (l, mut f) in fills.into_iter().enumerate() {
            let short = (quotas[l] as usize).saturating_sub(per_level_taken[l]);
            take_up_to(&mut f, short, sizes[l], distribution, &mut chosen, &mut left);
        }
        chosen.sort_by(order);
        left.extend(chosen.drain(chosen.len().min(slots)..));
        left.sort_by(order);
        let more = slots - chosen.len();
        taken.extend(chosen);
        taken.extend(left.into_iter().take(more));
    }
    sort_by_order(&mut taken);
    taken
}

/// Moves up to `q` of `cs` (one level's) into `taken`, the strongest or,
/// with `distribution`, the quadtree's spread over the level of size `wh`;
/// the others go to `rest`.
fn take_up_to(
    cs: &mut Vec<Corner>,
    q: usize,
    (w, h): (u32, u32),
    distribution: bool,
    taken: &mut Vec<Corner>,
    rest: &mut Vec<Corner>,
) {
    cs.sort_by(order);
    if cs.len() <= q {
        taken.append(cs);
    } else if distribution {
        let chosen = distribute_quadtree(cs, w, h, q);
        let at: std::collections::HashSet<(u32, u32)> = chosen.iter().map(|k| (k.x, k.y)).collect();
        rest.extend(cs.drain(..).filter(|c| !at.contains(&(c.x, c.y))));
        taken.extend(chosen);
    } else {
        rest.extend(cs.split_off(q));
        taken.append(cs);
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn sort_by_order_equals_the_stable_sort() {
        let mut rng = crate::rng::SplitMix64::new(7);
        let specials = [0.0f32, -0.0, 1.0, -1.0, f32::NAN, -f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 1e-30];
        for n in [0usize, 1, 2, 3, 17, 200, 1500] {
            let v: Vec<Corner> = (0..n)
                .map(|_| {
                    let r = rng.next_u64();
                    Corner {
                        level: (r % 3) as u32,
                        x: (r >> 8) as u32 % 5,
                        y: (r >> 16) as u32 % 4,
                        response: if r >> 60 < 6 {
                            specials[(r >> 24) as usize % specials.len()]
                        } else {
                            ((r >> 32) % 7) as f32 * 0.5
                        },
                        sub: [(r >> 40) as i8 % 8, 0],
                        fill: r >> 63 == 1,
                    }
                })
                .collect();
            let mut want = v.clone();
            want.sort_by(order);
            let mut got = v.clone();
            sort_by_order(&mut got);
            // compared bit for bit (NaN responses included), sub and fill too
            let bits = |v: &[Corner]| {
                v.iter().map(|c| (c.level, c.x, c.y, c.response.to_bits(), c.sub, c.fill)).collect::<Vec<_>>()
            };
            assert_eq!(bits(&got), bits(&want), "n {n}");
            // the same corners cut into lists (by level, and at random), merged
            for by_level in [true, false] {
                let mut lists = vec![Vec::new(); 4];
                for (i, c) in v.iter().enumerate() {
                    lists[if by_level { c.level as usize } else { i * 7 % 4 }].push(*c);
                }
                let concat: Vec<Corner> = lists.concat();
                let mut want = concat.clone();
                want.sort_by(order);
                assert_eq!(bits(&merge_in_order(lists)), bits(&want), "n {n}, lists by level {by_level}");
            }
        }
    }

    use super::*;

    fn c(level: u32, x: u32, y: u32, r: f32) -> Corner {
        Corner { level, x, y, response: r, sub: [0, 0], fill: false }
    }

    /// A fill corner.
    fn f(level: u32, x: u32, y: u32, r: f32) -> Corner {
        Corner { fill: true, ..c(level, x, y, r) }
    }

    #[test]
    fn fill_corners_take_only_what_l_fast_leaves() {
        let sizes = [(100, 100)];
        // 3 weak L-FAST corners and 10 strong fill corners, cap 5: all 3 L-FAST, then the 2 strongest fills
        let mut cs: Vec<Corner> = (0..3).map(|i| c(0, 10 * i, 5, 1.0 + i as f32)).collect();
        cs.extend((0..10).map(|i| f(0, 10 * i, 50, 100.0 + i as f32)));
        let out = select(vec![cs.clone()], &sizes, 5, false);
        assert_eq!(out.iter().filter(|k| !k.fill).count(), 3, "{out:?}");
        assert_eq!(out.iter().filter(|k| k.fill).map(|k| k.response).collect::<Vec<_>>(), [109.0, 108.0]);
        // output in SPEC 9 order whatever the kind
        assert!(out.windows(2).all(|w| order(&w[0], &w[1]).is_le()));
        // with the quadtree too
        let spread = select(vec![cs.clone()], &sizes, 5, true);
        assert_eq!((spread.len(), spread.iter().filter(|k| !k.fill).count()), (5, 3), "{spread:?}");
        // enough L-FAST corners: no fill corner at all
        let many: Vec<Corner> = (0..8).map(|i| c(0, 10 * i, 5, 1.0)).chain((0..4).map(|i| f(0, i, 90, 50.0))).collect();
        assert!(select(vec![many], &sizes, 5, false).iter().all(|k| !k.fill));
        // spare quota of an empty level: remaining L-FAST corners before fill corners
        let l0: Vec<Corner> = (0..4).map(|i| c(0, 10 * i, 5, 1.0)).chain([f(0, 0, 90, 50.0)]).collect();
        // (and the same with the fill corners on the other level)
        let out = select(vec![l0[..4].to_vec(), vec![f(1, 5, 5, 50.0)]], &[(100, 100), (100, 100)], 4, false);
        assert!(out.len() == 4 && out.iter().all(|k| !k.fill), "{out:?}");
        // short overall: level 1's shortfall is filled first, then level 0's best fill corner
        let out = select(
            vec![vec![c(0, 1, 1, 1.0), f(0, 2, 2, 9.0)], vec![f(1, 3, 3, 2.0), f(1, 4, 4, 3.0)]],
            &[(100, 100), (100, 100)],
            4,
            false,
        );
        assert_eq!(out.iter().map(|k| (k.level, k.x)).collect::<Vec<_>>(), [(0, 2), (1, 4), (1, 3), (0, 1)]);
        let out = select(vec![l0, vec![]], &[(100, 100), (100, 100)], 4, false);
        assert_eq!(level_quotas(4, &[(100, 100), (100, 100)]), [2, 2]);
        assert!(out.len() == 4 && out.iter().all(|k| !k.fill), "{out:?}");
    }

    #[test]
    fn order_is_total_and_deterministic() {
        let mut v = vec![c(1, 5, 5, 1.0), c(0, 9, 2, 1.0), c(0, 3, 2, 1.0), c(0, 0, 0, 2.0)];
        v.sort_by(order);
        assert_eq!(v, vec![c(0, 0, 0, 2.0), c(0, 3, 2, 1.0), c(0, 9, 2, 1.0), c(1, 5, 5, 1.0)]);
    }

    #[test]
    fn quotas_sum_to_n() {
        let sizes = crate::Config::default().level_sizes(1241, 376);
        for n in [1, 7, 500, 1000, 2000] {
            let q = level_quotas(n, &sizes);
            assert_eq!(q.iter().sum::<u32>(), n);
            assert!(q.windows(2).all(|w| w[0] >= w[1]), "{q:?}");
        }
    }

    #[test]
    fn cap_fills_spare_quota() {
        // level 1 has no corners; its quota goes to level 0's next best
        let l0: Vec<Corner> = (0..10).map(|i| c(0, i, 0, i as f32)).collect();
        let out = select(vec![l0, vec![]], &[(100, 100), (50, 50)], 5, false);
        assert_eq!(out.iter().map(|c| c.x).collect::<Vec<_>>(), vec![9, 8, 7, 6, 5]);
    }

    #[test]
    fn quadtree_spreads() {
        // 50 strong corners packed in one corner of the image, 4 weak ones spread out
        let mut cs: Vec<Corner> = (0..50).map(|i| c(0, i % 10, i / 10, 100.0 + i as f32)).collect();
        cs.extend([c(0, 90, 10, 1.0), c(0, 10, 90, 1.0), c(0, 90, 90, 1.0), c(0, 50, 50, 1.0)]);
        let top = select(vec![cs.clone()], &[(100, 100)], 5, false);
        assert!(top.iter().all(|c| c.response >= 100.0));
        let spread = select(vec![cs], &[(100, 100)], 5, true);
        assert_eq!(spread.len(), 5);
        assert!(spread.iter().filter(|c| c.response == 1.0).count() >= 3, "{spread:?}");
    }
}
