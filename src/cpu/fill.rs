//! Beyond the paper: the FAST fill (`Config::fill_fast_ini`,
//! `Config::fill_fast_min`; docs/algorithm.md, "Fill"). CPU only.
//!
//! L-FAST finds corners only on the improved Canny edge map, so a level of a
//! smooth or dark image can hold fewer of them than its share of
//! `n_features`. ORB-SLAM's extractor never runs short: its FAST threshold
//! drops in a cell that has no corner. With the fill on, such a level is
//! topped up with FAST-9 corners found as ORB-SLAM finds its own, cell by
//! cell with a lower threshold where the first finds nothing ([`fill_level`]:
//! cells without an L-FAST corner first, only as many cells as the shortfall
//! needs), each scored by the Harris response on the level's denoised image D
//! (as L-FAST corners are), and never within `nms_radius` of an L-FAST corner.
//! [`super::select`] keeps every L-FAST corner of a level before any fill corner.

use super::response;
use super::select::Corner;
use crate::baseline::fast::fast9;
use crate::baseline::orbslam::{FAST_MARGIN, cell_grid, crop};
use crate::image::Plane;

/// What [`fill_level`] needs of the configuration.
#[derive(Clone, Copy, Debug)]
pub struct FillParams {
    /// FAST threshold of the first try in each cell.
    pub ini: i32,
    /// FAST threshold of the retry in a cell where the first found nothing.
    pub min: i32,
    /// Corners keep this far (pixels) from every side of the level.
    pub border: u32,
    /// A fill corner keeps more than this far (Chebyshev) from every L-FAST corner.
    pub nms_radius: u32,
    /// Only corners of positive Harris response (`Config::reject_edges`).
    pub reject_edges: bool,
}

impl FillParams {
    /// The fill's parameters of `cfg`; `None` with the fill off.
    pub fn from_config(cfg: &crate::Config) -> Option<Self> {
        cfg.fills().then_some(Self {
            ini: cfg.fill_fast_ini as i32,
            min: cfg.fill_fast_min as i32,
            border: cfg.border,
            nms_radius: cfg.nms_radius,
            reject_edges: cfg.reject_edges,
        })
    }
}

