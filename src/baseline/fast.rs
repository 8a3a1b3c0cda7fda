//! FAST-9 (the 9-of-16 segment test) exactly as OpenCV's `cv::FAST` with
//! `TYPE_9_16`: `FAST_t<16>` of `modules/features2d/src/fast.cpp` and
//! `cornerScore<16>` of `fast_score.cpp` (SPEC 12).
//!
//! The port keeps OpenCV's structure so that its output matches keypoint for
//! keypoint, in the same order:
//!
//! - the threshold is clamped to `0..=255`, and a 511-entry table classifies a
//!   difference `x - v` as darker (1, `< -t`), brighter (2, `> t`) or neither (0);
//! - the quick rejection ANDs the classes of the opposite pairs 0/8, 2/10, 4/12,
//!   6/14, then 1/9, 3/11, 5/13, 7/15;
//! - the survivors run the 25-long cyclic count (`++count > 8`) for darker, then
//!   brighter; each run that succeeds records the pixel (so a pixel passing both
//!   would be recorded twice, as in OpenCV, although 9 + 9 > 16 makes that
//!   impossible);
//! - three rolling row buffers hold the scores (0 for non-corners, and all of
//!   them when non-max suppression is off); a corner of row `y` is kept iff its
//!   score is strictly greater than all 8 neighbours' — decided, and emitted,
//!   when row `y + 1` has been scanned, so output is row by row, left to right,
//!   over rows `3..=height-4` and columns `3..=width-4`.
//!
//! One OpenCV quirk is deliberately not copied: OpenCV builds its SIMD threshold
//! vector from the threshold *before* clamping it (`(char)threshold`, so 300
//! acts as 44 and -3 as 253 in the vectorised columns, while the scalar columns
//! use the clamped value). Within `0..=255` the two agree and this port is exact;
//! outside it, this port uses the clamped threshold everywhere.

use crate::cpu::fused::for_each_nonzero;
use crate::{KeyPoint, Plane};

/// The Bresenham circle of radius 3 as `(dx, dy)`, in OpenCV's `offsets16` order.
#[rustfmt::skip]
const OFFSETS: [(isize, isize); 16] = [
    (0, 3), (1, 3), (2, 2), (3, 1), (3, 0), (3, -1), (2, -2), (1, -3),
    (0, -3), (-1, -3), (-2, -2), (-3, -1), (-3, 0), (-3, 1), (-2, 2), (-1, 3),
];

/// Half the pattern: a corner needs `K + 1 = 9` contiguous circle pixels.
const K: usize = 8;
/// Length of the cyclic scan: the 16 circle pixels, then the first 9 again.
const N: usize = 16 + K + 1;
/// Distance from the image border that the circle needs.
const RADIUS: usize = 3;

/// OpenCV's `makeOffsets`: index offsets of the circle for a row stride, the
/// first `N - 16` repeated at the end.
fn make_offsets(stride: usize) -> [isize; N] {
    let stride = stride as isize;
    std::array::from_fn(|k| {
        let (dx, dy) = OFFSETS[k % 16];
        dx + dy * stride
    })
}

/// The circle pixel `k` (`0..N`) around the pixel at index `centre`.
///
/// The caller guarantees that `centre` is at least [`RADIUS`] pixels from every
/// side, so the index is in bounds.
#[inline]
fn circle(data: &[u8], centre: usize, pixel: &[isize; N], k: usize) -> i32 {
    i32::from(data[centre.wrapping_add_signed(pixel[k])])
}

