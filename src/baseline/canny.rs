//! Traditional Canny (SPEC 12), the paper's comparison: Gaussian blur (5x5,
//! sigma 0.8), 3x3 Sobel, L2 magnitude, NMS and hysteresis with fixed
//! thresholds (paper: 200 high, 100 low). Follows cv2.Canny(L2gradient=True)
//! on the blurred image; NMS and hysteresis are the shared ones of SPEC 3/7.

use crate::cpu::blur::{gaussian_blur, gaussian_kernel_q8};
use crate::cpu::classify::{NONE, STRONG, WEAK};
use crate::cpu::hysteresis::hysteresis;
use crate::cpu::nms::sector;
use crate::image::Plane;
use rayon::prelude::*;

/// Parameters of the traditional Canny detector.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CannyParams {
    /// Gaussian sigma (the paper's "alpha = 0.8").
    pub sigma: f64,
    /// Gaussian kernel size (odd).
    pub ksize: usize,
    /// Lower hysteresis threshold on the L2 Sobel magnitude.
    pub low: f64,
    /// Upper hysteresis threshold.
    pub high: f64,
}

impl Default for CannyParams {
    fn default() -> Self {
        Self { sigma: 0.8, ksize: 5, low: 100.0, high: 200.0 }
    }
}

/// 3x3 Sobel `(dx, dy)` at (x, y), replicate border.
#[inline]
pub fn sobel_at(img: &Plane<u8>, x: i32, y: i32) -> (i32, i32) {
    let p = |dx: i32, dy: i32| img.clamped(x + dx, y + dy) as i32;
    let gx = p(1, -1) + 2 * p(1, 0) + p(1, 1) - p(-1, -1) - 2 * p(-1, 0) - p(-1, 1);
    let gy = p(-1, 1) + 2 * p(0, 1) + p(1, 1) - p(-1, -1) - 2 * p(0, -1) - p(1, -1);
    (gx, gy)
}

/// The Canny edge map (255 = edge) of `img`.
///
/// ```
/// use lfast::baseline::canny::{canny, CannyParams};
/// let mut img = lfast::Plane::<u8>::new(20, 20);
/// for y in 0..20 { for x in 10..20 { img.data[y * 20 + x] = 255; } }
/// let e = canny(&img, &CannyParams::default());
/// // one thin vertical line next to the step
/// assert!((2..18).all(|y| (0..20).filter(|&x| e.at(x, y) == 255).count() == 1));
/// ```
pub fn canny(img: &Plane<u8>, p: &CannyParams) -> Plane<u8> {
    if img.is_empty() {
        return img.clone();
    }
    let blurred = gaussian_blur(img, &gaussian_kernel_q8(p.ksize, p.sigma));
    let (w, h) = (img.width as usize, img.height as usize);
    let mut gxy = vec![(0i32, 0i32); w * h];
    gxy.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, g) in row.iter_mut().enumerate() {
            *g = sobel_at(&blurred, x as i32, y as i32);
        }
    });
    let s: Vec<u64> = gxy.iter().map(|&(a, b)| (a * a + b * b) as u64).collect();
    let s_at = |x: i32, y: i32| {
        if x < 0 || y < 0 || x >= w as i32 || y >= h as i32 { 0 } else { s[y as usize * w + x as usize] }
    };
    let (low2, high2) = (p.low * p.low, p.high * p.high);
    let mut classes = Plane::<u8>::new(img.width, img.height);
    classes.data.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, c) in row.iter_mut().enumerate() {
            let i = y * w + x;
            let m = s[i];
            if m as f64 <= low2 {
                continue;
            }
            let ((ax, ay), (bx, by)) = sector(gxy[i].0, gxy[i].1);
            let (x, y) = (x as i32, y as i32);
            if m > s_at(x + ax, y + ay) && m >= s_at(x + bx, y + by) {
                *c = if m as f64 > high2 { STRONG } else { WEAK };
            } else {
                *c = NONE;
            }
        }
    });
    hysteresis(&classes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sobel_by_hand() {
        let img = Plane::from_vec(3, 3, vec![0, 0, 10, 0, 0, 10, 0, 0, 10]).unwrap();
        assert_eq!(sobel_at(&img, 1, 1), (40, 0));
    }

    #[test]
    fn weak_step_below_low_gives_nothing() {
        let mut img = Plane::<u8>::new(20, 20);
        for y in 0..20 {
            for x in 10..20 {
                img.data[y * 20 + x] = 10; // Sobel peak 40*~0.5 < 100
            }
        }
        assert!(canny(&img, &CannyParams::default()).data.iter().all(|&v| v == 0));
    }

    #[test]
    fn hysteresis_follows_weak_chain() {
        // A step whose height fades: strong at the top, weak further down,
        // connected, so the whole line is kept.
        let mut img = Plane::<u8>::new(20, 30);
        for y in 0..30 {
            let v = if y < 10 { 200 } else { 70 };
            for x in 10..20 {
                img.data[y * 20 + x] = v;
            }
        }
        let e = canny(&img, &CannyParams::default());
        assert!((3..27).all(|y| (8..12).any(|x| e.at(x, y) == 255)));
    }
}
