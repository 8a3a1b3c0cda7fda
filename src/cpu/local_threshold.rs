//! SPEC 5: the sliding-window statistics behind the local thresholds TL1, TL2.
//! Mirrors shaders/local_threshold.wgsl.
//!
//! Windows overlap by half, so each pixel lies in up to four of them. Instead of
//! sorting each window, the image is cut into *cells* at every window edge; one
//! 256-bin histogram per cell is built in a single pass, and a window's
//! histogram is the sum of its cells'. Min, max and lower median come from it.

use crate::cpu::simd::dispatch;
use crate::image::Plane;
pub use crate::spec::windows::{WindowLayout, cell_cuts, nearest_windows, window_origins};
use rayon::prelude::*;

/// Min, max and lower median of `M8` in one window.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WindowStats {
    /// Smallest M8.
    pub min: u8,
    /// Largest M8.
    pub max: u8,
    /// Element `(n-1)/2` of the sorted values.
    pub median: u8,
}

impl WindowStats {
    /// `V3 = max + median + min`, three times the paper's V.
    pub fn v3(&self) -> u32 {
        self.max as u32 + self.median as u32 + self.min as u32
    }
}

/// The window layout of an image ([`crate::spec::windows`]) and each window's statistics.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct WindowGrid {
    /// Window size, origins and the nearest window of every row and column.
    pub layout: WindowLayout,
    /// Per window, row-major: window `(i, j)` (x index i, y index j) is `stats[j * layout.xs.len() + i]`.
    pub stats: Vec<WindowStats>,
}

impl WindowGrid {
    /// `V3` of the window that pixel (x, y) uses.
    #[inline(always)]
    pub fn v3_at(&self, x: u32, y: u32) -> u32 {
        self.stats[self.layout.window_of(x, y)].v3()
    }
}

/// Min, max and lower median of a histogram with `n > 0` entries.
fn stats_of(h: &[u32; 256]) -> WindowStats {
    let n: u32 = h.iter().sum();
    let min = h.iter().position(|&c| c > 0).unwrap_or(0) as u8;
    let max = h.iter().rposition(|&c| c > 0).unwrap_or(0) as u8;
    let target = (n.max(1) - 1) / 2;
    let mut acc = 0u32;
    let mut median = 0u8;
    for (v, &c) in h.iter().enumerate() {
        acc += c;
        if acc > target {
            median = v as u8;
            break;
        }
    }
    WindowStats { min, max, median }
}

/// The window layout of a `w x h` image cut into cells at every window edge.
#[derive(Clone, Debug)]
pub(crate) struct Cells {
    pub windows: WindowLayout,
    /// Cell boundaries along x and y (every window edge, plus 0 and the size).
    pub cx: Vec<u32>,
    pub cy: Vec<u32>,
}

impl Cells {
    pub fn new(w: u32, h: u32) -> Self {
        let windows = WindowLayout::new(w, h);
        let cx = cell_cuts(&windows.xs, windows.a, w);
        let cy = cell_cuts(&windows.ys, windows.b, h);
        Self { windows, cx, cy }
    }

    /// Sums the cells' histograms (`cells[j][i]`: cell row j, cell column i)
    /// into each window's statistics and builds the grid.
    pub fn grid(self, cells: &[Vec<[u32; 256]>]) -> WindowGrid {
        let stats = self.stats(cells);
        WindowGrid { layout: self.windows, stats }
    }

    /// Each window's statistics (row-major, as [`WindowGrid::stats`]) from the cells' histograms.
    pub fn stats(&self, cells: &[Vec<[u32; 256]>]) -> Vec<WindowStats> {
        let cell_of = |cuts: &[u32], v: u32| cuts.binary_search(&v).expect("window edges are cut points");
        let l = &self.windows;
        let mut stats = Vec::with_capacity(l.len());
        for &y0 in &l.ys {
            let (j0, j1) = (cell_of(&self.cy, y0), cell_of(&self.cy, y0 + l.b));
            for &x0 in &l.xs {
                let (i0, i1) = (cell_of(&self.cx, x0), cell_of(&self.cx, x0 + l.a));
                let mut hist = [0u32; 256];
                sum_cells(&cells[j0..j1], i0, i1, &mut hist);
                stats.push(stats_of(&hist));
            }
        }
        stats
    }
}