/// OpenCV's `cornerScore<16>` on the pixel at index `centre`.
///
/// With `d[k] = v - circle[k]`, it returns `max(threshold, A, -B) - 1`, where `A`
/// (`B`) is the largest (smallest), over the 16 arcs of 9 contiguous circle
/// pixels, of the smallest (largest) `d` on the arc. For a corner at
/// `threshold` this is the largest threshold at which the pixel is still a
/// corner. OpenCV's scalar form skips arcs that cannot raise the running
/// maximum (data-dependent branches); this computes every arc's minimum and
/// maximum by doubling windows over 16-bit lanes (`|d| <= 255`), which gives
/// the same maxima without branches (`tests::corner_score_equals_opencvs_form`).
fn corner_score(data: &[u8], centre: usize, pixel: &[isize; N], threshold: i32) -> i32 {
    let v = i32::from(data[centre]);
    let c: [i16; 16] = std::array::from_fn(|k| (v - circle(data, centre, pixel, k)) as i16);
    // the circle twice, so that every arc is a contiguous window
    let d: [i16; 32] = std::array::from_fn(|k| c[k % 16]);
    // smallest / largest over windows of 2, 4, 8, then 9 pixels starting at k
    let lo2: [i16; 31] = std::array::from_fn(|k| d[k].min(d[k + 1]));
    let hi2: [i16; 31] = std::array::from_fn(|k| d[k].max(d[k + 1]));
    let lo4: [i16; 29] = std::array::from_fn(|k| lo2[k].min(lo2[k + 2]));
    let hi4: [i16; 29] = std::array::from_fn(|k| hi2[k].max(hi2[k + 2]));
    let lo8: [i16; 25] = std::array::from_fn(|k| lo4[k].min(lo4[k + 4]));
    let hi8: [i16; 25] = std::array::from_fn(|k| hi4[k].max(hi4[k + 4]));
    let (mut a, mut b) = (i16::MIN, i16::MAX);
    for k in 0..16 {
        a = a.max(lo8[k].min(d[k + 8]));
        b = b.min(hi8[k].max(d[k + 8]));
    }
    threshold.max(i32::from(a)).max(-i32::from(b)) - 1
}

/// Bit `k` set where circle pixel `k` (`0..16`) satisfies `pass`.
#[inline]
fn circle_mask(data: &[u8], centre: usize, pixel: &[isize; N], pass: impl Fn(i32) -> bool) -> u32 {
    (0..16).fold(0, |m, k| m | (u32::from(pass(circle(data, centre, pixel, k))) << k))
}

/// [`has_run`] on a [`circle_mask`]: true iff the 16 bits, read cyclically,
/// hold more than [`K`] consecutive ones. The mask is doubled so that every
/// arc is a contiguous window; `t` keeps bit `i` where bits `i..i + 8` are all
/// set, found by doubling windows (2, 4, 8, then the 9th bit), with no branch
/// to mispredict (`tests::has_arc_equals_the_run_count`).
#[inline]
fn has_arc(mask: u32) -> bool {
    let m = mask | (mask << 16);
    let t = m & (m >> 1);
    let t = t & (t >> 2);
    let t = t & (t >> 4);
    t & (m >> K) & 0xffff != 0
}

/// The cyclic run count of `FAST_t`: true iff more than [`K`] consecutive
/// entries of the 25-long scan satisfy `pass`. The reference of [`has_arc`].
#[cfg_attr(not(test), allow(dead_code))]
#[inline]
fn has_run(data: &[u8], centre: usize, pixel: &[isize; N], pass: impl Fn(i32) -> bool) -> bool {
    let mut count = 0;
    for k in 0..N {
        if pass(circle(data, centre, pixel, k)) {
            count += 1;
            if count > K {
                return true;
            }
        } else {
            count = 0;
        }
    }
    false
}

/// The `--detector fast` front end: FAST-9 with non-maximum suppression,
/// the `cap` strongest kept (0 = all), described by `describe` (ORB descriptors
/// of the caller-supplied keypoints).
pub fn fast9_and_compute(
    image: &Plane<u8>,
    threshold: i32,
    cap: u32,
    describe: &crate::cpu::CpuDetector,
) -> crate::Result<(Vec<KeyPoint>, Vec<crate::Descriptor>)> {
    image.view().check()?;
    let mut kps = fast9(image, threshold, true);
    if cap > 0 {
        kps.sort_by(|a, b| b.response.total_cmp(&a.response));
        kps.truncate(cap as usize);
    }
    let desc = describe.compute(image.view(), &kps)?;
    Ok((kps, desc))
}

/// OpenCV's quick rejection at one pixel, the scalar reference of
/// [`quick_classes_row`]: with class 1 for a circle pixel darker than
/// `v - t`, 2 for brighter than `v + t`, 0 otherwise, the AND over the eight
/// opposite pairs `k, k + 8` of `class(k) | class(k + 8)`. Bit 1 (2) set means
/// the darker (brighter) run count must run; 0 rejects the pixel.
#[cfg_attr(not(test), allow(dead_code))]
fn quick_class(data: &[u8], centre: usize, pixel: &[isize; N], threshold: i32) -> u8 {
    let v = i32::from(data[centre]);
    let class = |k: usize| {
        let x = circle(data, centre, pixel, k);
        (x < v - threshold) as u8 | (((x > v + threshold) as u8) << 1)
    };
    (0..8).fold(3, |d, k| d & (class(k) | class(k + 8)))
}

