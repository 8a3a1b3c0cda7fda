//! The CPU reference path: one module per stage, named as its shader in
//! shaders/, and [`CpuDetector`], which chains them as SPEC says.
//!
//! Every stage is a plain function over [`Plane`]s, so a test can run any one
//! of them on the output of the previous stage (the GPU cross-check does
//! exactly that, stage by stage).

pub mod blur;
pub mod classify;
pub mod corner_nms;
pub mod fill;
pub mod fused;
pub mod gradient;
pub mod histogram;
pub mod hysteresis;
pub mod lfast;
pub mod local_threshold;
pub mod matcher;
pub mod median;
pub mod nms;
pub mod opencv;
pub mod orb;
pub mod orientation;
pub mod otsu;
pub mod pyramid;
pub mod response;
pub mod rules;
pub mod select;
pub(crate) mod simd;
pub mod snap;

use crate::config::{Config, DELTA_DEN, DescriptorKind};
use crate::error::{Error, Result};
use crate::image::{GrayView, Plane};
use crate::keypoint::{Descriptor, KeyPoint};
use crate::spec;
pub use crate::spec::mask::level_mask;
use gradient::Gradient;
use local_threshold::WindowGrid;
use orb::{Pattern, RotatedPatterns};
use rayon::prelude::*;
use select::Corner;

/// `class_id` of a keypoint of the FAST fill (`Config::fill_fast_ini`); an
/// L-FAST keypoint's is -1, as OpenCV's default.
pub const FILL_CLASS_ID: i32 = 1;

/// The improved Canny edge map of one image with every intermediate (SPEC 1-7).
#[derive(Clone, Debug)]
pub struct EdgeMap {
    /// D: the flagged-median output (SPEC 1).
    pub denoised: Plane<u8>,
    /// gx2, gy2, S and M (SPEC 2).
    pub gradient: Gradient,
    /// 1 where a pixel survives NMS (SPEC 3).
    pub nms: Plane<u8>,
    /// Histogram of M8 (SPEC 4).
    pub histogram: [u32; 256],
    /// Otsu's k; `None` when the histogram has a single non-empty bin (no edges).
    pub otsu_k: Option<u8>,
    /// The local-threshold windows and their statistics (SPEC 5).
    pub windows: WindowGrid,
    /// Classes of SPEC 6 ([`classify::NONE`] .. [`classify::STRONG`]).
    pub classes: Plane<u8>,
    /// Classes after rules 1 and 2 of SPEC 7.
    pub ruled: Plane<u8>,
    /// E: 255 on edges, 0 elsewhere (SPEC 7).
    pub edges: Plane<u8>,
}

impl EdgeMap {
    /// The edge map of an image without pixels.
    fn empty(w: u32, h: u32) -> Self {
        let grid = WindowGrid::default();
        let g = Gradient { gx2: Plane::new(w, h), gy2: Plane::new(w, h), s: Plane::new(w, h), m: Plane::new(w, h) };
        let e = Plane::new(w, h);
        EdgeMap {
            denoised: e.clone(),
            gradient: g,
            nms: e.clone(),
            histogram: [0; 256],
            otsu_k: None,
            windows: grid,
            classes: e.clone(),
            ruled: e.clone(),
            edges: e,
        }
    }

    /// T1 = k + 1, or `None` when the image has no edges.
    pub fn t1(&self) -> Option<u32> {
        self.otsu_k.map(|k| k as u32 + 1)
    }

    /// The gradient magnitude M.
    pub fn magnitude(&self) -> &Plane<u16> {
        &self.gradient.m
    }

    /// TL1 of each pixel's window, `(100 + alpha_pct) * V3 / 300` rounded down
    /// and capped at 255, as a picture of the local threshold.
    pub fn local_threshold_map(&self, alpha_pct: u32) -> Plane<u8> {
        let (w, h) = (self.edges.width, self.edges.height);
        let mut out = Plane::<u8>::new(w, h);
        for y in 0..h {
            for x in 0..w {
                out.data[(y * w + x) as usize] = ((100 + alpha_pct) * self.windows.v3_at(x, y) / 300).min(255) as u8;
            }
        }
        out
    }
}

