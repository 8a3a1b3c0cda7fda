//! SPEC 7 rule 3: hysteresis. Every STRONG pixel and every WEAK pixel joined to
//! a STRONG one through 8-connected WEAK pixels becomes an edge (255).
//! Mirrors shaders/hysteresis.wgsl, which labels the 8-connected components of
//! WEAK/STRONG pixels with a lock-free union-find and keeps the components that
//! hold a STRONG pixel; here the WEAK pixels next to a STRONG one start flood
//! fills over their WEAK components, which gives the same set.

use super::classify::{EDGE, STRONG, WEAK};
use super::simd::for_each_eq;
use crate::image::Plane;

/// The edge map E (255 = edge, 0 = background) from the classes after
/// [`rules`](super::rules::rules) (only STRONG, WEAK and NONE remain).
///
/// ```
/// use lfast::Plane;
/// use lfast::cpu::{classify::*, hysteresis::hysteresis};
/// let c = Plane::from_vec(5, 1, vec![STRONG, WEAK, WEAK, NONE, WEAK]).unwrap();
/// assert_eq!(hysteresis(&c).data, vec![255, 255, 255, 0, 0]);
/// ```
pub fn hysteresis(classes: &Plane<u8>) -> Plane<u8> {
    let weak: Vec<usize> = classes.data.iter().enumerate().filter(|&(_, &c)| c == WEAK).map(|(i, _)| i).collect();
    let mut out = classes.clone();
    flood_in_place(&mut out, &weak);
    out
}

/// Hysteresis in place: `e` holds the classes after the rules (STRONG, WEAK,
/// NONE) and `weak` lists its WEAK pixels (linear indices, any order). Each
/// WEAK pixel next to a STRONG or already promoted one starts a flood over its
/// WEAK component; then STRONG and promoted pixels become EDGE and the rest 0.
/// Flooding from every STRONG pixel gives the same set; this visits the
/// (fewer) WEAK pixels instead, and needs no second plane.
pub fn flood_in_place(e: &mut Plane<u8>, weak: &[usize]) {
    let w = e.width as usize;
    if w == 0 {
        return;
    }
    flood(&mut e.data, w, weak.iter().map(|&i| ((i % w) as u32, (i / w) as u32)));
    for v in e.data.iter_mut() {
        *v = if *v == EDGE || *v == STRONG { EDGE } else { 0 };
    }
}

/// [`flood_in_place`] for a plane whose STRONG pixels are already EDGE (the
/// fused path's rules write them so), cut into bands of `band_rows` rows:
/// `weak[k]` lists the WEAK pixels (x, y) of band k. Each band is flooded on
/// its own thread with the other bands as walls; then one serial flood starts
/// from the WEAK pixels on the bands' first and last rows, which is where a
/// component that crosses bands continues (each band-local piece of a WEAK
/// component is promoted whole or not at all, so a piece left WEAK that should
/// be promoted touches a promoted pixel across a band edge). The WEAK pixels
/// left after that are cleared through the lists, not by a pass over the plane.
/// The fused path runs the two steps itself (the band floods inside its band
/// tasks); this composition is what the tests check against the naive sweep.
#[cfg(test)]
fn flood_edges_banded(e: &mut Plane<u8>, weak: &[Vec<(u32, u32)>], band_rows: usize) {
    use rayon::prelude::*;
    debug_assert!(!e.data.contains(&STRONG));
    let w = e.width as usize;
    if w == 0 || e.height == 0 {
        return;
    }
    e.data.par_chunks_mut(band_rows * w).zip(weak).enumerate().for_each(|(b, (band, weak))| {
        flood_band(band, w, (b * band_rows) as u32, weak);
    });
    flood_seams(e, weak, band_rows);
}

/// The first step of [`flood_edges_banded`] for one band: `band` holds rows
/// `y0..` of the plane (`w` wide), `weak` its WEAK pixels (x, y), y counted in the plane.
pub(crate) fn flood_band(band: &mut [u8], w: usize, y0: u32, weak: &[(u32, u32)]) {
    flood(band, w, weak.iter().map(|&(x, y)| (x, y - y0)));
}