/// [`quick_class`] of every pixel of row `i` at columns `3..width-3`, into
/// `out[j - 3]`. Rows `i - 3 ..= i + 3` must exist.
fn quick_classes_row(data: &[u8], width: usize, i: usize, threshold: u8, out: &mut [u8]) {
    let n = width - 2 * RADIUS;
    // the 16 circle pixels of the n centres as shifted slices of their rows
    let at = |dx: isize, dy: isize| {
        let start = ((i as isize + dy) * width as isize + RADIUS as isize + dx) as usize;
        &data[start..start + n]
    };
    let ring: [&[u8]; 16] = std::array::from_fn(|k| at(OFFSETS[k].0, OFFSETS[k].1));
    quick_classes(at(0, 0), &ring, threshold, &mut out[..n]);
}

crate::cpu::simd::dispatch! {
    /// The lane-parallel body of [`quick_classes_row`]: `centre[x]` against
    /// `ring[k][x]`, with saturating bounds (`x < v - t` is `x < sat(v - t)`
    /// for u8, as no u8 is below 0 or above 255).
    fn quick_classes(centre: &[u8], ring: &[&[u8]; 16], threshold: u8, out: &mut [u8]) {
        let n = out.len();
        let centre = &centre[..n];
        let ring: [&[u8]; 16] = std::array::from_fn(|k| &ring[k][..n]);
        for x in 0..n {
            let v = centre[x];
            let (lo, hi) = (v.saturating_sub(threshold), v.saturating_add(threshold));
            let mut d = 3u8;
            for k in 0..8 {
                let (a, b) = (ring[k][x], ring[k + 8][x]);
                let ca = (a < lo) as u8 | (((a > hi) as u8) << 1);
                let cb = (b < lo) as u8 | (((b > hi) as u8) << 1);
                d &= ca | cb;
            }
            out[x] = d;
        }
    }
}

/// FAST-9 corners of `image`, exactly as OpenCV's
/// `cv::FAST(image, keypoints, threshold, nonmax, FastFeatureDetector::TYPE_9_16)`:
/// same keypoints, same order (row by row, left to right).
///
/// Every keypoint has `size = 7`, `angle = -1`, `octave = 0`, `class_id = -1`
/// and `response` = its score (OpenCV's `cornerScore`), or 0 when `nonmax` is
/// off. `threshold` is clamped to `0..=255`. Images smaller than 7x7 (or whose
/// `data` is shorter than `width * height`) have no keypoints.
///
/// ```
/// use lfast::{Plane, baseline::fast::fast9};
///
/// // One bright pixel on a dark 9x9 background.
/// let mut img = Plane::<u8>::new(9, 9);
/// img.data[4 * 9 + 4] = 200;
/// let kps = fast9(&img, 20, true);
/// assert_eq!(kps.len(), 1);
/// assert_eq!((kps[0].pt.x, kps[0].pt.y), (4.0, 4.0));
/// assert_eq!(kps[0].response, 199.0); // still a corner at any threshold below 200
/// ```
pub fn fast9(image: &Plane<u8>, threshold: i32, nonmax: bool) -> Vec<KeyPoint> {
    let (width, height) = (image.width as usize, image.height as usize);
    let data = image.data.as_slice();
    let mut keypoints = Vec::new();
    if width < 2 * RADIUS + 1 || height < 2 * RADIUS + 1 || data.len() < width * height {
        return keypoints;
    }

    let threshold = threshold.clamp(0, 255);
    let pixel = make_offsets(width);
    let mut classes = vec![0u8; width - 2 * RADIUS];

    // Scores of the last three rows (row i - 3 in slot (i - 3) % 3) and their corners' columns.
    let mut scores: [Vec<u8>; 3] = std::array::from_fn(|_| vec![0; width]);
    let mut corners: [Vec<usize>; 3] = Default::default();

    for i in RADIUS..height - 2 {
        let slot = (i - 3) % 3;
        scores[slot].fill(0);
        corners[slot].clear();

        if i < height - 3 {
            let (curr, cornerpos) = (&mut scores[slot], &mut corners[slot]);
            // The quick rejection of 32 pixels at a time (AVX2), then the run
            // counts on the few survivors, in column order as OpenCV.
            quick_classes_row(data, width, i, threshold as u8, &mut classes);
            for_each_nonzero(&classes, |k| {
                let j = RADIUS + k;
                let centre = i * width + j;
                let v = i32::from(data[centre]);
                let d = classes[k];
                if d & 1 != 0 && has_arc(circle_mask(data, centre, &pixel, |x| x < v - threshold)) {
                    cornerpos.push(j);
                }
                if d & 2 != 0 && has_arc(circle_mask(data, centre, &pixel, |x| x > v + threshold)) {
                    cornerpos.push(j);
                }
            });
            if nonmax {
                // OpenCV scores each corner as it records it; scoring the row's
                // corners afterwards stores the same values. A score is in
                // 0..=254, as `max(threshold, A, B) <= 255` and A or B exceeds the
                // threshold at a corner.
                for &j in cornerpos.iter() {
                    curr[j] = corner_score(data, i * width + j, &pixel, threshold) as u8;
                }
            }
        }

        if i == RADIUS {
            continue;
        }

        // Decide row i - 1 now that rows i - 2 and i are scored.
        let curr = &scores[slot];
        let prev = &scores[(i - 1) % 3];
        let pprev = &scores[(i - 2) % 3];
        for &j in &corners[(i - 1) % 3] {
            let score = prev[j];
            let is_max = || {
                score > prev[j + 1]
                    && score > prev[j - 1]
                    && score > pprev[j - 1]
                    && score > pprev[j]
                    && score > pprev[j + 1]
                    && score > curr[j - 1]
                    && score > curr[j]
                    && score > curr[j + 1]
            };
            if !nonmax || is_max() {
                let mut kp = KeyPoint::new(j as f32, (i - 1) as f32, 7.0);
                kp.response = f32::from(score);
                keypoints.push(kp);
            }
        }
    }
    keypoints
}