/// Runs SPEC 1-7 on one image.
///
/// ```
/// // a bright square on black: its outline is the edge map
/// let mut img = lfast::Plane::<u8>::new(32, 32);
/// for y in 8..24 { for x in 8..24 { img.data[y * 32 + x] = 200; } }
/// let em = lfast::cpu::edge_map(&img, &lfast::Config::default());
/// assert!(em.edges.data.iter().any(|&v| v == 255));
/// assert_eq!(em.edges.at(16, 16), 0); // inside the flat square
/// ```
pub fn edge_map(img: &Plane<u8>, cfg: &Config) -> EdgeMap {
    edge_map_with(img, cfg.delta_num(), DELTA_DEN, cfg.alpha_pct)
}

/// [`edge_map`] with the two parameters it reads given directly.
pub fn edge_map_with(img: &Plane<u8>, delta_num: u32, delta_den: u32, alpha_pct: u32) -> EdgeMap {
    if img.is_empty() {
        return EdgeMap::empty(img.width, img.height);
    }
    let denoised = median::median(img, delta_num, delta_den);
    let gradient = gradient::gradient(&denoised);
    let nms = nms::nms(&gradient);
    let histogram = histogram::histogram(&gradient.m);
    let otsu_k = otsu::otsu(&histogram);
    let windows = local_threshold::local_threshold(&gradient.m);
    let classes = classify::classify(&gradient.m, &nms, otsu_k.map(|k| k as u32 + 1), &windows, alpha_pct);
    let ruled = rules::rules(&classes);
    let edges = hysteresis::hysteresis(&ruled);
    EdgeMap { denoised, gradient, nms, histogram, otsu_k, windows, classes, ruled, edges }
}

/// The L-FAST detector and ORB descriptor on the CPU.
///
/// ```
/// use lfast::{Config, cpu::CpuDetector};
/// let det = CpuDetector::new(Config::default()).unwrap();
/// let img = lfast::Plane::<u8>::new(64, 48);
/// let (kps, desc) = det.detect_and_compute(img.view(), None).unwrap();
/// assert!(kps.is_empty() && desc.is_empty()); // a flat image has no corners
/// ```
#[derive(Debug)]
pub struct CpuDetector {
    cfg: Config,
    pattern: &'static Pattern,
    rotated: Option<RotatedPatterns>,
    mask_radius: u32,
    /// Workspaces of earlier calls, reused so that a frame allocates nothing
    /// large (fresh buffers cost more in page faults than the passes).
    pool: std::sync::Mutex<Vec<Workspace>>,
}

impl Clone for CpuDetector {
    fn clone(&self) -> Self {
        Self {
            cfg: self.cfg.clone(),
            pattern: self.pattern,
            rotated: self.rotated.clone(),
            mask_radius: self.mask_radius,
            pool: Default::default(),
        }
    }
}

/// Per-frame buffers: pyramid levels, the fused edge path's D and E per level,
/// and the smoothed levels (in `detect_and_compute`, E's planes, borrowed).
#[derive(Debug, Default)]
struct Workspace {
    levels: Vec<Plane<u8>>,
    edges: Vec<fused::EdgeScratch>,
    smooth: Smoothing,
}

#[derive(Debug, Default)]
pub(crate) struct Smoothing {
    levels: Vec<Plane<u8>>,
}

impl CpuDetector {
    /// Validates `cfg` and prepares the rotated patterns.
    pub fn new(cfg: Config) -> Result<Self> {
        cfg.validate()?;
        let pattern = Pattern::orb();
        let rotated = (cfg.orientation_bins > 0).then(|| RotatedPatterns::new(pattern, cfg.orientation_bins));
        Ok(Self { cfg, pattern, rotated, mask_radius: spec::mask_radius(), pool: Default::default() })
    }

