//! SPEC 11 orientation geometry shared by both paths: the radius-15 disc
//! (OpenCV ORB's `umax`), the keypoint angle from the integer moments, and the
//! quantisation of a direction into `orientation_bins` by integer tests.
//! The moments themselves are computed by src/cpu/orientation.rs and
//! shaders/orientation.wgsl.

/// Radius of the orientation disc (ORB's half patch size).
pub const HALF_PATCH: i32 = 15;

/// OpenCV ORB's `umax`: the half-width of row `v` of the radius-15 disc.
pub const UMAX: [i32; 16] = [15, 15, 15, 15, 14, 14, 14, 13, 13, 12, 11, 10, 9, 8, 6, 3];

/// Computes `umax` the way OpenCV does (for the test that checks [`UMAX`]).
pub fn compute_umax(half: i32) -> Vec<i32> {
    let h = half as usize;
    let mut umax = vec![0i32; h + 2];
    let s2 = std::f32::consts::SQRT_2;
    let vmax = (half as f32 * s2 / 2.0 + 1.0).floor() as usize;
    let vmin = (half as f32 * s2 / 2.0).ceil() as usize;
    for v in 0..=vmax {
        umax[v] = (((half * half) as f64 - (v * v) as f64).sqrt()).round_ties_even() as i32;
    }
    let mut v0 = 0usize;
    let mut v = h;
    while v >= vmin {
        while umax[v0] == umax[v0 + 1] {
            v0 += 1;
        }
        umax[v] = v0 as i32;
        v0 += 1;
        v -= 1;
    }
    umax.truncate(h + 1);
    umax
}

/// `atan2(m01, m10)` in degrees, in [0, 360) (KeyPoint.angle).
///
/// ```
/// use lfast::spec::angle::angle_deg;
/// assert_eq!(angle_deg(10, 0), 0.0);
/// assert_eq!(angle_deg(0, 10), 90.0);
/// assert_eq!(angle_deg(0, -10), 270.0);
/// ```
pub fn angle_deg(m10: i32, m01: i32) -> f32 {
    let a = (m01 as f64).atan2(m10 as f64).to_degrees();
    let a = if a < 0.0 { a + 360.0 } else { a };
    let a = a as f32;
    if a >= 360.0 { 0.0 } else { a }
}

/// Quantises the direction `(m10, m01)` into `bins` equal sectors centred on
/// `b * 360/bins` degrees, with integer tests only: each sector boundary is a
/// direction vector in Q8 (`round(256 * (cos, sin))`), and a direction is
/// at or past a boundary by a half-plane test and a cross product. Products
/// stay under 2^30 for moments under 2^21, so they fit i32 on the GPU.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AngleBins {
    bounds: Vec<(i32, i32)>,
}

/// 0 for directions in [0°, 180°), 1 for [180°, 360°); (0, 0) counts as 0°.
#[inline]
fn half(x: i32, y: i32) -> u32 {
    if y > 0 || (y == 0 && x >= 0) { 0 } else { 1 }
}

/// True iff the angle of `v` is >= the angle of `b` (both in [0, 360)).
#[inline]
fn at_or_past(b: (i32, i32), v: (i32, i32)) -> bool {
    let (hb, hv) = (half(b.0, b.1), half(v.0, v.1));
    hb < hv || (hb == hv && b.0 * v.1 - b.1 * v.0 >= 0)
}

impl AngleBins {
    /// Boundaries at `(b + 0.5) * 360/bins` degrees for `b = 0..bins`.
    pub fn new(bins: u32) -> Self {
        let bounds = (0..bins.max(1))
            .map(|b| {
                let a = (b as f64 + 0.5) * std::f64::consts::TAU / bins.max(1) as f64;
                ((a.cos() * 256.0).round() as i32, (a.sin() * 256.0).round() as i32)
            })
            .collect();
        Self { bounds }
    }

    /// The sector boundaries in Q8, `(cos, sin) * 256` rounded (the GPU's table).
    pub fn bounds(&self) -> &[(i32, i32)] {
        &self.bounds
    }

    /// Number of bins.
    pub fn len(&self) -> usize {
        self.bounds.len()
    }

    /// Never true (there is at least one bin).
    pub fn is_empty(&self) -> bool {
        self.bounds.is_empty()
    }