/// OpenCV's `cornerScore<16>` at `(x, y)`: for a FAST-9 corner at `threshold`,
/// the largest threshold at which it is still a corner (the `response` that
/// [`fast9`] reports).
///
/// This is the scalar form of OpenCV: `max(threshold, A, B) - 1`, where `A`
/// (`B`) is the largest, over the 16 arcs of 9 contiguous circle pixels, of the
/// smallest `v - circle` (`circle - v`) on the arc. (OpenCV's SIMD form returns
/// `max(A, B) - 1`; both agree on every corner.) `threshold` is used as given,
/// as OpenCV's function does. Points closer than 3 pixels to a side, or outside
/// the image, score 0.
///
/// ```
/// use lfast::{Plane, baseline::fast::fast_score};
///
/// let mut img = Plane::<u8>::new(7, 7);
/// img.data[3 * 7 + 3] = 10; // a dark background: darker by 10 all round
/// assert_eq!(fast_score(&img, 3, 3, 5), 9);
/// assert_eq!(fast_score(&img, 0, 0, 5), 0);
/// ```
pub fn fast_score(image: &Plane<u8>, x: u32, y: u32, threshold: i32) -> i32 {
    let (width, height) = (image.width as usize, image.height as usize);
    let (x, y) = (x as usize, y as usize);
    let inside = x >= RADIUS && y >= RADIUS && x + RADIUS < width && y + RADIUS < height;
    if !inside || image.data.len() < width * height {
        return 0;
    }
    corner_score(&image.data, y * width + x, &make_offsets(width), threshold)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// OpenCV's `cornerScore<16>` in its scalar form, as the reference.
    ///
    /// With `d[k] = v - circle[k]`, it returns `max(threshold, A, B) - 1`, where `A`
    /// (`B`) is the largest, over the 16 arcs of 9 contiguous circle pixels, of the
    /// smallest `d` (`-d`) on the arc. For a corner at `threshold` this is the
    /// largest threshold at which the pixel is still a corner.
    fn corner_score_opencv(data: &[u8], centre: usize, pixel: &[isize; N], threshold: i32) -> i32 {
        let v = i32::from(data[centre]);
        let d: [i32; N] = std::array::from_fn(|k| v - circle(data, centre, pixel, k));

        let mut a0 = threshold;
        for k in (0..16).step_by(2) {
            let mut a = d[k + 1].min(d[k + 2]).min(d[k + 3]);
            if a <= a0 {
                continue;
            }
            a = a.min(d[k + 4]).min(d[k + 5]).min(d[k + 6]).min(d[k + 7]).min(d[k + 8]);
            a0 = a0.max(a.min(d[k]));
            a0 = a0.max(a.min(d[k + 9]));
        }

        let mut b0 = -a0;
        for k in (0..16).step_by(2) {
            let mut b = d[k + 1].max(d[k + 2]).max(d[k + 3]).max(d[k + 4]).max(d[k + 5]);
            if b >= b0 {
                continue;
            }
            b = b.max(d[k + 6]).max(d[k + 7]).max(d[k + 8]);
            b0 = b0.min(b.max(d[k]));
            b0 = b0.min(b.max(d[k + 9]));
        }

        -b0 - 1
    }

    proptest! {
        #[test]
        fn corner_score_equals_opencvs_form(patch in proptest::collection::vec(any::<u8>(), 49), threshold in 0i32..256,
                                            spread in 0u8..4) {
            // a 7x7 patch: the circle around its centre (24); `spread` narrows
            // values towards the centre so that ties and small d occur
            let patch: Vec<u8> = patch.iter().map(|&v| if spread == 0 { v } else { 128u8.wrapping_add(v >> (4 + spread)) }).collect();
            let pixel = make_offsets(7);
            prop_assert_eq!(corner_score(&patch, 24, &pixel, threshold), corner_score_opencv(&patch, 24, &pixel, threshold));
        }
    }

    #[test]
    fn has_arc_equals_the_run_count() {
        // every 16-bit mask, as the circle of a 7x7 patch: pixel k dark (0) where bit k is set
        let pixel = make_offsets(7);
        for mask in 0u32..1 << 16 {
            let mut patch = [255u8; 49];
            for k in 0..16 {
                if mask >> k & 1 != 0 {
                    patch[24usize.wrapping_add_signed(pixel[k])] = 0;
                }
            }
            let dark = |x: i32| x < 100;
            assert_eq!(circle_mask(&patch, 24, &pixel, dark), mask);
            assert_eq!(has_arc(mask), has_run(&patch, 24, &pixel, dark), "{mask:016b}");
        }
    }

    fn plane(width: u32, height: u32, data: Vec<u8>) -> Plane<u8> {
        Plane { width, height, data }
    }

    fn points(kps: &[KeyPoint]) -> Vec<(u32, u32, u32)> {
        kps.iter().map(|k| (k.pt.x as u32, k.pt.y as u32, k.response as u32)).collect()
    }

    /// `value` at `(x, y)` on a `fill` background.
    fn dot(width: u32, height: u32, fill: u8, x: u32, y: u32, value: u8) -> Plane<u8> {
        let mut p = plane(width, height, vec![fill; (width * height) as usize]);
        p.data[(y * width + x) as usize] = value;
        p
    }

    #[test]
    fn bright_dot_is_one_corner() {
        // The centre is brighter than all 16 circle pixels by 255: a corner at
        // every threshold t with 255 > t, so the score is 254. Every other pixel
        // sees the dot at most once on its circle.
        let img = dot(9, 9, 0, 4, 4, 255);
        let kps = fast9(&img, 20, true);
        assert_eq!(points(&kps), vec![(4, 4, 254)]);
        let kp = kps[0];
        assert_eq!((kp.size, kp.angle, kp.octave, kp.class_id), (7.0, -1.0, 0, -1));
        assert_eq!(fast_score(&img, 4, 4, 20), 254);
        // Without non-max suppression the response is 0.
        assert_eq!(points(&fast9(&img, 20, false)), vec![(4, 4, 0)]);
    }

    #[test]
    fn dark_dot_scores_difference_minus_one() {
        let img = dot(9, 9, 200, 4, 4, 50);
        assert_eq!(points(&fast9(&img, 20, true)), vec![(4, 4, 149)]);
        // At threshold 149 still a corner (150 > 149), at 150 not.
        assert_eq!(fast9(&img, 149, false).len(), 1);
        assert!(fast9(&img, 150, false).is_empty());
    }

    #[test]
    fn dot_below_threshold_is_not_a_corner() {
        let img = dot(9, 9, 100, 4, 4, 120);
        assert!(fast9(&img, 20, true).is_empty());
        assert_eq!(points(&fast9(&img, 19, true)), vec![(4, 4, 19)]);
    }

    #[test]
    fn threshold_is_clamped() {
        let img = dot(9, 9, 0, 4, 4, 255);
        assert_eq!(points(&fast9(&img, -7, true)), vec![(4, 4, 254)]);
        // Clamped to 255: nothing differs by more than 255.
        assert!(fast9(&img, 1000, true).is_empty());
    }

    #[test]
    fn flat_image_has_no_corners() {
        for v in [0, 128, 255] {
            let img = plane(16, 12, vec![v; 16 * 12]);
            assert!(fast9(&img, 0, false).is_empty());
        }
    }

    #[test]
    fn straight_edge_has_no_corners() {
        // Any pixel beside a vertical or horizontal step sees 7 circle pixels
        // across it, never 9.
        let (w, h) = (14u32, 12u32);
        let vertical = plane(w, h, (0..w * h).map(|i| if i % w < 7 { 0 } else { 255 }).collect());
        let horizontal = plane(w, h, (0..w * h).map(|i| if i / w < 6 { 0 } else { 255 }).collect());
        for img in [vertical, horizontal] {
            assert!(fast9(&img, 20, false).is_empty());
        }
    }

    #[test]
    fn square_corner_and_strict_suppression() {
        // A bright (255) quadrant x >= 6, y >= 6 on black. Inside it, (6, 6) sees
        // circle pixels 5..=15 dark (11 in a row), (7, 6) 5..=14, (8, 6) 5..=13,
        // (7, 7) 6..=14; (6, 7) and (6, 8) mirror (7, 6) and (8, 6). (9, 6) sees
        // only 7 dark in a row, (8, 7) 8, and pixels outside see at most 3 bright.
        // All six score 254, so none is strictly greater than its neighbours and
        // non-max suppression removes all of them (as OpenCV does).
        let (w, h) = (13u32, 13u32);
        let img = plane(w, h, (0..w * h).map(|i| if i % w >= 6 && i / w >= 6 { 255 } else { 0 }).collect());
        let expected = vec![(6, 6, 0), (7, 6, 0), (8, 6, 0), (6, 7, 0), (7, 7, 0), (6, 8, 0)];
        assert_eq!(points(&fast9(&img, 20, false)), expected);
        for (x, y, _) in expected {
            assert_eq!(fast_score(&img, x, y, 20), 254);
        }
        assert!(fast9(&img, 20, true).is_empty());
    }

    #[test]
    fn equal_neighbours_suppress_each_other() {
        // Two touching bright pixels are both corners with score 254; neither is
        // strictly greater than the other.
        let mut img = dot(10, 9, 0, 4, 4, 255);
        img.data[4 * 10 + 5] = 255;
        assert_eq!(points(&fast9(&img, 20, false)), vec![(4, 4, 0), (5, 4, 0)]);
        assert!(fast9(&img, 20, true).is_empty());
    }

    #[test]
    fn small_or_malformed_images_give_nothing() {
        for (w, h) in [(0, 0), (1, 1), (6, 6), (6, 40), (40, 6), (7, 7)] {
            let img = dot(w.max(1), h.max(1), 0, 0, 0, 255);
            let img = plane(w, h, img.data[..(w * h) as usize].to_vec());
            assert!(fast9(&img, 0, true).is_empty());
        }
        // 7x7: only the centre is tested.
        assert_eq!(points(&fast9(&dot(7, 7, 0, 3, 3, 255), 20, true)), vec![(3, 3, 254)]);
        let short = plane(9, 9, vec![0; 10]);
        assert!(fast9(&short, 20, true).is_empty());
        assert_eq!(fast_score(&short, 4, 4, 20), 0);
        assert_eq!(fast_score(&dot(9, 9, 0, 4, 4, 255), 2, 4, 20), 0);
        assert_eq!(fast_score(&dot(9, 9, 0, 4, 4, 255), 4, 6, 20), 0);
        assert_eq!(fast_score(&dot(9, 9, 0, 4, 4, 255), u32::MAX, 4, 20), 0);
    }

    // ---- naive reference ----

    fn naive_circle(img: &Plane<u8>, x: usize, y: usize) -> [i32; 16] {
        let w = img.width as usize;
        std::array::from_fn(|k| {
            let (dx, dy) = OFFSETS[k];
            let (cx, cy) = (x as isize + dx, y as isize + dy);
            i32::from(img.data[cy as usize * w + cx as usize])
        })
    }

    /// The segment test: 9 contiguous circle pixels all brighter than v + t or
    /// all darker than v - t.
    fn naive_is_corner(img: &Plane<u8>, x: usize, y: usize, t: i32) -> bool {
        let v = i32::from(img.data[y * img.width as usize + x]);
        let c = naive_circle(img, x, y);
        (0..16).any(|s| {
            let arc = || (0..9).map(|m| c[(s + m) % 16]);
            arc().all(|p| p > v + t) || arc().all(|p| p < v - t)
        })
    }

    /// The largest threshold at which the pixel is still a corner.
    fn naive_score(img: &Plane<u8>, x: usize, y: usize, t: i32) -> i32 {
        let mut s = t;
        while s < 255 && naive_is_corner(img, x, y, s + 1) {
            s += 1;
        }
        s
    }

    /// Corners (x, y, score) of the plain definition, then non-max by the 8-neighbourhood.
    fn naive_fast9(img: &Plane<u8>, t: i32, nonmax: bool) -> Vec<(u32, u32, u32)> {
        let (w, h) = (img.width as usize, img.height as usize);
        if w < 7 || h < 7 {
            return Vec::new();
        }
        let t = t.clamp(0, 255);
        let mut score = vec![0i32; w * h];
        let mut found = Vec::new();
        for y in 3..h - 3 {
            for x in 3..w - 3 {
                if naive_is_corner(img, x, y, t) {
                    score[y * w + x] = naive_score(img, x, y, t);
                    found.push((x, y));
                }
            }
        }
        found
            .into_iter()
            .filter(|&(x, y)| {
                let s = score[y * w + x];
                !nonmax
                    || (-1..=1isize).all(|dy| {
                        (-1..=1isize).all(|dx| {
                            (dx, dy) == (0, 0) || s > score[(y as isize + dy) as usize * w + (x as isize + dx) as usize]
                        })
                    })
            })
            .map(|(x, y)| (x as u32, y as u32, if nonmax { score[y * w + x] as u32 } else { 0 }))
            .collect()
    }

    fn image_strategy() -> impl Strategy<Value = Plane<u8>> {
        (0u32..20, 0u32..20).prop_flat_map(|(w, h)| {
            let n = (w * h) as usize;
            let pixels = prop_oneof![
                // A few levels: many corners and ties.
                prop::collection::vec(prop::sample::select(vec![0u8, 30, 60, 128, 200, 255]), n),
                // Two levels: blobs and edges.
                prop::collection::vec(prop::sample::select(vec![40u8, 90]), n),
                prop::collection::vec(any::<u8>(), n),
            ];
            pixels.prop_map(move |data| plane(w, h, data))
        })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(512))]

        #[test]
        fn matches_naive_reference(img in image_strategy(), t in -5i32..80, nonmax in any::<bool>()) {
            prop_assert_eq!(points(&fast9(&img, t, nonmax)), naive_fast9(&img, t, nonmax));
        }

        #[test]
        fn score_is_largest_corner_threshold(img in image_strategy(), t in 0i32..80) {
            let (w, h) = (img.width as usize, img.height as usize);
            for y in 3..h.saturating_sub(3) {
                for x in 3..w.saturating_sub(3) {
                    if naive_is_corner(&img, x, y, t) {
                        prop_assert_eq!(fast_score(&img, x as u32, y as u32, t), naive_score(&img, x, y, t));
                    }
                }
            }
        }

        #[test]
        fn vector_quick_rejection_matches_scalar(w in 7usize..80, h in 7usize..10, t in 0u8..=255, seed in any::<u64>()) {
            // widths cross the 16- and 32-lane boundaries; levels near 0 and 255 test the saturation
            let mut s = seed;
            let data: Vec<u8> = (0..w * h).map(|_| {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                [0u8, 1, 254, 255, (s >> 40) as u8, (s >> 48) as u8][(s >> 61) as usize % 6]
            }).collect();
            let pixel = make_offsets(w);
            let mut out = vec![9u8; w - 6];
            for i in 3..h - 3 {
                quick_classes_row(&data, w, i, t, &mut out);
                for j in 3..w - 3 {
                    prop_assert_eq!(out[j - 3], quick_class(&data, i * w + j, &pixel, i32::from(t)), "row {} col {}", i, j);
                }
            }
        }
    }
}
