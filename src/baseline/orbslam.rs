//! The keypoint selection of ORB-SLAM2/3's extractor, the paper's comparator,
//! written from its published description (Mur-Artal et al., ORB-SLAM, IEEE
//! T-RO 2015, section III-A and the ORB-SLAM3 documentation), not from its source:
//!
//! - the same pyramid as ORB (scale 1.2, 8 levels, bilinear), and per-level
//!   quotas in the geometric series of ratio 1/scale ([`opencv_level_quotas`]);
//! - on each level, the region 16 px in from every side is cut into square
//!   cells of about [`CELL`] px; FAST-9 with non-maximum suppression runs on
//!   each cell (plus the 3-px margin its circle reads) at [`INI_TH_FAST`], and
//!   again at [`MIN_TH_FAST`] in a cell where it found nothing, so that
//!   low-contrast regions still contribute;
//! - the level's keypoints are spread over the region by the quadtree
//!   ([`distribute_quadtree`]) down to the level's quota, keeping the
//!   strongest FAST score of each node;
//! - orientation by the continuous intensity centroid, descriptors on the 7x7
//!   sigma-2 Gaussian-blurred level (SPEC 11 with `orientation_bins = 0`).
//!
//! Keypoints use OpenCV's integer position convention (`pt = x * s^l`) and
//! report the FAST score as `response`.

use super::fast::fast9;
use super::orb::opencv_level_quotas;
use crate::config::Config;
use crate::cpu::select::{Corner, distribute_quadtree, order};
use crate::cpu::{CpuDetector, pyramid};
use crate::error::Result;
use crate::image::{GrayView, Plane};
use crate::keypoint::{Descriptor, KeyPoint};
use rayon::prelude::*;

/// Side of a cell, pixels (the cells of a level are this size or a little larger).
pub const CELL: u32 = 30;
/// FAST threshold tried first in every cell.
pub const INI_TH_FAST: i32 = 20;
/// FAST threshold of the retry in a cell where the first found nothing.
pub const MIN_TH_FAST: i32 = 7;
/// Keypoints lie at least this far from every side of their level.
pub const MIN_BORDER: u32 = 16;
/// Pixels the FAST circle reads beyond a candidate.
pub const FAST_MARGIN: u32 = 3;

/// Parameters of the ORB-SLAM extractor (defaults as ORB-SLAM2/3's settings files).
#[derive(Clone, Debug, PartialEq)]
pub struct OrbSlamParams {
    /// Total keypoints wanted.
    pub n_features: u32,
    /// Pyramid scale.
    pub scale_factor: f64,
    /// Pyramid levels.
    pub n_levels: u32,
    /// FAST threshold of the first try in each cell.
    pub ini_th_fast: i32,
    /// FAST threshold of the retry.
    pub min_th_fast: i32,
}

impl Default for OrbSlamParams {
    fn default() -> Self {
        Self { n_features: 1000, scale_factor: 1.2, n_levels: 8, ini_th_fast: INI_TH_FAST, min_th_fast: MIN_TH_FAST }
    }
}

/// The cells of a region `[0, w) x [0, h)`: `max(1, w / CELL)` columns of
/// width `ceil(w / cols)` (likewise rows), as `(x0, y0, x1, y1)`, clipped to
/// the region; empty cells are left out.
///
/// ```
/// let cells = lfast::baseline::orbslam::cells(95, 40);
/// // 3 columns of 32 px (the last 31), 1 row of 40
/// assert_eq!(cells, vec![(0, 0, 32, 40), (32, 0, 64, 40), (64, 0, 95, 40)]);
/// ```
pub fn cells(w: u32, h: u32) -> Vec<(u32, u32, u32, u32)> {
    let CellGrid { cols, rows, cw, ch } = cell_grid(w, h);
    let mut out = Vec::with_capacity((cols * rows) as usize);
    for r in 0..rows {
        for c in 0..cols {
            let (x0, y0) = (c * cw, r * ch);
            let (x1, y1) = ((x0 + cw).min(w), (y0 + ch).min(h));
            if x0 < x1 && y0 < y1 {
                out.push((x0, y0, x1, y1));
            }
        }
    }
    out
}