/// The fill corners of level `level`, at least `want` where the level has
/// them: FAST-9 corners of `img` (the level image) cell by cell, with their
/// Harris response on `denoised` (the level's D), each inside the border and
/// the mask (nonzero = on), more than `nms_radius` from every corner of
/// `lfast` (the level's L-FAST corners) and, with `reject_edges`, of
/// positive response. Marked [`fill`](Corner::fill).
///
/// The cells ([`crate::baseline::orbslam::cells`] of the region inside the
/// border) are visited in a fixed order that spreads over the level
/// ([`spread_order`]): first those holding no L-FAST corner, then the others,
/// until `want` corners are found. A cell takes the FAST corners (with
/// non-maximum suppression) found at `ini` in its row of cells, or where
/// there are none, those found at `min`: ORB-SLAM's extractor retries a cell
/// the same way, running FAST cell by cell. Here FAST runs on a whole row of
/// cells the first time one of its cells needs it, so that its vector pass
/// has full rows to work on; it suppresses non-maxima across cell borders
/// within the row.
///
/// ```
/// use lfast::cpu::fill::{FillParams, fill_level};
/// use lfast::Plane;
/// // a 90x60 flat level with one bright pixel of contrast 12: below the
/// // first threshold, found by the retry
/// let img = Plane::from_vec(90, 60, (0..90 * 60).map(|i| if i == 30 * 90 + 45 { 112 } else { 100 }).collect()).unwrap();
/// let p = FillParams { ini: 20, min: 7, border: 16, nms_radius: 4, reject_edges: true };
/// let found = fill_level(&img, &img, 0, &[], None, &p, 10);
/// assert!(found.len() == 1 && found[0].fill && found[0].response > 0.0);
/// ```
pub fn fill_level(
    img: &Plane<u8>,
    denoised: &Plane<u8>,
    level: u32,
    lfast: &[Corner],
    mask: Option<&Plane<u8>>,
    p: &FillParams,
    want: usize,
) -> Vec<Corner> {
    let (w, h, b) = (img.width, img.height, p.border);
    if w <= 2 * b || h <= 2 * b || want == 0 {
        return Vec::new();
    }
    // pixels within nms_radius of an L-FAST corner, one bit each
    let r = p.nms_radius as i64;
    let words = (w as usize).div_ceil(64);
    let mut near = vec![0u64; words * h as usize];
    for c in lfast {
        let (x0, x1) = ((c.x as i64 - r).max(0) as usize, (c.x as i64 + r).min(w as i64 - 1) as usize);
        for y in (c.y as i64 - r).max(0) as usize..=(c.y as i64 + r).min(h as i64 - 1) as usize {
            for x in x0..=x1 {
                near[y * words + x / 64] |= 1 << (x % 64);
            }
        }
    }
    let keep = |x: u32, y: u32| {
        near[y as usize * words + x as usize / 64] >> (x % 64) & 1 == 0 && mask.is_none_or(|m| m.at(x, y) != 0)
    };
    let g = cell_grid(w - 2 * b, h - 2 * b);
    let n_cells = (g.cols * g.rows) as usize;
    let cell_of = |x: u32, y: u32| ((y - b) / g.ch * g.cols + (x - b) / g.cw) as usize;
    let mut occupied = vec![false; n_cells];
    for c in lfast.iter().filter(|c| c.x >= b && c.y >= b && c.x < w - b && c.y < h - b) {
        occupied[cell_of(c.x, c.y)] = true;
    }
    // FAST on a whole row of cells at a time (its AVX2 pass needs rows wider
    // than a cell), at most once per row and threshold
    let mut bands: [Vec<Option<Vec<[u32; 2]>>>; 2] = [vec![None; g.rows as usize], vec![None; g.rows as usize]];
    let order: Vec<usize> = spread_order(n_cells).collect();
    let visit = order.iter().filter(|&&i| !occupied[i]).chain(order.iter().filter(|&&i| occupied[i]));
    let mut out = Vec::new();
    for &i in visit {
        if out.len() >= want {
            break;
        }
        let (c, r) = (i as u32 % g.cols, i as u32 / g.cols);
        let (cx0, cx1) = (b + c * g.cw, (b + (c + 1) * g.cw).min(w - b));
        let mut in_cell = |t: usize| -> Vec<[u32; 2]> {
            let band = bands[t][r as usize].get_or_insert_with(|| {
                let (y0, y1) = (b + r * g.ch, (b + (r + 1) * g.ch).min(h - b));
                band_fast(img, y0, y1, [p.ini, p.min][t], b)
            });
            band.iter().copied().filter(|&[x, _]| (cx0..cx1).contains(&x)).collect()
        };
        let mut found = in_cell(0);
        if found.is_empty() {
            found = in_cell(1);
        }
        for [x, y] in found.into_iter().filter(|&[x, y]| keep(x, y)) {
            let response = response::harris(denoised, x, y);
            if !p.reject_edges || response > 0.0 {
                out.push(Corner { level, x, y, response, sub: [0, 0], fill: true });
            }
        }
    }
    out
}

/// FAST-9 corners (non-maximum suppression on) at `threshold` of the rows
/// `y0..y1` of `img`, read with the 3 rows above and below that its circle
/// needs, at columns `border..width - border`, in raster order.
fn band_fast(img: &Plane<u8>, y0: u32, y1: u32, threshold: i32, border: u32) -> Vec<[u32; 2]> {
    // border >= 7 > FAST_MARGIN: the margin rows exist
    let top = y0 - FAST_MARGIN;
    let rows = crop(img, 0, top, img.width, y1 + FAST_MARGIN);
    fast9(&rows, threshold, true)
        .iter()
        .map(|k| [k.pt.x as u32, top + k.pt.y as u32])
        .filter(|&[x, y]| (y0..y1).contains(&y) && x >= border && x < img.width - border)
        .collect()
}

/// The indices `0..n` in an order that spreads over them from the start: the
/// multiples of a stride near `n` times the golden ratio's fractional part
/// (0.618...), coprime with `n`, modulo `n`. Every index once.
///
/// ```
/// let v: Vec<usize> = lfast::cpu::fill::spread_order(10).collect();
/// assert_eq!(v, [0, 7, 4, 1, 8, 5, 2, 9, 6, 3]); // stride 7 (6 shares 2 with 10)
/// ```
pub fn spread_order(n: usize) -> impl Iterator<Item = usize> {
    fn gcd(a: usize, b: usize) -> usize {
        if b == 0 { a } else { gcd(b, a % b) }
    }
    let mut step = ((n as f64 * 0.618_033_988_749_895).round() as usize).max(1);
    while n > 1 && gcd(step, n) != 1 {
        step += 1;
    }
    (0..n).map(move |k| (k * step) % n.max(1))
}

