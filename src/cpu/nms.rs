//! SPEC 3: non-maximum suppression across the gradient direction, with the
//! direction sector found by integer tests. Mirrors shaders/nms.wgsl.

use super::gradient::Gradient;
use crate::image::Plane;
use rayon::prelude::*;

/// Neighbour offsets `(first, second)` of the direction sector of `(gx2, gy2)`.
/// `tan(22.5°) ≈ 13573/32768` and `tan(67.5°) ≈ 79109/32768`.
///
/// ```
/// use lfast::cpu::nms::sector;
/// assert_eq!(sector(10, 0), ((-1, 0), (1, 0)));   // horizontal gradient
/// assert_eq!(sector(0, -7), ((0, -1), (0, 1)));   // vertical gradient
/// assert_eq!(sector(5, 5), ((-1, -1), (1, 1)));   // same signs
/// assert_eq!(sector(5, -5), ((1, -1), (-1, 1)));  // opposite signs
/// ```
#[inline]
pub fn sector(gx2: i32, gy2: i32) -> ((i32, i32), (i32, i32)) {
    let ax = gx2.unsigned_abs();
    let ay = gy2.unsigned_abs();
    if ay * 32768 < 13573 * ax {
        ((-1, 0), (1, 0))
    } else if ay * 32768 > 79109 * ax {
        ((0, -1), (0, 1))
    } else if (gx2 > 0) == (gy2 > 0) {
        ((-1, -1), (1, 1))
    } else {
        ((1, -1), (-1, 1))
    }
}

/// S at (x, y), 0 outside the image.
#[inline(always)]
fn s_or_zero(s: &Plane<u32>, x: i32, y: i32) -> u32 {
    if x < 0 || y < 0 || x >= s.width as i32 || y >= s.height as i32 { 0 } else { s.at(x as u32, y as u32) }
}

/// 1 where the pixel survives NMS: `S > 0`, `S > S(first)`, `S >= S(second)`.
pub fn nms(g: &Gradient) -> Plane<u8> {
    let w = g.s.width as usize;
    let mut keep = Plane::<u8>::new(g.s.width, g.s.height);
    keep.data.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        let y = y as i32;
        for (x, k) in row.iter_mut().enumerate() {
            let x = x as i32;
            let s = g.s.at(x as u32, y as u32);
            if s == 0 {
                continue;
            }
            let ((ax, ay), (bx, by)) = sector(g.gx2.at(x as u32, y as u32) as i32, g.gy2.at(x as u32, y as u32) as i32);
            *k = (s > s_or_zero(&g.s, x + ax, y + ay) && s >= s_or_zero(&g.s, x + bx, y + by)) as u8;
        }
    });
    keep
}

#[cfg(test)]
mod tests {
    use super::super::gradient::gradient;
    use super::*;

    #[test]
    fn ramp_thins_to_one_pixel() {
        // A horizontal ramp 0,0,40,120,160,160,...: the gradient peaks where the
        // step is steepest (columns 2|3), NMS keeps only that column.
        let row = [0u8, 0, 40, 120, 160, 160, 160];
        let d = Plane::from_vec(7, 4, row.iter().copied().cycle().take(28).collect()).unwrap();
        let g = gradient(&d);
        let k = nms(&g);
        for y in 0..4 {
            let kept: Vec<u32> = (0..7).filter(|&x| k.at(x, y) == 1).collect();
            assert_eq!(kept, vec![2], "row {y}: {:?}", (0..7).map(|x| g.s.at(x, y)).collect::<Vec<_>>());
        }
    }

    #[test]
    fn plateau_keeps_first_of_equal_pair() {
        // Two equal maxima side by side in a horizontal pair: the left one passes
        // (S > S(x-1), S >= S(x+1)), the right one fails S > S(x-1). Exactly one survives.
        let row = [0u8, 0, 100, 200, 200];
        let d = Plane::from_vec(5, 2, row.iter().copied().cycle().take(10).collect()).unwrap();
        let g = gradient(&d);
        assert_eq!(g.s.at(1, 0), g.s.at(2, 0));
        let k = nms(&g);
        assert_eq!((k.at(1, 0), k.at(2, 0)), (1, 0));
    }

    #[test]
    fn sector_boundaries() {
        // ay/ax just below and above tan(22.5°)
        assert_eq!(sector(1000, 414), ((-1, 0), (1, 0)));
        assert_eq!(sector(1000, 415), ((-1, -1), (1, 1)));
        // ay/ax just above and below tan(67.5°) = 2.41421
        assert_eq!(sector(415, 1000), ((-1, -1), (1, 1)));
        assert_eq!(sector(415, -1000), ((1, -1), (-1, 1)));
        assert_eq!(sector(414, 1000), ((0, -1), (0, 1)));
    }
}