dispatch! {
    /// `out` = the sum of the histograms of cells `i0..i1` of every band in
    /// `bands`, 64 bins at a time in registers (eight AVX2 vectors) rather than
    /// a load, add and store of the whole histogram per cell.
    fn sum_cells(bands: &[Vec<[u32; 256]>], i0: usize, i1: usize, out: &mut [u32; 256]) {
        for (b, o) in out.chunks_exact_mut(64).enumerate() {
            let mut acc = [0u32; 64];
            for band in bands {
                for cell in &band[i0..i1] {
                    let c: &[u32; 64] = cell[b * 64..b * 64 + 64].try_into().expect("64 bins");
                    for (a, &v) in acc.iter_mut().zip(c) {
                        *a += v;
                    }
                }
            }
            o.copy_from_slice(&acc);
        }
    }
}

/// Adds one row of M8 values to the histograms of the cells it crosses.
#[inline]
pub(crate) fn add_row(band: &mut [[u32; 256]], cx: &[u32], m8: impl Fn(usize) -> u8) {
    for (i, hist) in band.iter_mut().enumerate() {
        for x in cx[i] as usize..cx[i + 1] as usize {
            hist[m8(x) as usize] += 1;
        }
    }
}

/// Cell histograms of one band kept as four interleaved sub-histograms, so
/// that runs of equal values do not serialise on one counter. The
/// sub-histograms count in u16 (half the memory to clear and merge per cell)
/// and are flushed into the cell's u32 histogram before any counter could wrap.
pub(crate) struct BandHistograms {
    quads: Vec<[[u16; 256]; 4]>,
    cells: Vec<[u32; 256]>,
    /// Rows added since the last flush, and the most that fit in u16.
    rows: u32,
    max_rows: u32,
}

dispatch! {
    /// [`BandHistograms::flush`]'s loop: each cell's four u16 sub-histograms
    /// added into its u32 one (and cleared when `clear`), 16 bins a vector
    /// with AVX2.
    fn merge_quads(quads: &mut [[[u16; 256]; 4]], cells: &mut [[u32; 256]], clear: bool) {
        for (q, cell) in quads.iter_mut().zip(cells.iter_mut()) {
            for (b, c) in cell.iter_mut().enumerate() {
                *c += q[0][b] as u32 + q[1][b] as u32 + q[2][b] as u32 + q[3][b] as u32;
            }
            if clear {
                *q = [[0; 256]; 4];
            }
        }
    }
}

impl BandHistograms {
    /// Histograms for the cells cut at `cx` (`cx.len() - 1` cells).
    pub fn new(cx: &[u32]) -> Self {
        let n = cx.len() - 1;
        // per row, sub-histogram 0 takes at most widest / 4 + 3 values of one bin
        let widest = cx.windows(2).map(|c| c[1] - c[0]).max().unwrap_or(0);
        let max_rows = (u16::MAX as u32 / (widest / 4 + 3)).max(1);
        Self { quads: vec![[[0; 256]; 4]; n], cells: vec![[0; 256]; n], rows: 0, max_rows }
    }

    /// Adds one row of M8 values to the cells it crosses.
    #[inline]
    pub fn add_row(&mut self, cx: &[u32], m8: &[u8]) {
        if self.rows == self.max_rows {
            self.flush(true);
        }
        self.rows += 1;
        for (i, q) in self.quads.iter_mut().enumerate() {
            let cell = &m8[cx[i] as usize..cx[i + 1] as usize];
            let mut chunks = cell.chunks_exact(4);
            for c in &mut chunks {
                q[0][c[0] as usize] += 1;
                q[1][c[1] as usize] += 1;
                q[2][c[2] as usize] += 1;
                q[3][c[3] as usize] += 1;
            }
            for &v in chunks.remainder() {
                q[0][v as usize] += 1;
            }
        }
    }