#[cfg(test)]
mod tests {
    use super::*;

    const ALL: usize = usize::MAX;

    fn params() -> FillParams {
        FillParams { ini: 20, min: 7, border: 16, nms_radius: 4, reject_edges: true }
    }

    /// A flat 120x80 level with bright pixels of the given contrast (single
    /// pixels: FAST's non-maximum suppression drops every corner of a group
    /// of equal scores, as OpenCV's does).
    fn dots(spots: &[(u32, u32, u8)]) -> Plane<u8> {
        let mut img = Plane::from_vec(120, 80, vec![100u8; 120 * 80]).unwrap();
        for &(x, y, c) in spots {
            img.data[(y * 120 + x) as usize] = 100 + c;
        }
        img
    }

    #[test]
    fn finds_dots_away_from_l_fast_corners_inside_border_and_mask() {
        // the region inside the border (88x48) is two cells, x 16..60 and 60..104:
        // two dots of contrast 60 in the first, one of 12 (found by the retry) in the second
        let img = dots(&[(30, 40, 60), (50, 40, 60), (85, 40, 12)]);
        let all = fill_level(&img, &img, 2, &[], None, &params(), ALL);
        let at = |v: &[Corner], x: u32, y: u32| v.iter().any(|c| (c.x, c.y) == (x, y));
        assert!(at(&all, 30, 40) && at(&all, 50, 40) && at(&all, 85, 40) && all.len() == 3, "{all:?}");
        assert!(all.iter().all(|c| c.fill && c.level == 2 && c.sub == [0, 0] && c.response > 0.0));
        // the retry is per cell: a cell where the first threshold finds something keeps only that
        let mixed = dots(&[(30, 40, 60), (50, 40, 12)]);
        assert_eq!(fill_level(&mixed, &mixed, 0, &[], None, &params(), ALL).len(), 1);
        // an L-FAST corner at (33, 42) keeps the fill away from the first dot (Chebyshev distance 3 <= 4)
        let lf = Corner { level: 2, x: 33, y: 42, response: 1.0, sub: [0, 0], fill: false };
        let got = fill_level(&img, &img, 2, &[lf], None, &params(), ALL);
        assert!(!at(&got, 30, 40) && at(&got, 50, 40) && at(&got, 85, 40), "{got:?}");
        // a mask off over x >= 60
        let mask =
            Plane::from_vec(120, 80, (0..120 * 80).map(|i| if i % 120 < 60 { 255 } else { 0 }).collect()).unwrap();
        let got = fill_level(&img, &img, 2, &[], Some(&mask), &params(), ALL);
        assert!(at(&got, 30, 40) && at(&got, 50, 40) && !at(&got, 85, 40), "{got:?}");
        // a border of 35 leaves the dot at x = 85 (>= 120 - 35) out
        let wide = FillParams { border: 35, ..params() };
        let got = fill_level(&img, &img, 2, &[], None, &wide, ALL);
        assert!(!at(&got, 30, 40) && at(&got, 50, 40) && !at(&got, 85, 40), "{got:?}");
    }

    #[test]
    fn cells_without_l_fast_corners_come_first_and_the_search_stops_at_want() {
        let img = dots(&[(30, 40, 60), (85, 40, 60)]);
        // an L-FAST corner in the first cell, far from its dot
        let lf = Corner { level: 0, x: 20, y: 20, response: 1.0, sub: [0, 0], fill: false };
        let one = fill_level(&img, &img, 0, &[lf], None, &params(), 1);
        assert_eq!(one.iter().map(|c| (c.x, c.y)).collect::<Vec<_>>(), [(85, 40)]);
        let both = fill_level(&img, &img, 0, &[lf], None, &params(), 2);
        assert_eq!(both.len(), 2);
        assert!(fill_level(&img, &img, 0, &[lf], None, &params(), 0).is_empty());
    }

    #[test]
    fn spread_order_is_a_permutation() {
        for n in [0usize, 1, 2, 3, 10, 41, 492, 1000] {
            let mut v: Vec<usize> = spread_order(n).collect();
            v.sort_unstable();
            assert_eq!(v, (0..n).collect::<Vec<_>>(), "{n}");
        }
    }

    #[test]
    fn a_level_too_small_for_the_border_gets_nothing() {
        let img = Plane::from_vec(32, 32, vec![7u8; 32 * 32]).unwrap();
        assert!(fill_level(&img, &img, 0, &[], None, &params(), ALL).is_empty());
    }
}
