//! SPEC 7 rules 1 and 2: isolated-edge suppression (paper Algorithm 3).
//! Mirrors shaders/rules.wgsl. Both rules read the classes of SPEC 6 for all
//! pixels at once, so the result does not depend on the visiting order.

use super::classify::{NONE, STRONG, WEAK, WEAK_STRONG, WEAK_WEAK};
use crate::image::Plane;
use rayon::prelude::*;

/// True iff one of the 8 neighbours of (x, y) (inside the image) has class `c`.
#[inline]
pub fn has_neighbour(classes: &Plane<u8>, x: u32, y: u32, c: u8) -> bool {
    let (w, h) = (classes.width as i32, classes.height as i32);
    for dy in -1..=1i32 {
        for dx in -1..=1i32 {
            let (nx, ny) = (x as i32 + dx, y as i32 + dy);
            if (dx, dy) != (0, 0) && nx >= 0 && ny >= 0 && nx < w && ny < h && classes.at(nx as u32, ny as u32) == c {
                return true;
            }
        }
    }
    false
}

/// Applies rules 1 and 2: WEAK_STRONG becomes STRONG next to another
/// WEAK_STRONG, else WEAK; WEAK_WEAK becomes NONE next to another WEAK_WEAK,
/// else WEAK. STRONG, WEAK and NONE are unchanged.
///
/// ```
/// use lfast::Plane;
/// use lfast::cpu::{classify::*, rules::rules};
/// let c = Plane::from_vec(3, 1, vec![WEAK_STRONG, WEAK_STRONG, WEAK_WEAK]).unwrap();
/// assert_eq!(rules(&c).data, vec![STRONG, STRONG, WEAK]);
/// ```
pub fn rules(classes: &Plane<u8>) -> Plane<u8> {
    let w = classes.width as usize;
    let mut out = Plane::<u8>::new(classes.width, classes.height);
    out.data.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        let y = y as u32;
        for (x, o) in row.iter_mut().enumerate() {
            *o = rule_at(classes, x as u32, y);
        }
    });
    out
}

/// The class of (x, y) after rules 1 and 2.
#[inline]
pub fn rule_at(classes: &Plane<u8>, x: u32, y: u32) -> u8 {
    match classes.at(x, y) {
        WEAK_STRONG => {
            if has_neighbour(classes, x, y, WEAK_STRONG) {
                STRONG
            } else {
                WEAK
            }
        }
        WEAK_WEAK => {
            if has_neighbour(classes, x, y, WEAK_WEAK) {
                NONE
            } else {
                WEAK
            }
        }
        c => c,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(w: u32, v: &[u8]) -> Plane<u8> {
        Plane::from_vec(w, v.len() as u32 / w, v.to_vec()).unwrap()
    }

    #[test]
    fn rule1_pair_becomes_strong() {
        // diagonal neighbours count (8-connectivity)
        let c = p(3, &[WEAK_STRONG, 0, 0, 0, WEAK_STRONG, 0, 0, 0, 0]);
        let r = rules(&c);
        assert_eq!((r.at(0, 0), r.at(1, 1)), (STRONG, STRONG));
    }

    #[test]
    fn rule1_isolated_becomes_weak() {
        // a STRONG neighbour does not count, only WEAK_STRONG
        let c = p(3, &[STRONG, 0, 0, 0, WEAK_STRONG, 0, 0, 0, WEAK]);
        let r = rules(&c);
        assert_eq!(r.data, vec![STRONG, 0, 0, 0, WEAK, 0, 0, 0, WEAK]);
    }

    #[test]
    fn rule2_pair_is_removed() {
        let c = p(4, &[WEAK_WEAK, WEAK_WEAK, 0, WEAK_WEAK]);
        let r = rules(&c);
        // the pair vanishes, the isolated one becomes WEAK
        assert_eq!(r.data, vec![NONE, NONE, 0, WEAK]);
    }

    #[test]
    fn rules_read_the_original_classes() {
        // Three WEAK_WEAK in a row all see a WEAK_WEAK neighbour in the input,
        // so all three go, though the middle one's neighbours are removed too.
        let c = p(3, &[WEAK_WEAK, WEAK_WEAK, WEAK_WEAK]);
        assert_eq!(rules(&c).data, vec![NONE; 3]);
        // WEAK_STRONG next to WEAK_WEAK: neither rule fires on the other class.
        let c = p(2, &[WEAK_STRONG, WEAK_WEAK]);
        assert_eq!(rules(&c).data, vec![WEAK, WEAK]);
    }
}