    /// The configuration.
    pub fn config(&self) -> &Config {
        &self.cfg
    }

    /// Distance kept between keypoints and the boundary of a mask, in level
    /// pixels ([`spec::mask_radius`]).
    pub fn mask_radius(&self) -> u32 {
        self.mask_radius
    }

    /// The improved Canny edge map E of `image` (255 = edge), by the fused
    /// fast path; identical to `edges(image)?.edges`.
    pub fn edge_image(&self, image: GrayView<'_>) -> Result<Plane<u8>> {
        let mut out = Plane::default();
        self.edge_image_into(image, &mut out)?;
        Ok(out)
    }

    /// [`edge_image`](Self::edge_image) into `out`, reusing its allocation:
    /// with the same `out` from frame to frame, nothing is allocated or copied
    /// (the input is read in place, the map is swapped with the workspace's).
    /// On an error `out` is left as it was.
    ///
    /// ```
    /// use lfast::{Config, Plane, cpu::CpuDetector};
    /// let det = CpuDetector::new(Config::default()).unwrap();
    /// let img = Plane::from_vec(64, 48, (0..64 * 48).map(|i| if i % 64 < 32 { 20 } else { 220 }).collect()).unwrap();
    /// let mut e = Plane::default();
    /// det.edge_image_into(img.view(), &mut e).unwrap();
    /// assert_eq!((e.width, e.height), (64, 48));
    /// assert!(e.data.iter().any(|&v| v == 255)); // the vertical step at x = 32
    /// ```
    pub fn edge_image_into(&self, image: GrayView<'_>, out: &mut Plane<u8>) -> Result<()> {
        image.check()?;
        self.with_workspace(|ws| {
            ws.edges.resize_with(1, Default::default);
            let sc = &mut ws.edges[0];
            fused::edges_fused_into(image, self.cfg.delta_num(), DELTA_DEN, self.cfg.alpha_pct, sc);
            std::mem::swap(&mut sc.edges, out);
        });
        Ok(())
    }

    /// The improved Canny edge map of `image` with all its intermediates (the
    /// staged path, for debugging and cross-checks; [`edge_image`](Self::edge_image) is faster).
    pub fn edges(&self, image: GrayView<'_>) -> Result<EdgeMap> {
        image.check()?;
        Ok(edge_map(&image.to_plane(), &self.cfg))
    }

    /// L-FAST keypoints of `image` (SPEC 1-10), with orientation, in SPEC 9 order.
    /// `mask`: any nonzero pixel is "on"; no keypoint lies within
    /// [`mask_radius`](Self::mask_radius) of an "off" pixel, at any level.
    pub fn detect(&self, image: GrayView<'_>, mask: Option<GrayView<'_>>) -> Result<Vec<KeyPoint>> {
        self.with_workspace(|ws| {
            let corners = self.find(image, mask, ws)?;
            Ok(corners.iter().map(|c| self.keypoint(&ws.levels, c, spec::LFAST_CENTRE).0).collect())
        })
    }

    /// Runs `f` with a workspace from the pool, and puts it back. `f` runs
    /// on a thread of the current rayon pool (the global one when called
    /// from outside any): from another thread, each of the frame's ~50
    /// parallel stages would otherwise be handed to the pool and waited for
    /// apart, a wake-up and a sleep each (4% of a KITTI frame in the kernel's
    /// scheduler); inside a pool it runs in place.
    fn with_workspace<R: Send>(&self, f: impl FnOnce(&mut Workspace) -> R + Send) -> R {
        let mut ws = self.pool.lock().map(|mut p| p.pop()).ok().flatten().unwrap_or_default();
        let r = rayon::scope(|_| f(&mut ws));
        if let Ok(mut p) = self.pool.lock() {
            p.push(ws);
        }
        r
    }