/// The cells of [`cells`]: `cols` x `rows` of `cw` x `ch` pixels (the last
/// column and row clipped to the region).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CellGrid {
    /// Columns, >= 1.
    pub cols: u32,
    /// Rows, >= 1.
    pub rows: u32,
    /// Width of a cell.
    pub cw: u32,
    /// Height of a cell.
    pub ch: u32,
}

/// The grid of [`cells`] over a region `[0, w) x [0, h)` (`w, h >= 1`).
pub fn cell_grid(w: u32, h: u32) -> CellGrid {
    let cols = (w / CELL).max(1);
    let rows = (h / CELL).max(1);
    CellGrid { cols, rows, cw: w.div_ceil(cols), ch: h.div_ceil(rows) }
}

/// A copy of `img`'s rectangle `[x0, x1) x [y0, y1)`.
pub fn crop(img: &Plane<u8>, x0: u32, y0: u32, x1: u32, y1: u32) -> Plane<u8> {
    let (w, h) = (x1 - x0, y1 - y0);
    let mut data = Vec::with_capacity((w * h) as usize);
    for y in y0..y1 {
        data.extend_from_slice(&img.row(y)[x0 as usize..x1 as usize]);
    }
    Plane::from_vec(w, h, data).expect("the crop's size matches its data")
}

/// FAST corners of one level, cell by cell with the threshold retry, in level
/// coordinates, with the FAST score as response. Every corner lies inside
/// `[MIN_BORDER, w - MIN_BORDER)` in both directions.
pub fn level_fast(img: &Plane<u8>, level: u32, ini: i32, min: i32) -> Vec<Corner> {
    let (w, h) = (img.width, img.height);
    if w <= 2 * MIN_BORDER || h <= 2 * MIN_BORDER {
        return Vec::new();
    }
    let (rw, rh) = (w - 2 * MIN_BORDER, h - 2 * MIN_BORDER);
    let mut out = Vec::new();
    for (cx0, cy0, cx1, cy1) in cells(rw, rh) {
        // the cell in level coordinates, with the margin the FAST circle reads
        let (x0, y0) = (MIN_BORDER + cx0 - FAST_MARGIN, MIN_BORDER + cy0 - FAST_MARGIN);
        let (x1, y1) = (MIN_BORDER + cx1 + FAST_MARGIN, MIN_BORDER + cy1 + FAST_MARGIN);
        let roi = crop(img, x0, y0, x1, y1);
        let mut kps = fast9(&roi, ini, true);
        if kps.is_empty() {
            kps = fast9(&roi, min, true);
        }
        out.extend(kps.into_iter().map(|k| Corner {
            level,
            x: x0 + k.pt.x as u32,
            y: y0 + k.pt.y as u32,
            response: k.response,
            sub: [0, 0],
            fill: false,
        }));
    }
    out
}

/// The ORB-SLAM baseline detector.
#[derive(Clone, Debug)]
pub struct OrbSlamDetector {
    params: OrbSlamParams,
    inner: CpuDetector,
}

impl OrbSlamDetector {
    /// Validates the pyramid parameters.
    pub fn new(params: OrbSlamParams) -> Result<Self> {
        let cfg = Config {
            n_levels: params.n_levels,
            scale_factor: params.scale_factor,
            orientation_bins: 0,
            ..Config::default()
        };
        Ok(Self { inner: CpuDetector::new(cfg)?, params })
    }

    /// The parameters.
    pub fn params(&self) -> &OrbSlamParams {
        &self.params
    }

