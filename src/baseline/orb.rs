//! ORB as OpenCV builds it (SPEC 12): FAST-9 on every pyramid level, the
//! border filter, the best `2 * quota` by FAST score, Harris ranking down to
//! the quota, then orientation and rBRIEF. Pyramid, orientation and
//! descriptor are the same as L-FAST's, so the comparison isolates the detector.

use super::fast::fast9;
use crate::config::Config;
use crate::cpu::select::{Corner, order};
use crate::cpu::{CpuDetector, pyramid, response};
use crate::error::Result;
use crate::image::GrayView;
use crate::keypoint::{Descriptor, KeyPoint};
use rayon::prelude::*;

/// ORB parameters, defaults as `cv2.ORB_create()`.
#[derive(Clone, Debug, PartialEq)]
pub struct OrbParams {
    /// Total keypoints wanted.
    pub n_features: u32,
    /// Pyramid scale.
    pub scale_factor: f64,
    /// Pyramid levels.
    pub n_levels: u32,
    /// Keypoints closer than this to a level's side are dropped.
    pub edge_threshold: u32,
    /// FAST threshold.
    pub fast_threshold: i32,
    /// Orientation bins of the descriptor (0 = continuous, as OpenCV).
    pub orientation_bins: u32,
}

impl Default for OrbParams {
    fn default() -> Self {
        Self {
            n_features: 500,
            scale_factor: 1.2,
            n_levels: 8,
            edge_threshold: 31,
            fast_threshold: 20,
            orientation_bins: 30,
        }
    }
}

/// OpenCV's per-level feature counts: a geometric series with ratio 1/scale,
/// rounded, the last level taking what is left.
///
/// ```
/// let q = lfast::baseline::orb::opencv_level_quotas(500, 1.2, 8);
/// assert_eq!(q.iter().sum::<u32>(), 500);
/// assert_eq!(q[0], 109);
/// ```
pub fn opencv_level_quotas(n: u32, scale: f64, levels: u32) -> Vec<u32> {
    let factor = 1.0 / scale;
    let mut per = n as f64 * (1.0 - factor) / (1.0 - factor.powi(levels as i32));
    let mut sum = 0u32;
    let mut q = Vec::with_capacity(levels as usize);
    for _ in 0..levels.saturating_sub(1) {
        let k = per.round() as u32;
        q.push(k);
        sum += k;
        per *= factor;
    }
    q.push(n.saturating_sub(sum));
    q
}

/// The ORB baseline detector.
#[derive(Clone, Debug)]
pub struct OrbDetector {
    params: OrbParams,
    inner: CpuDetector,
}

impl OrbDetector {
    /// Validates the pyramid and orientation parameters.
    pub fn new(params: OrbParams) -> Result<Self> {
        let cfg = Config {
            n_levels: params.n_levels,
            scale_factor: params.scale_factor,
            orientation_bins: params.orientation_bins,
            ..Config::default()
        };
        Ok(Self { inner: CpuDetector::new(cfg)?, params })
    }

    /// Keypoints and descriptors, in SPEC 9 order (response, level, y, x).
    pub fn detect_and_compute(&self, image: GrayView<'_>) -> Result<(Vec<KeyPoint>, Vec<Descriptor>)> {
        image.check()?;
        let p = &self.params;
        let sizes = self.inner.config().level_sizes(image.width(), image.height());
        let levels = pyramid::pyramid(&image.to_plane(), &sizes);
        let quotas = opencv_level_quotas(p.n_features, p.scale_factor, p.n_levels);
        let b = p.edge_threshold;
        let mut corners: Vec<Corner> = levels
            .par_iter()
            .enumerate()
            .flat_map_iter(|(l, img)| {
                let mut kps: Vec<KeyPoint> = fast9(img, p.fast_threshold, true)
                    .into_iter()
                    .filter(|k| {
                        let (x, y) = (k.pt.x as u32, k.pt.y as u32);
                        x >= b && y >= b && x + b < img.width && y + b < img.height
                    })
                    .collect();
                // retainBest(2 * quota) by FAST score, ties by position
                kps.sort_by(|a, c| {
                    c.response.total_cmp(&a.response).then(a.pt.y.total_cmp(&c.pt.y)).then(a.pt.x.total_cmp(&c.pt.x))
                });
                kps.truncate(2 * quotas[l] as usize);
                let mut cs: Vec<Corner> = kps
                    .iter()
                    .map(|k| {
                        let (x, y) = (k.pt.x as u32, k.pt.y as u32);
                        Corner {
                            level: l as u32,
                            x,
                            y,
                            response: response::harris(img, x, y),
                            sub: [0, 0],
                            fill: false,
                        }
                    })
                    .collect();
                cs.sort_by(order);
                cs.truncate(quotas[l] as usize);
                cs
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
    fn quotas_like_opencv() {
        // 500 * (1 - 1/1.2) / (1 - 1.2^-8) = 108.59, then * 1/1.2 per level, rounded;
        // the last level takes the remainder 500 - 469
        assert_eq!(opencv_level_quotas(500, 1.2, 8), vec![109, 90, 75, 63, 52, 44, 36, 31]);
        assert_eq!(opencv_level_quotas(10, 1.2, 1), vec![10]);
    }

    #[test]
    fn fills_the_budget_on_a_real_image() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/camera_cc0_v0.18plus.png");
        let img = crate::image::load_gray(path).unwrap();
        let orb = OrbDetector::new(OrbParams::default()).unwrap();
        let (kps, desc) = orb.detect_and_compute(img.view()).unwrap();
        assert_eq!(kps.len(), 500);
        assert_eq!(desc.len(), 500);
        let quotas = opencv_level_quotas(500, 1.2, 8);
        for (l, &q) in quotas.iter().enumerate() {
            let n = kps.iter().filter(|k| k.octave == l as i32).count();
            assert!(n <= q as usize, "level {l}: {n} > {q}");
        }
        for k in &kps {
            let s = 1.2f32.powi(k.octave);
            // OpenCV's convention: level pixel x at x * s; 31 pixels from every side
            assert!(k.pt.x / s >= 30.99 && k.pt.y / s >= 30.99, "{k:?}");
            assert!((0.0..360.0).contains(&k.angle));
            assert!((k.size - 31.0 * s).abs() < 1e-3);
        }
        assert!(kps.windows(2).all(|w| w[0].response >= w[1].response));
    }
}