    /// The bin of direction `(m10, m01)`: how many boundaries it is at or past, mod bins.
    ///
    /// ```
    /// let bins = lfast::spec::angle::AngleBins::new(30);
    /// assert_eq!(bins.bin_of(100, 0), 0);    // 0°
    /// assert_eq!(bins.bin_of(0, 100), 8);    // 90° lies on the boundary of bins 7 and 8: the upper wins
    /// assert_eq!(bins.bin_of(100, -1), 0);   // just under 360° wraps to bin 0
    /// ```
    pub fn bin_of(&self, m10: i32, m01: i32) -> u32 {
        if (m10, m01) == (0, 0) {
            return 0; // no direction: angle 0, as atan2(0, 0)
        }
        // The boundaries ascend strictly in angle (tested for every bin count
        // allowed), so those the direction is at or past are a prefix: a binary
        // search counts them, as shaders/orientation.wgsl `bin_of` does.
        let n = self.bounds.partition_point(|&b| at_or_past(b, (m10, m01)));
        (n % self.bounds.len()) as u32
    }

    /// Centre angle of bin `b` in radians.
    pub fn centre(&self, b: u32) -> f64 {
        b as f64 * std::f64::consts::TAU / self.bounds.len() as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// shaders/orientation.wgsl counts the boundaries a direction is at or
    /// past by binary search, which equals the count only if they ascend
    /// strictly in angle: check it for every bin count the config allows.
    #[test]
    fn bounds_ascend_strictly_for_every_bin_count() {
        for bins in 1..=360u32 {
            let b = AngleBins::new(bins);
            for w in b.bounds().windows(2) {
                assert!(at_or_past(w[0], w[1]) && !at_or_past(w[1], w[0]), "bins {bins}: {:?}", w);
            }
        }
    }

    /// The binary search of `bin_of` == the count of every boundary the
    /// direction is at or past, for every bin count and directions on and
    /// beside every boundary.
    #[test]
    fn bin_of_equals_the_linear_count() {
        for bins in 1..=360u32 {
            let b = AngleBins::new(bins);
            let mut dirs = vec![(1, 0), (0, 1), (-1, 0), (0, -1), (100, -1), (-7, -1 << 20), ((1 << 21) - 1, 3)];
            for &(x, y) in b.bounds() {
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (-1, 0), (0, -1)] {
                    dirs.push((x + dx, y + dy));
                    dirs.push((x * 4096 + dx, y * 4096 + dy));
                }
            }
            for v in dirs {
                let linear = b.bounds().iter().filter(|&&bd| at_or_past(bd, v)).count() % b.len();
                assert_eq!(b.bin_of(v.0, v.1) as usize, linear, "bins {bins}, direction {v:?}");
            }
        }
    }

    #[test]
    fn umax_matches_opencv() {
        assert_eq!(compute_umax(15), UMAX.to_vec());
    }

    /// OpenCV builds `umax` so the disc is symmetric about its diagonal: row
    /// `v` holds `|u| <= UMAX[|v|]` exactly when column `u` holds `|v| <=
    /// UMAX[|u|]`. shaders/orientation.wgsl walks the disc by columns on that.
    #[test]
    fn umax_disc_is_symmetric_about_its_diagonal() {
        for u in -HALF_PATCH..=HALF_PATCH {
            for v in -HALF_PATCH..=HALF_PATCH {
                let by_row = u.abs() <= UMAX[v.unsigned_abs() as usize];
                let by_column = v.abs() <= UMAX[u.unsigned_abs() as usize];
                assert_eq!(by_row, by_column, "({u}, {v})");
            }
        }
    }

    #[test]
    fn bins_agree_with_float_angles_away_from_boundaries() {
        let bins = AngleBins::new(30);
        for deg10 in 0..3600 {
            let deg = deg10 as f64 / 10.0;
            let (m10, m01) = ((deg.to_radians().cos() * 1e6) as i32, (deg.to_radians().sin() * 1e6) as i32);
            let frac = (deg / 12.0 + 0.5).fract();
            if frac > 0.01 && frac < 0.99 {
                let want = ((deg / 12.0 + 0.5).floor() as u32) % 30;
                assert_eq!(bins.bin_of(m10, m01), want, "{deg} degrees ({m10}, {m01})");
            }
        }
        assert_eq!(bins.bin_of(0, 0), 0);
        assert_eq!(AngleBins::new(1).bin_of(-5, -5), 0);
    }
}