    /// Adds the sub-histograms into the cells' (and clears them when `clear`).
    fn flush(&mut self, clear: bool) {
        merge_quads(&mut self.quads, &mut self.cells, clear);
        self.rows = 0;
    }

    /// The merged histogram of each cell.
    pub fn finish(mut self) -> Vec<[u32; 256]> {
        self.flush(false);
        self.cells
    }
}

/// Window statistics of `M8 = min(M, 255)` (SPEC 5).
pub fn local_threshold(m: &Plane<u16>) -> WindowGrid {
    let (w, h) = (m.width, m.height);
    let layout = Cells::new(w, h);
    let (cx, cy) = (&layout.cx, &layout.cy);
    // One histogram per cell, one band of cells per task.
    let cells: Vec<Vec<[u32; 256]>> = (0..cy.len() - 1)
        .into_par_iter()
        .map(|j| {
            let mut band = vec![[0u32; 256]; cx.len() - 1];
            for y in cy[j]..cy[j + 1] {
                let row = m.row(y);
                add_row(&mut band, cx, |x| row[x].min(255) as u8);
            }
            band
        })
        .collect();
    layout.grid(&cells)
}

#[cfg(test)]
mod tests {
    #[test]
    fn band_histograms_flush_before_u16_wraps() {
        // 2 cells (widths 8 and 3), 70 000 rows of one value: 560 000 counts in
        // one bin, far past u16, so the sub-histograms must have been flushed.
        let cx = [0u32, 8, 11];
        let mut band = super::BandHistograms::new(&cx);
        let row = [7u8, 7, 7, 7, 7, 7, 7, 7, 200, 201, 200];
        for _ in 0..70_000 {
            band.add_row(&cx, &row);
        }
        let cells = band.finish();
        assert_eq!(cells[0][7], 560_000);
        assert_eq!(cells[0].iter().sum::<u32>(), 560_000);
        assert_eq!((cells[1][200], cells[1][201], cells[1].iter().sum::<u32>()), (140_000, 70_000, 210_000));
    }

    use super::*;

    #[test]
    fn tiny_images() {
        let m = Plane::from_vec(1, 1, vec![300u16]).unwrap();
        let g = local_threshold(&m);
        assert_eq!(g.stats, vec![WindowStats { min: 255, max: 255, median: 255 }]);
    }

    #[test]
    fn stats_on_literal() {
        // 10x5 image: a = 2, b = 1, windows of 2x1 pixels.
        let m = Plane::from_vec(10, 5, (0..50u16).map(|i| i * 7).collect()).unwrap();
        let g = local_threshold(&m);
        assert_eq!(g.layout.xs, (0..9).collect::<Vec<_>>());
        assert_eq!(g.layout.ys, (0..5).collect::<Vec<_>>());
        // window (0, 0) holds 0 and 7: lower median = 0
        assert_eq!(g.stats[0], WindowStats { min: 0, max: 7, median: 0 });
        // window (3, 4) holds pixels 43, 44 -> 301 and 308, both clipped to 255
        assert_eq!(g.stats[4 * 9 + 3], WindowStats { min: 255, max: 255, median: 255 });
    }

    proptest::proptest! {
        #[test]
        fn matches_naive_sort(w in 1u32..40, h in 1u32..40, seed in proptest::prelude::any::<u64>()) {
            let mut s = seed;
            let data: Vec<u16> = (0..w * h).map(|_| { s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407); ((s >> 40) % 300) as u16 }).collect();
            let m = Plane::from_vec(w, h, data).unwrap();
            let g = local_threshold(&m);
            let l = &g.layout;
            for (j, &y0) in l.ys.iter().enumerate() {
                for (i, &x0) in l.xs.iter().enumerate() {
                    let mut v: Vec<u8> = vec![];
                    for y in y0..y0 + l.b { for x in x0..x0 + l.a { v.push(m.at(x, y).min(255) as u8); } }
                    v.sort();
                    let want = WindowStats { min: v[0], max: *v.last().unwrap(), median: v[(v.len() - 1) / 2] };
                    proptest::prop_assert_eq!(g.stats[j * l.xs.len() + i], want);
                }
            }
        }
    }
}