    /// Keypoints and their descriptors (SPEC 1-11); `desc[i]` belongs to `kps[i]`.
    pub fn detect_and_compute(
        &self,
        image: GrayView<'_>,
        mask: Option<GrayView<'_>>,
    ) -> Result<(Vec<KeyPoint>, Vec<Descriptor>)> {
        self.with_workspace(|ws| {
            let corners = self.find(image, mask, ws)?;
            Ok(self.describe_found(ws, &corners))
        })
    }

    /// [`detect_and_compute`](Self::detect_and_compute) with `image` used as
    /// the pyramid's level 0 for the call instead of copied into the
    /// workspace: the copy and a plane the size of the frame saved (1 byte
    /// per pixel, 8 MB at 3840x2160). `image` is handed back unchanged, also
    /// on an error.
    ///
    /// ```
    /// use lfast::{Config, Plane, cpu::CpuDetector};
    /// let det = CpuDetector::new(Config::default()).unwrap();
    /// let mut img = Plane::from_vec(96, 64, (0..96 * 64).map(|i| ((i * 7) % 251) as u8).collect()).unwrap();
    /// let copy = img.clone();
    /// let in_place = det.detect_and_compute_in(&mut img, None).unwrap();
    /// assert_eq!(in_place, det.detect_and_compute(copy.view(), None).unwrap());
    /// assert_eq!(img, copy);
    /// ```
    pub fn detect_and_compute_in(
        &self,
        image: &mut Plane<u8>,
        mask: Option<GrayView<'_>>,
    ) -> Result<(Vec<KeyPoint>, Vec<Descriptor>)> {
        image.view().check()?;
        self.with_workspace(|ws| {
            if ws.levels.is_empty() {
                ws.levels.push(Plane::default());
            }
            std::mem::swap(image, &mut ws.levels[0]);
            let r = self.find_from_level0(mask, ws).map(|corners| self.describe_found(ws, &corners));
            std::mem::swap(image, &mut ws.levels[0]);
            r
        })
    }

    /// The keypoints and descriptors of the corners `find` left in `ws`.
    fn describe_found(&self, ws: &mut Workspace, corners: &[Corner]) -> (Vec<KeyPoint>, Vec<Descriptor>) {
        if self.cfg.descriptor == DescriptorKind::Opencv {
            let kps: Vec<KeyPoint> =
                corners.iter().map(|c| self.keypoint(&ws.levels, c, spec::LFAST_CENTRE).0).collect();
            let desc = self.describe_opencv(&ws.levels[0], &kps);
            return (kps, desc);
        }
        // E is spent once the corners are found: its planes take the
        // smoothed levels, so that no third plane per level is kept
        // (docs/pipeline.md, "Memory")
        let Workspace { levels, edges, smooth } = ws;
        smooth.levels = edges.iter_mut().map(|e| std::mem::take(&mut e.edges)).collect();
        let out = self.describe_in(levels, corners, spec::LFAST_CENTRE, smooth);
        edges.iter_mut().zip(smooth.levels.drain(..)).for_each(|(e, p)| e.edges = p);
        out
    }

    /// Keypoints (SPEC 10, 11) and descriptors of corners found on `levels`.
    /// `centre` is where a pixel's position lies within it:
    /// [`spec::LFAST_CENTRE`] or [`spec::OPENCV_CENTRE`] ([`spec::keypoint_at`]).
    pub(crate) fn describe_corners(
        &self,
        levels: &[Plane<u8>],
        corners: &[Corner],
        centre: f64,
    ) -> (Vec<KeyPoint>, Vec<Descriptor>) {
        self.with_workspace(|ws| self.describe_in(levels, corners, centre, &mut ws.smooth))
    }