/// The last step of [`flood_edges_banded`], after [`flood_band`] on every band.
pub(crate) fn flood_seams(e: &mut Plane<u8>, weak: &[Vec<(u32, u32)>], band_rows: usize) {
    let (w, h) = (e.width as usize, e.height as usize);
    if w == 0 {
        return;
    }
    let mut seams = Vec::new();
    for y0 in (band_rows..h).step_by(band_rows) {
        for y in [y0 - 1, y0] {
            for_each_eq(&e.data[y * w..(y + 1) * w], WEAK, |x| seams.push((x as u32, y as u32)));
        }
    }
    flood(&mut e.data, w, seams.into_iter());
    for &(x, y) in weak.iter().flatten() {
        let v = &mut e.data[y as usize * w + x as usize];
        if *v == WEAK {
            *v = 0;
        }
    }
}

/// The floods of [`flood_in_place`] over the rows in `data` (`w` wide):
/// promotes to EDGE every WEAK pixel joined to a STRONG or EDGE one through
/// WEAK pixels, visiting the WEAK pixels at `weak` ((x, y), y counted from
/// `data`'s first row) and the components they reach within `data`.
fn flood(data: &mut [u8], w: usize, weak: impl Iterator<Item = (u32, u32)>) {
    let h = data.len() / w;
    let data = &mut data[..w * h];
    let mut stack: Vec<(usize, usize)> = Vec::new();
    for (x, y) in weak {
        let (x, y) = (x as usize, y as usize);
        let i = y * w + x;
        if data[i] != WEAK {
            continue; // promoted by an earlier flood
        }
        let mut joined = false;
        for_each_neighbour(x, y, w, h, |j, _, _| joined |= data[j] == STRONG || data[j] == EDGE);
        if !joined {
            continue;
        }
        data[i] = EDGE;
        stack.push((x, y));
        while let Some((x, y)) = stack.pop() {
            for_each_neighbour(x, y, w, h, |j, nx, ny| {
                if data[j] == WEAK {
                    data[j] = EDGE;
                    stack.push((nx, ny));
                }
            });
        }
    }
}

