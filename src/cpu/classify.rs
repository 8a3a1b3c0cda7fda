//! SPEC 6: the double adaptive dual threshold (paper Algorithm 2), as exact
//! rational comparisons. Mirrors shaders/classify.wgsl.

use super::local_threshold::WindowGrid;
use crate::image::Plane;
use rayon::prelude::*;

/// Not an edge candidate.
pub const NONE: u8 = 0;
/// Below both weak thresholds' max, above their min.
pub const WEAK_WEAK: u8 = 1;
/// Weak edge.
pub const WEAK: u8 = 2;
/// Above one of the strong thresholds only.
pub const WEAK_STRONG: u8 = 3;
/// Strong edge.
pub const STRONG: u8 = 4;
/// Edge pixel in the final map E.
pub const EDGE: u8 = 255;

/// The class of an NMS survivor with magnitude `m` (SPEC 6). `t1` is Otsu's
/// `T1 = k + 1`; `v3` the pixel's window `V3`; `alpha_pct` alpha in hundredths.
///
/// ```
/// use lfast::cpu::classify::*;
/// // T1 = 40 and a window with V3 = 60 (TL1 = 27, TL2 = 13 at alpha 35)
/// assert_eq!(class_of(45, 40, 60, 35), STRONG);      // >= max(T1, TL1)
/// assert_eq!(class_of(30, 40, 60, 35), WEAK_STRONG); // >= min(T1, TL1)
/// assert_eq!(class_of(20, 40, 60, 35), WEAK);        // >= max(T2, TL2) = 20
/// assert_eq!(class_of(15, 40, 60, 35), WEAK_WEAK);   // >= min(T2, TL2) = 13
/// assert_eq!(class_of(12, 40, 60, 35), NONE);
/// ```
#[inline]
pub fn class_of(m: u32, t1: u32, v3: u32, alpha_pct: u32) -> u8 {
    let above_t1 = m >= t1;
    let above_t2 = 2 * m >= t1;
    let above_tl1 = m >= 255 || 300 * m >= (100 + alpha_pct) * v3;
    let above_tl2 = 300 * m >= (100 - alpha_pct) * v3;
    if above_t1 && above_tl1 {
        STRONG
    } else if above_t1 || above_tl1 {
        WEAK_STRONG
    } else if above_t2 && above_tl2 {
        WEAK
    } else if above_t2 || above_tl2 {
        WEAK_WEAK
    } else {
        NONE
    }
}

/// The class map: NMS survivors (`keep == 1`) get [`class_of`], the rest
/// [`NONE`]. `t1 = None` (a histogram with one bin, SPEC 4) means no edges.
pub fn classify(m: &Plane<u16>, keep: &Plane<u8>, t1: Option<u32>, grid: &WindowGrid, alpha_pct: u32) -> Plane<u8> {
    let w = m.width as usize;
    let mut out = Plane::<u8>::new(m.width, m.height);
    let Some(t1) = t1 else { return out };
    out.data.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        let y = y as u32;
        let (mr, kr) = (m.row(y), keep.row(y));
        for x in 0..w {
            if kr[x] != 0 {
                row[x] = class_of(mr[x] as u32, t1, grid.v3_at(x as u32, y), alpha_pct);
            }
        }
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tl1_saturates_at_255() {
        // V3 so large that (1+alpha)V > 360: M >= 255 still counts as above TL1.
        assert_eq!(class_of(255, 300, 765, 35), WEAK_STRONG);
        assert_eq!(class_of(254, 300, 765, 35), WEAK);
    }

    #[test]
    fn exact_rational_boundaries() {
        // alpha 35, V3 = 100: TL1 = 135/3 = 45, TL2 = 65/3 = 21.67
        assert_eq!(class_of(45, 1000, 100, 35), WEAK_STRONG);
        assert_eq!(class_of(44, 1000, 100, 35), WEAK_WEAK);
        // T1 = 31 -> T2 = 15.5: 16 is above, 15 is not
        assert_eq!(class_of(16, 31, 10_000, 35), WEAK_WEAK);
        assert_eq!(class_of(15, 31, 10_000, 35), NONE);
        // M = 22 >= TL2 (300*22 = 6600 >= 6500) but not 21
        assert_eq!(class_of(22, 1000, 100, 35), WEAK_WEAK);
        assert_eq!(class_of(21, 1000, 100, 35), NONE);
    }
}
