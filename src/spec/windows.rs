//! SPEC 5 window layout: window size `a x b = max(1, W/5) x max(1, H/5)`,
//! origins every half window plus one flush with the end, and for every
//! column and row the window whose centre is nearest. The CPU's
//! [`WindowGrid`](crate::cpu::local_threshold::WindowGrid) and the GPU's
//! [`FrameLayout`](crate::gpu::FrameLayout) both build it here.

/// Most SPEC 5 windows along one axis of any length: `a = max(1, L/5)` with
/// stride `max(1, a/2)` gives L windows for L < 10, L-1 for L < 15, L-2 for
/// L < 20 (17 at L = 19) and at most 11 from L = 20 on (a test checks every L).
pub const MAX_WINDOWS_PER_AXIS: usize = 17;

/// Most cells ([`cell_cuts`]) along one axis of any length L: L for L < 20
/// (every position a cut), at most 25 beyond (first at L = 29; a test checks
/// every L), so never more than `min(L, 25)`.
pub const MAX_CELLS_PER_AXIS: usize = 25;

/// The window layout of one `w x h` image (one pyramid level).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct WindowLayout {
    /// Window width `a = max(1, W/5)`.
    pub a: u32,
    /// Window height `b = max(1, H/5)`.
    pub b: u32,
    /// Window origins along x.
    pub xs: Vec<u32>,
    /// Window origins along y.
    pub ys: Vec<u32>,
    /// For each column x, the index in `xs` of the window whose centre is nearest.
    pub col_window: Vec<u32>,
    /// For each row y, the index in `ys` of the window whose centre is nearest.
    pub row_window: Vec<u32>,
}

impl WindowLayout {
    /// The layout of a `w x h` image (`w, h >= 1`).
    ///
    /// ```
    /// let l = lfast::spec::WindowLayout::new(1241, 376);
    /// assert_eq!((l.a, l.b, l.xs.len(), l.ys.len()), (248, 75, 10, 10));
    /// ```
    pub fn new(w: u32, h: u32) -> Self {
        let (a, b) = ((w / 5).max(1), (h / 5).max(1));
        let xs = window_origins(w, a);
        let ys = window_origins(h, b);
        Self { a, b, col_window: nearest_windows(&xs, a, w), row_window: nearest_windows(&ys, b, h), xs, ys }
    }

    /// Number of windows.
    pub fn len(&self) -> usize {
        self.xs.len() * self.ys.len()
    }

    /// True for the layout of an image without pixels.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Row-major index of the window that pixel (x, y) uses.
    #[inline(always)]
    pub fn window_of(&self, x: u32, y: u32) -> usize {
        self.row_window[y as usize] as usize * self.xs.len() + self.col_window[x as usize] as usize
    }
}

/// Cell boundaries along one axis of length `len`: 0, `len` and both edges
/// of every window (origins `origins`, size `size`), sorted, without repeats.
/// Every window is the union of the cells between two of them, so window
/// statistics can be summed from per-cell histograms (the CPU's
/// `local_threshold` and shaders/local_threshold.wgsl both do).
///
/// ```
/// let xs = lfast::spec::window_origins(1241, 248);
/// let c = lfast::spec::cell_cuts(&xs, 248, 1241);
/// assert_eq!(c, vec![0, 124, 248, 372, 496, 620, 744, 868, 992, 993, 1116, 1240, 1241]);
/// ```
pub fn cell_cuts(origins: &[u32], size: u32, len: u32) -> Vec<u32> {
    let mut c: Vec<u32> = origins.iter().flat_map(|&o| [o, o + size]).chain([0, len]).collect();
    c.sort_unstable();
    c.dedup();
    c
}

/// Window origins along one axis of length `len` for window size `size`:
/// `0, stride, 2*stride, ...` while the window fits, then one flush with the end.
///
/// ```
/// // KITTI width 1241: a = 248, stride 124
/// let xs = lfast::spec::window_origins(1241, 248);
/// assert_eq!(xs, vec![0, 124, 248, 372, 496, 620, 744, 868, 992, 993]);
/// ```
pub fn window_origins(len: u32, size: u32) -> Vec<u32> {
    let stride = (size / 2).max(1);
    let mut v: Vec<u32> = (0..).map(|i| i * stride).take_while(|&o| o + size <= len).collect();
    let last = len - size;
    if v.last() != Some(&last) {
        v.push(last);
    }
    v
}

/// For each coordinate `0..len`, the index of the window whose centre
/// `o + (size-1)/2` is nearest (compared doubled, ties to the lower index).
pub fn nearest_windows(origins: &[u32], size: u32, len: u32) -> Vec<u32> {
    (0..len)
        .map(|c| {
            let mut best = 0usize;
            let mut best_d = u32::MAX;
            for (i, &o) in origins.iter().enumerate() {
                let d = (2 * c as i64 - (2 * o as i64 + size as i64 - 1)).unsigned_abs() as u32;
                if d < best_d {
                    best_d = d;
                    best = i;
                }
            }
            best as u32
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kitti_layout() {
        // 1241x376: a = 248, b = 75, strides 124 and 37
        let xs = window_origins(1241, 248);
        assert_eq!(xs, vec![0, 124, 248, 372, 496, 620, 744, 868, 992, 993]);
        let ys = window_origins(376, 75);
        assert_eq!(ys, vec![0, 37, 74, 111, 148, 185, 222, 259, 296, 301]);
        // Centres: x window i at xs[i] + 123.5, so windows 0 and 1 meet at 185.5.
        let cw = nearest_windows(&xs, 248, 1241);
        assert_eq!((cw[0], cw[185], cw[186]), (0, 0, 1));
        // The last two windows' centres are 1115.5 and 1116.5: column 1116 ties
        // -> window 8; 1117 and beyond -> 9.
        assert_eq!((cw[1115], cw[1116], cw[1117], cw[1240]), (8, 8, 9, 9));
        let rw = nearest_windows(&ys, 75, 376);
        assert_eq!((rw[0], rw[55], rw[56], rw[375]), (0, 0, 1, 9));
        let l = WindowLayout::new(1241, 376);
        assert_eq!((l.xs, l.ys, l.col_window, l.row_window), (xs, ys, cw, rw));
    }

    #[test]
    fn tiny_images() {
        assert_eq!(window_origins(1, 1), vec![0]);
        assert_eq!(window_origins(4, 1), vec![0, 1, 2, 3]);
        assert_eq!(window_origins(9, 1), (0..9).collect::<Vec<_>>());
        assert_eq!(window_origins(10, 2), (0..9).collect::<Vec<_>>());
    }

    #[test]
    fn no_axis_has_more_than_max_cells() {
        let cells = |l: u32| {
            let a = (l / 5).max(1);
            cell_cuts(&window_origins(l, a), a, l).len() - 1
        };
        let mut worst = 0;
        for l in 1..=crate::image::MAX_SIDE {
            let n = cells(l);
            assert!(n <= (l as usize).min(MAX_CELLS_PER_AXIS), "{l}: {n} cells");
            worst = worst.max(n);
        }
        assert_eq!(worst, MAX_CELLS_PER_AXIS);
    }

    #[test]
    fn no_axis_has_more_than_max_windows() {
        let worst = (1..=crate::image::MAX_SIDE).map(|l| window_origins(l, (l / 5).max(1)).len()).max().unwrap();
        assert_eq!(worst, MAX_WINDOWS_PER_AXIS);
    }
}