    /// Keypoints and descriptors, in SPEC 9 order (response, level, y, x).
    pub fn detect_and_compute(&self, image: GrayView<'_>) -> Result<(Vec<KeyPoint>, Vec<Descriptor>)> {
        image.check()?;
        let p = &self.params;
        let sizes = self.inner.config().level_sizes(image.width(), image.height());
        let levels = pyramid::pyramid(&image.to_plane(), &sizes);
        let quotas = opencv_level_quotas(p.n_features, p.scale_factor, p.n_levels);
        let mut corners: Vec<Corner> = levels
            .par_iter()
            .enumerate()
            .flat_map_iter(|(l, img)| {
                let found = level_fast(img, l as u32, p.ini_th_fast, p.min_th_fast);
                if found.is_empty() {
                    return Vec::new();
                }
                // the quadtree works in region coordinates
                let shifted: Vec<Corner> =
                    found.iter().map(|c| Corner { x: c.x - MIN_BORDER, y: c.y - MIN_BORDER, ..*c }).collect();
                let (rw, rh) = (img.width - 2 * MIN_BORDER, img.height - 2 * MIN_BORDER);
                distribute_quadtree(&shifted, rw, rh, quotas[l] as usize)
                    .into_iter()
                    .map(|c| Corner { x: c.x + MIN_BORDER, y: c.y + MIN_BORDER, ..c })
                    .collect()
            })
            .collect();
        corners.sort_by(order);
        Ok(self.inner.describe_corners(&levels, &corners, crate::spec::OPENCV_CENTRE))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cells_cover_the_region_once() {
        for (w, h) in [(1, 1), (29, 31), (60, 60), (1209, 344), (95, 40)] {
            let cs = cells(w, h);
            let area: u32 = cs.iter().map(|&(x0, y0, x1, y1)| (x1 - x0) * (y1 - y0)).sum();
            assert_eq!(area, w * h, "{w}x{h}");
            assert!(cs.iter().all(|&(x0, y0, x1, y1)| x1 - x0 <= 2 * CELL && y1 - y0 <= 2 * CELL));
        }
    }

    #[test]
    fn retry_finds_low_contrast_corners() {
        // bright dots of contrast 12 (below 20, above 7) on a flat image, and one
        // of contrast 60 in another cell
        let mut img = Plane::<u8>::new(100, 80);
        img.data.fill(100);
        for (x, y) in [(25, 30), (40, 50), (50, 33)] {
            img.data[y * 100 + x] = 112;
        }
        img.data[40 * 100 + 75] = 160;
        assert_eq!(fast9(&img, INI_TH_FAST, true).len(), 1);
        // region 68 x 48: two cells, [16, 50) and [50, 84) in x; the left one
        // retries at 7 and finds its dots, the right one keeps its strong dot
        // and not the weak one at (50, 33)
        assert_eq!(cells(68, 48).len(), 2);
        let mut got: Vec<(u32, u32, f32)> =
            level_fast(&img, 0, INI_TH_FAST, MIN_TH_FAST).iter().map(|c| (c.x, c.y, c.response)).collect();
        got.sort_by_key(|&(x, y, _)| (x, y));
        let pos: Vec<(u32, u32)> = got.iter().map(|&(x, y, _)| (x, y)).collect();
        assert_eq!(pos, vec![(25, 30), (40, 50), (75, 40)]);
        assert!(got[0].2 >= MIN_TH_FAST as f32 && got[0].2 < INI_TH_FAST as f32, "{got:?}");
    }

    #[test]
    fn quotas_and_spread_on_a_real_image() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/camera_cc0_v0.18plus.png");
        let img = crate::image::load_gray(path).unwrap();
        let det = OrbSlamDetector::new(OrbSlamParams { n_features: 500, ..Default::default() }).unwrap();
        let (kps, desc) = det.detect_and_compute(img.view()).unwrap();
        assert_eq!(kps.len(), desc.len());
        assert!(kps.len() > 250 && kps.len() <= 500, "{}", kps.len());
        let quotas = opencv_level_quotas(500, 1.2, 8);
        for (l, &q) in quotas.iter().enumerate() {
            assert!(kps.iter().filter(|k| k.octave == l as i32).count() <= q as usize);
        }
        assert!(kps.windows(2).all(|w| w[0].response >= w[1].response));
        // spread: no 30x30 level-0 cell holds more than a few of the level-0 keypoints
        let mut per_cell = std::collections::HashMap::new();
        for k in kps.iter().filter(|k| k.octave == 0) {
            *per_cell.entry((k.pt.x as u32 / 30, k.pt.y as u32 / 30)).or_insert(0) += 1;
        }
        assert!(per_cell.values().all(|&n| n <= 8), "{per_cell:?}");
        // continuous angles, not binned
        let distinct: std::collections::HashSet<u32> = kps.iter().map(|k| k.angle.to_bits()).collect();
        assert!(distinct.len() > 60, "{}", distinct.len());
    }
}
