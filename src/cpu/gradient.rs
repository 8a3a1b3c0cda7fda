//! SPEC 2: LSD 2x2 gradient (paper Eq. 2) in integers. Mirrors shaders/gradient.wgsl.

use crate::image::Plane;
use rayon::prelude::*;

/// Per-pixel gradient planes of SPEC 2.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Gradient {
    /// Twice the paper's gx, in [-510, 510].
    pub gx2: Plane<i16>,
    /// Twice the paper's gy, in [-510, 510].
    pub gy2: Plane<i16>,
    /// Squared magnitude `gx2^2 + gy2^2`.
    pub s: Plane<u32>,
    /// Magnitude `isqrt(S) >> 1`, in 0..=360.
    pub m: Plane<u16>,
}

/// The gradient of D at (x, y): `(gx2, gy2)` with right and bottom reads clamped.
///
/// ```
/// use lfast::Plane;
/// // a vertical step from 0 to 100 between columns 0 and 1
/// let d = Plane::from_vec(2, 2, vec![0, 100, 0, 100]).unwrap();
/// assert_eq!(lfast::cpu::gradient::lsd_at(&d, 0, 0), (200, 0));
/// ```
#[inline]
pub fn lsd_at(d: &Plane<u8>, x: u32, y: u32) -> (i32, i32) {
    let x1 = (x + 1).min(d.width - 1);
    let y1 = (y + 1).min(d.height - 1);
    let a = d.at(x, y) as i32; // (x, y)
    let b = d.at(x1, y) as i32; // (x+1, y)
    let c = d.at(x, y1) as i32; // (x, y+1)
    let e = d.at(x1, y1) as i32; // (x+1, y+1)
    (b + e - a - c, c + e - a - b)
}

/// `M = isqrt(S) >> 1` (SPEC 2).
#[inline(always)]
pub fn magnitude(s: u32) -> u16 {
    (s.isqrt() >> 1) as u16
}

/// All gradient planes of D.
pub fn gradient(d: &Plane<u8>) -> Gradient {
    let (w, h) = (d.width as usize, d.height as usize);
    let mut gx2 = Plane::<i16>::new(d.width, d.height);
    let mut gy2 = Plane::<i16>::new(d.width, d.height);
    let mut s = Plane::<u32>::new(d.width, d.height);
    let mut m = Plane::<u16>::new(d.width, d.height);
    gx2.data
        .par_chunks_mut(w)
        .zip(gy2.data.par_chunks_mut(w))
        .zip(s.data.par_chunks_mut(w))
        .zip(m.data.par_chunks_mut(w))
        .enumerate()
        .for_each(|(y, (((gx, gy), ss), mm))| {
            let r0 = d.row(y as u32);
            let r1 = d.row((y + 1).min(h - 1) as u32);
            for x in 0..w {
                let x1 = (x + 1).min(w - 1);
                let (a, b, c, e) = (r0[x] as i32, r0[x1] as i32, r1[x] as i32, r1[x1] as i32);
                let dx = b + e - a - c;
                let dy = c + e - a - b;
                let sq = (dx * dx + dy * dy) as u32;
                gx[x] = dx as i16;
                gy[x] = dy as i16;
                ss[x] = sq;
                mm[x] = magnitude(sq);
            }
        });
    Gradient { gx2, gy2, s, m }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn step_gradient() {
        // Horizontal step 10 -> 60 between columns 1 and 2, 4x3 image.
        #[rustfmt::skip]
        let d = Plane::from_vec(4, 3, vec![
            10, 10, 60, 60,
            10, 10, 60, 60,
            10, 10, 60, 60,
        ]).unwrap();
        let g = gradient(&d);
        // Only the 2x2 cells straddling columns 1|2 see the step: gx2 = 2*50.
        for y in 0..3 {
            assert_eq!(g.gx2.at(0, y), 0);
            assert_eq!(g.gx2.at(1, y), 100);
            assert_eq!(g.gx2.at(2, y), 0);
            assert_eq!(g.gx2.at(3, y), 0); // clamped: x+1 reads x
            for x in 0..4 {
                assert_eq!(g.gy2.at(x, y), 0);
            }
            assert_eq!(g.s.at(1, y), 10000);
            assert_eq!(g.m.at(1, y), 50); // isqrt(10000) >> 1
        }
    }

    #[test]
    fn diagonal_and_extremes() {
        let d = Plane::from_vec(2, 2, vec![0, 0, 0, 255]).unwrap();
        assert_eq!(lsd_at(&d, 0, 0), (255, 255));
        let g = gradient(&d);
        assert_eq!(g.s.at(0, 0), 2 * 255 * 255);
        assert_eq!(g.m.at(0, 0), ((2u32 * 255 * 255).isqrt() >> 1) as u16); // 180
        let d = Plane::from_vec(2, 2, vec![0, 255, 0, 255]).unwrap();
        assert_eq!(lsd_at(&d, 0, 0), (510, 0));
        let d = Plane::from_vec(2, 2, vec![0, 255, 255, 255]).unwrap();
        let (gx, gy) = lsd_at(&d, 0, 0);
        assert_eq!((gx, gy), (255, 255));
        let d = Plane::from_vec(2, 2, vec![255, 0, 0, 255]).unwrap();
        assert_eq!(lsd_at(&d, 0, 0), (0, 0));
        // the maximum magnitude of SPEC 2: 360
        assert_eq!(magnitude(510 * 510 * 2), 360);
    }

    #[test]
    fn single_pixel_image() {
        let d = Plane::from_vec(1, 1, vec![77]).unwrap();
        let g = gradient(&d);
        assert_eq!(g.s.data, vec![0]);
    }
}
