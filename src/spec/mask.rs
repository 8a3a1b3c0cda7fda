//! Masks: the input mask taken to every pyramid level, and the distance kept
//! between a keypoint and the boundary of the mask (both paths build the
//! level masks here; the GPU uploads them).

use super::angle::HALF_PATCH;
use super::pattern::Pattern;
use crate::image::Plane;

/// Distance kept between keypoints and the boundary of a mask, in level
/// pixels: a corner's descriptor reads the smoothed image up to the ORB
/// pattern radius (+3 for the 7x7 blur) and its orientation the radius-15 disc.
///
/// ```
/// assert_eq!(lfast::spec::mask_radius(), 22);
/// ```
pub fn mask_radius() -> u32 {
    (Pattern::orb().radius() + 3).max(HALF_PATCH) as u32
}

/// The mask at a `w x h` level: a level pixel is on only if every input pixel
/// under its footprint is on, then eroded by `radius` level pixels (square).
pub fn level_mask(mask: &Plane<u8>, w: u32, h: u32, radius: u32) -> Plane<u8> {
    let (w0, h0) = (mask.width as u64, mask.height as u64);
    let span = |i: u64, n: u64, n0: u64| (i * n0 / n, ((i + 1) * n0).div_ceil(n).min(n0).max(i * n0 / n + 1));
    // footprint min along x for every input row, then along y
    let mut tmp = vec![0u8; h0 as usize * w as usize];
    for y in 0..h0 as usize {
        let row = mask.row(y as u32);
        for x in 0..w as u64 {
            let (a, b) = span(x, w as u64, w0);
            tmp[y * w as usize + x as usize] = row[a as usize..b as usize].iter().all(|&v| v != 0) as u8;
        }
    }
    let mut lv = Plane::<u8>::new(w, h);
    for y in 0..h as u64 {
        let (a, b) = span(y, h as u64, h0);
        for x in 0..w as usize {
            lv.data[y as usize * w as usize + x] = (a..b).all(|yy| tmp[yy as usize * w as usize + x] != 0) as u8;
        }
    }
    erode(&lv, radius)
}

/// Square erosion of a 0/1 plane by `r` (min filter), replicate border.
fn erode(p: &Plane<u8>, r: u32) -> Plane<u8> {
    if r == 0 {
        return p.clone();
    }
    let r = r as i32;
    let mut tmp = Plane::<u8>::new(p.width, p.height);
    for y in 0..p.height as i32 {
        for x in 0..p.width as i32 {
            tmp.data[(y * p.width as i32 + x) as usize] = (-r..=r).map(|d| p.clamped(x + d, y)).min().unwrap_or(0);
        }
    }
    let mut out = Plane::<u8>::new(p.width, p.height);
    for y in 0..p.height as i32 {
        for x in 0..p.width as i32 {
            out.data[(y * p.width as i32 + x) as usize] = (-r..=r).map(|d| tmp.clamped(x, y + d)).min().unwrap_or(0);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn level_mask_footprints_and_erosion() {
        // one off pixel in the input turns off its level pixel and, after erosion, a square
        let mut m = Plane::<u8>::new(40, 40);
        m.data.fill(1);
        m.data[20 * 40 + 20] = 0;
        let lv = level_mask(&m, 20, 20, 0);
        assert_eq!(lv.data.iter().filter(|&&v| v == 0).count(), 1);
        assert_eq!(lv.at(10, 10), 0);
        let lv = level_mask(&m, 20, 20, 2);
        assert_eq!(lv.data.iter().filter(|&&v| v == 0).count(), 25);
        // a non-integer ratio: footprints overlap, so two level pixels may go off
        let lv = level_mask(&m, 17, 17, 0);
        let off = lv.data.iter().filter(|&&v| v == 0).count();
        assert!((1..=4).contains(&off), "{off}");
    }
}