    /// [`describe_corners`](Self::describe_corners) with given smoothing buffers.
    fn describe_in(
        &self,
        levels: &[Plane<u8>],
        corners: &[Corner],
        centre: f64,
        smooth: &mut Smoothing,
    ) -> (Vec<KeyPoint>, Vec<Descriptor>) {
        let smoothed = smooth_used_levels(levels, corners.iter().map(|c| c.level), smooth);
        // In raster order per level, then back to SPEC 9's (response) order:
        // each keypoint reads ~31 rows of its level around it, which on a large
        // frame come from memory rather than cache unless the previous keypoint
        // read the same rows (same output: each keypoint is computed alone).
        // (by level and row, a counting sort: a comparison sort of the
        // indices was serial work between the parallel stages; the order
        // within a row does not matter)
        let mut row_start = vec![0u32; levels.len() + 1];
        for (l, p) in levels.iter().enumerate() {
            row_start[l + 1] = row_start[l] + p.height;
        }
        let row_of = |c: &Corner| {
            let l = c.level as usize;
            (row_start[l] + c.y.min(row_start[l + 1] - row_start[l])) as usize
        };
        let mut count = vec![0u32; row_start[levels.len()] as usize + 2];
        for c in corners {
            count[row_of(c) + 1] += 1;
        }
        for r in 1..count.len() {
            count[r] += count[r - 1];
        }
        let mut order = vec![0u32; corners.len()];
        for (i, c) in corners.iter().enumerate() {
            let slot = &mut count[row_of(c)];
            order[*slot as usize] = i as u32;
            *slot += 1;
        }
        let done: Vec<(KeyPoint, Descriptor)> = order
            .par_iter()
            .map(|&i| {
                let c = &corners[i as usize];
                let (kp, bin) = self.keypoint(levels, c, centre);
                (kp, self.describe(&smoothed[c.level as usize], c, kp.angle, bin))
            })
            .collect();
        // back to SPEC 9's order: `order` is a permutation, so each result
        // is fetched from its place (a sort of these 60-byte records was
        // serial work after the parallel description)
        let mut at = vec![0u32; order.len()];
        for (k, &i) in order.iter().enumerate() {
            at[i as usize] = k as u32;
        }
        at.iter().map(|&k| done[k as usize]).unzip()
    }

    /// Descriptors of `kps` on `base` as OpenCV 5's ORB `compute()` makes them
    /// (`descriptor = "opencv"`): its pyramid up to the highest octave, its
    /// blur, each keypoint's own angle. Unlike OpenCV, keypoints near the
    /// image border are kept, in order; their samples read the level's
    /// reflect-101 border as OpenCV's padded pyramid has it.
    fn describe_opencv(&self, base: &Plane<u8>, kps: &[KeyPoint]) -> Vec<Descriptor> {
        let top = kps.iter().map(|k| k.octave.max(0) as usize + 1).max().unwrap_or(0);
        let raw = opencv::pyramid(base, top, self.cfg.scale_factor);
        let mut used = vec![false; top];
        kps.iter().for_each(|k| used[k.octave.max(0) as usize] = true);
        let levels: Vec<Option<opencv::Level>> =
            raw.into_par_iter().zip(used).map(|(p, u)| u.then(|| opencv::Level::new(p))).collect();
        kps.par_iter()
            .map(|k| {
                let l = k.octave.max(0) as u32;
                let level = levels[l as usize].as_ref().expect("every used level is blurred");
                opencv::describe(level, k, opencv::level_scale(self.cfg.scale_factor, l), self.pattern)
            })
            .collect()
    }