/// Calls `f(index, x, y)` for the 8-neighbours of (x, y) inside a `w` x `h`
/// plane: fixed offsets inside the plane (nearly every pixel), clipped loops
/// on its border.
#[inline(always)]
fn for_each_neighbour(x: usize, y: usize, w: usize, h: usize, mut f: impl FnMut(usize, usize, usize)) {
    if x > 0 && y > 0 && x + 1 < w && y + 1 < h {
        let i = y * w + x;
        f(i - w - 1, x - 1, y - 1);
        f(i - w, x, y - 1);
        f(i - w + 1, x + 1, y - 1);
        f(i - 1, x - 1, y);
        f(i + 1, x + 1, y);
        f(i + w - 1, x - 1, y + 1);
        f(i + w, x, y + 1);
        f(i + w + 1, x + 1, y + 1);
        return;
    }
    for ny in y.saturating_sub(1)..(y + 2).min(h) {
        for nx in x.saturating_sub(1)..(x + 2).min(w) {
            if (nx, ny) != (x, y) {
                f(ny * w + nx, nx, ny);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::classify::NONE;
    use super::*;

    /// Naive reference: sweep the whole image, promoting WEAK pixels next to an
    /// edge, until a sweep changes nothing (the GPU's scheme, unbounded).
    fn naive(classes: &Plane<u8>) -> Plane<u8> {
        let mut e: Vec<u8> = classes.data.iter().map(|&c| if c == STRONG { EDGE } else { 0 }).collect();
        let (w, h) = (classes.width as i32, classes.height as i32);
        loop {
            let mut changed = false;
            for y in 0..h {
                for x in 0..w {
                    let i = (y * w + x) as usize;
                    if e[i] != 0 || classes.data[i] != WEAK {
                        continue;
                    }
                    let near = (-1..=1).any(|dy| {
                        (-1..=1).any(|dx| {
                            let (nx, ny) = (x + dx, y + dy);
                            nx >= 0 && ny >= 0 && nx < w && ny < h && e[(ny * w + nx) as usize] == EDGE
                        })
                    });
                    if near {
                        e[i] = EDGE;
                        changed = true;
                    }
                }
            }
            if !changed {
                break;
            }
        }
        Plane::from_vec(classes.width, classes.height, e).unwrap()
    }

    /// [`flood_edges_banded`] on `classes` as the fused path hands them over:
    /// STRONG already EDGE, the WEAK pixels `weak` (linear indices, in this
    /// order) as (x, y) per band of `band_rows` rows.
    fn banded(classes: &Plane<u8>, weak: &[usize], band_rows: usize) -> Plane<u8> {
        let mut f = classes.clone();
        f.data.iter_mut().filter(|v| **v == STRONG).for_each(|v| *v = EDGE);
        let w = classes.width as usize;
        let mut bands = vec![Vec::new(); (classes.height as usize).div_ceil(band_rows)];
        for &i in weak {
            bands[i / w / band_rows].push(((i % w) as u32, (i / w) as u32));
        }
        flood_edges_banded(&mut f, &bands, band_rows);
        f
    }

    #[test]
    fn long_snake_converges() {
        // A serpentine WEAK path with the STRONG seed at its far end: the number
        // of sweeps a propagation scheme needs grows with the path length.
        let (w, h) = (9u32, 9u32);
        let mut c = Plane::<u8>::new(w, h);
        for y in (0..h).step_by(2) {
            for x in 0..w {
                c.data[(y * w + x) as usize] = WEAK;
            }
            let link_x = if (y / 2) % 2 == 0 { w - 1 } else { 0 };
            if y + 1 < h {
                c.data[((y + 1) * w + link_x) as usize] = WEAK;
            }
        }
        c.data[(8 * w) as usize] = STRONG;
        let e = hysteresis(&c);
        let n_path = c.data.iter().filter(|&&v| v != NONE).count();
        assert_eq!(e.data.iter().filter(|&&v| v == EDGE).count(), n_path);
        assert_eq!(e, naive(&c));
        // banded: the path crosses every band edge, the seed is in the last band
        let weak: Vec<usize> = (0..c.data.len()).filter(|&i| c.data[i] == WEAK).collect();
        for band_rows in [1, 2, 3, 4, 9] {
            assert_eq!(banded(&c, &weak, band_rows), e, "band_rows {band_rows}");
        }
    }

    #[test]
    fn weak_alone_is_dropped() {
        let c = Plane::from_vec(3, 3, vec![WEAK, 0, 0, 0, 0, 0, 0, 0, STRONG]).unwrap();
        assert_eq!(hysteresis(&c).data, vec![0, 0, 0, 0, 0, 0, 0, 0, 255]);
    }

    proptest::proptest! {
        #[test]
        fn matches_naive(w in 1u32..30, h in 1u32..30, seed in proptest::prelude::any::<u64>()) {
            let mut s = seed;
            let data: Vec<u8> = (0..w * h).map(|_| { s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                match (s >> 58) % 8 { 0 => STRONG, 1..=4 => WEAK, _ => NONE } }).collect();
            let c = Plane::from_vec(w, h, data).unwrap();
            proptest::prop_assert_eq!(hysteresis(&c), naive(&c));
            let mut e = c.clone();
            let mut weak: Vec<usize> = (0..c.data.len()).filter(|&i| c.data[i] == WEAK).collect();
            if seed % 2 == 1 {
                weak.reverse(); // any order
            }
            flood_in_place(&mut e, &weak);
            proptest::prop_assert_eq!(&e, &naive(&c));
            // the fused path's variant: STRONG already EDGE, weak as (x, y) per band
            proptest::prop_assert_eq!(banded(&c, &weak, 1 + (seed % 5) as usize), e);
        }
    }
}
