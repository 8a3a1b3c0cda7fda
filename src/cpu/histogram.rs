//! SPEC 4, first half: the 256-bin histogram of `M8 = min(M, 255)`.
//! Mirrors shaders/histogram.wgsl.

use crate::image::Plane;

/// Histogram of `min(M, 255)` over all pixels.
///
/// ```
/// let m = lfast::Plane::from_vec(3, 1, vec![0u16, 7, 300]).unwrap();
/// let h = lfast::cpu::histogram::histogram(&m);
/// assert_eq!((h[0], h[7], h[255]), (1, 1, 1));
/// ```
pub fn histogram(m: &Plane<u16>) -> [u32; 256] {
    let mut h = [0u32; 256];
    for &v in &m.data {
        h[v.min(255) as usize] += 1;
    }
    h
}