    /// Descriptors of caller-supplied keypoints (from any detector). A keypoint
    /// is sampled at level `octave`, at pixel `floor(pt / s^octave + 1/32)`
    /// ([`spec::level_pixel`]),
    /// which is the intended pixel both for lfast's half-pixel convention and
    /// OpenCV's integer one. Orientation is recomputed from the image (the
    /// `angle` field is not read), so the result equals `detect_and_compute`'s.
    /// With `descriptor = "opencv"` the keypoint is described as OpenCV's ORB
    /// `compute()` does instead: its own `angle`, centre `cvRound(pt / s)`,
    /// and, unlike OpenCV, none dropped near the border.
    pub fn compute(&self, image: GrayView<'_>, keypoints: &[KeyPoint]) -> Result<Vec<Descriptor>> {
        image.check()?;
        let sizes = self.cfg.level_sizes(image.width(), image.height());
        let mut at = Vec::with_capacity(keypoints.len());
        for (index, kp) in keypoints.iter().enumerate() {
            let bad = |reason: String| Error::InvalidKeypoint { index, reason };
            if kp.octave < 0 || kp.octave as u32 >= self.cfg.n_levels {
                return Err(bad(format!("octave {} is outside 0..{}", kp.octave, self.cfg.n_levels)));
            }
            if !kp.pt.x.is_finite() || !kp.pt.y.is_finite() {
                return Err(bad(format!("position ({}, {}) is not finite", kp.pt.x, kp.pt.y)));
            }
            let l = kp.octave as u32;
            let s = self.cfg.level_scale(l);
            let (x, y) = (spec::level_pixel(kp.pt.x, s), spec::level_pixel(kp.pt.y, s));
            let (w, h) = sizes[l as usize];
            if x < 0.0 || y < 0.0 || x >= w as f64 || y >= h as f64 {
                return Err(bad(format!("position ({}, {}) is outside level {l} ({w}x{h})", kp.pt.x, kp.pt.y)));
            }
            // with a snap, the 1/16-px offset from the pixel as detection reports it
            let sub = if self.cfg.snap() > 0 {
                [spec::level_subpixel(kp.pt.x, s, x), spec::level_subpixel(kp.pt.y, s, y)]
            } else {
                [0, 0]
            };
            at.push(Corner { level: l, x: x as u32, y: y as u32, response: kp.response, sub, fill: false });
        }
        if self.cfg.descriptor == DescriptorKind::Opencv {
            return Ok(self.describe_opencv(&image.to_plane(), keypoints));
        }
        let top = at.iter().map(|c| c.level + 1).max().unwrap_or(1) as usize;
        Ok(self.with_workspace(|ws| {
            ws.levels.resize_with(1, Default::default);
            image.par_copy_into(&mut ws.levels[0]);
            pyramid::build_levels(&sizes[..top], &mut ws.levels);
            let levels = &ws.levels;
            let smoothed = smooth_used_levels(levels, at.iter().map(|c| c.level), &mut ws.smooth);
            at.par_iter()
                .map(|c| {
                    let (kp, bin) = self.keypoint(levels, c, spec::LFAST_CENTRE);
                    self.describe(&smoothed[c.level as usize], c, kp.angle, bin)
                })
                .collect()
        }))
    }

    /// SPEC 1-9 on every level: the pyramid and the selected corners in SPEC 9 order.
    fn find(&self, image: GrayView<'_>, mask: Option<GrayView<'_>>, ws: &mut Workspace) -> Result<Vec<Corner>> {
        image.check()?;
        check_mask(mask, image.width(), image.height())?;
        if ws.levels.is_empty() {
            ws.levels.push(Plane::default());
        }
        image.par_copy_into(&mut ws.levels[0]);
        self.find_from_level0(mask, ws)
    }

