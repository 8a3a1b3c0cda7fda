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
}

/// SPEC 9's output order: response descending, then level, y, x ascending.
pub fn order(a: &Corner, b: &Corner) -> Ordering {
    b.response.total_cmp(&a.response).then(a.level.cmp(&b.level)).then(a.y.cmp(&b.y)).then(a.x.cmp(&b.x))
}

pub use crate::spec::quotas::level_quotas;

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
pub fn select(per_level: Vec<Vec<Corner>>, sizes: &[(u32, u32)], n: u32, distribution: bool) -> Vec<Corner> {
    if n == 0 {
        let mut all: Vec<Corner> = per_level.into_iter().flatten().collect();
        all.sort_by(order);
        return all;
    }
    let quotas = level_quotas(n, sizes);
    let mut taken = Vec::new();
    let mut rest = Vec::new();
    for (l, mut cs) in per_level.into_iter().enumerate() {
        let q = quotas.get(l).copied().unwrap_or(0) as usize;
        cs.sort_by(order);
        if cs.len() <= q {
            taken.extend(cs);
        } else if distribution {
            let (w, h) = sizes[l];
            let chosen = distribute_quadtree(&cs, w, h, q);
            let at: std::collections::HashSet<(u32, u32)> = chosen.iter().map(|k| (k.x, k.y)).collect();
            rest.extend(cs.into_iter().filter(|c| !at.contains(&(c.x, c.y))));
            taken.extend(chosen);
        } else {
            rest.extend(cs.split_off(q));
            taken.extend(cs);
        }
    }
    let spare = (n as usize).saturating_sub(taken.len());
    rest.sort_by(order);
    taken.extend(rest.into_iter().take(spare));
    taken.sort_by(order);
    taken
}

#[cfg(test)]
mod tests {
    use super::*;

    fn c(level: u32, x: u32, y: u32, r: f32) -> Corner {
        Corner { level, x, y, response: r, sub: [0, 0] }
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