    /// [`find`](Self::find) on the image already in `ws.levels[0]`.
    fn find_from_level0(&self, mask: Option<GrayView<'_>>, ws: &mut Workspace) -> Result<Vec<Corner>> {
        let (width, height) = (ws.levels[0].width, ws.levels[0].height);
        check_mask(mask, width, height)?;
        let sizes = self.cfg.level_sizes(width, height);
        let n = sizes.len();
        ws.levels.resize_with(n, Default::default);
        ws.levels.truncate(n);
        ws.edges.resize_with(n, Default::default);
        let masks: Option<Vec<Plane<u8>>> = mask.map(|m| {
            let m = m.to_plane();
            sizes.par_iter().map(|&(w, h)| level_mask(&m, w, h, self.mask_radius)).collect()
        });
        let params = lfast::LfastParams::from_config(&self.cfg);
        let level_corners = |l: usize, img: &Plane<u8>, em: &mut fused::EdgeScratch| -> Vec<Corner> {
            let b = params.border;
            if img.width <= 2 * b || img.height <= 2 * b {
                return Vec::new();
            }
            fused::edges_fused_into(img.view(), self.cfg.delta_num(), DELTA_DEN, self.cfg.alpha_pct, em);
            let cands = lfast::lfast(&em.edges, masks.as_ref().map(|m| &m[l]), &params);
            let resp = response::responses(&em.denoised, &cands);
            let mut kept: Vec<Corner> =
                corner_nms::survivors(&cands, &resp, self.cfg.nms_radius, self.cfg.reject_edges)
                    .into_iter()
                    .map(|i| Corner {
                        level: l as u32,
                        x: cands[i][0],
                        y: cands[i][1],
                        response: resp[i],
                        sub: [0, 0],
                        fill: false,
                    })
                    .collect();
            if self.cfg.snap() > 0 {
                let m = masks.as_ref().map(|m| &m[l]);
                snap::snap_all(&em.denoised, m, &mut kept, self.cfg.snap(), params.border);
            }
            kept
        };
        // Level 0 needs no resizing: detect on it while levels 1.. are built
        // (each from the one before) and then detected on.
        let (head, rest) = ws.levels.split_at_mut(1);
        let (em0, em_rest) = ws.edges.split_at_mut(1);
        let base = &head[0];
        let (first, others) = rayon::join(
            || level_corners(0, base, &mut em0[0]),
            || {
                pyramid::build_levels_from(base, &sizes, rest);
                rest.par_iter()
                    .zip(em_rest.par_iter_mut())
                    .enumerate()
                    .map(|(i, (img, em))| level_corners(i + 1, img, em))
                    .collect::<Vec<_>>()
            },
        );
        let mut per_level: Vec<Vec<Corner>> = std::iter::once(first).chain(others).collect();
        let found: usize = per_level.iter().map(Vec::len).sum();
        if let Some(fp) = fill::FillParams::from_config(&self.cfg).filter(|_| found < self.cfg.n_features as usize) {
            // fewer L-FAST corners than the cap: levels short of their quota
            // take FAST corners (docs/algorithm.md, "Fill")
            let quotas = select::level_quotas(self.cfg.n_features, &sizes);
            let (levels, edges) = (&ws.levels, &ws.edges);
            per_level.par_iter_mut().enumerate().for_each(|(l, cs)| {
                let img = &levels[l];
                // D of this frame exists where level_corners ran (wider and taller than twice the border)
                let short = (quotas[l] as usize).saturating_sub(cs.len());
                if short > 0 && img.width > 2 * params.border && img.height > 2 * params.border {
                    let m = masks.as_ref().map(|m| &m[l]);
                    // twice the shortfall, so that the quadtree has a choice
                    let extra = fill::fill_level(img, &edges[l].denoised, l as u32, cs, m, &fp, 2 * short);
                    cs.extend(extra);
                }
            });
        }
        Ok(select::select(per_level, &sizes, self.cfg.n_features, self.cfg.distribution))
    }

    /// The keypoint of a corner (SPEC 10) with its angle, and its orientation bin.
    fn keypoint(&self, levels: &[Plane<u8>], c: &Corner, centre: f64) -> (KeyPoint, u32) {
        let s = self.cfg.level_scale(c.level);
        let (m10, m01) = orientation::moments(&levels[c.level as usize], c.x, c.y);
        let bin = self.rotated.as_ref().map_or(0, |r| r.bins.bin_of(m10, m01));
        let kp =
            spec::keypoint_at_sub(c.level, [c.x, c.y], c.sub, s, centre, orientation::angle_deg(m10, m01), c.response);
        // the fill's FAST corners are told apart by their class (docs/algorithm.md, "Fill")
        (KeyPoint { class_id: if c.fill { FILL_CLASS_ID } else { kp.class_id }, ..kp }, bin)
    }

    /// The descriptor of corner `c` (SPEC 11): with a snap, at its sub-pixel
    /// position (`orb::describe_fine`; docs/algorithm.md), else at its pixel.
    fn describe(&self, smoothed: &Plane<u8>, c: &Corner, angle: f32, bin: u32) -> Descriptor {
        match &self.rotated {
            Some(r) if self.cfg.snap() > 0 => {
                let b = bin as usize;
                orb::describe_fine_within(smoothed, c.x, c.y, c.sub, &r.fine[b], r.fine_reach[b])
            }
            Some(r) => orb::describe(smoothed, c.x, c.y, &r.tables[bin as usize]),
            None => orb::describe_continuous(smoothed, c.x, c.y, angle, self.pattern),
        }
    }
}

/// A mask, if any, is a valid plane of the image's size.
fn check_mask(mask: Option<GrayView<'_>>, width: u32, height: u32) -> Result<()> {
    let Some(m) = mask else { return Ok(()) };
    m.check()?;
    if (m.width(), m.height()) != (width, height) {
        return Err(Error::MaskSize { mask_width: m.width(), mask_height: m.height(), width, height });
    }
    Ok(())
}

/// The 7x7 sigma-2 blur of each level some corner uses (others are left stale).
fn smooth_used_levels<'a>(
    levels: &[Plane<u8>],
    used: impl Iterator<Item = u32>,
    sm: &'a mut Smoothing,
) -> &'a [Plane<u8>] {
    let mut need = vec![false; levels.len()];
    used.for_each(|l| need[l as usize] = true);
    sm.levels.resize_with(levels.len(), Default::default);
    levels.par_iter().zip(need).zip(sm.levels.par_iter_mut()).for_each(|((lv, n), out)| {
        if n {
            blur::gaussian_blur_into(lv, &blur::ORB_KERNEL, out);
        }
    });
    &sm.levels[..levels.len()]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_image_used_in_place_comes_back_unchanged_also_on_an_error() {
        let det = CpuDetector::new(Config::default()).unwrap();
        let mut img = Plane::from_vec(80, 70, (0..80 * 70).map(|i| (i * 13 % 256) as u8).collect()).unwrap();
        let copy = img.clone();
        let m = Plane::<u8>::new(79, 70);
        let e = det.detect_and_compute_in(&mut img, Some(m.view())).unwrap_err();
        assert!(matches!(e, Error::MaskSize { mask_width: 79, .. }), "{e}");
        assert_eq!(img, copy);
        // and the workspace it went through still works, in place or copied
        let in_place = det.detect_and_compute_in(&mut img, None).unwrap();
        assert_eq!(in_place, det.detect_and_compute(copy.view(), None).unwrap());
        assert_eq!(img, copy);
    }

    #[test]
    fn mask_size_mismatch_is_an_error() {
        let det = CpuDetector::new(Config::default()).unwrap();
        let img = Plane::<u8>::new(64, 64);
        let m = Plane::<u8>::new(63, 64);
        let e = det.detect(img.view(), Some(m.view())).unwrap_err();
        assert!(matches!(e, Error::MaskSize { mask_width: 63, .. }), "{e}");
    }

    #[test]
    fn compute_rejects_bad_keypoints() {
        let det = CpuDetector::new(Config::default()).unwrap();
        let img = Plane::<u8>::new(64, 64);
        let mut kp = KeyPoint::new(10.0, 10.0, 31.0);
        kp.octave = 9;
        assert!(det.compute(img.view(), &[kp]).unwrap_err().to_string().contains("keypoint 0: octave 9"));
        let kp = KeyPoint::new(64.5, 10.0, 31.0);
        assert!(
            det.compute(img.view(), &[KeyPoint::new(1.0, 1.0, 7.0), kp])
                .unwrap_err()
                .to_string()
                .contains("keypoint 1")
        );
        let kp = KeyPoint::new(f32::NAN, 10.0, 31.0);
        assert!(det.compute(img.view(), &[kp]).is_err());
    }
}
