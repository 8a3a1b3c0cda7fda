//! SPEC 8: the L-FAST corner test on the edge map (paper 3.2, Steps 1-5).
//! Mirrors shaders/lfast.wgsl.

use super::classify::EDGE;
use crate::config::Mode;
use crate::image::Plane;
use rayon::prelude::*;

mod scan;

/// The radius-3 Bresenham circle in FAST order (index 0 straight up, clockwise).
pub const CIRCLE: [(i32, i32); 16] = [
    (0, -3),
    (1, -3),
    (2, -2),
    (3, -1),
    (3, 0),
    (3, 1),
    (2, 2),
    (1, 3),
    (0, 3),
    (-1, 3),
    (-2, 2),
    (-3, 1),
    (-3, 0),
    (-3, -1),
    (-2, -2),
    (-1, -3),
];

/// Parameters of the corner test.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LfastParams {
    /// Paper or Branch.
    pub mode: Mode,
    /// Edge neighbours a non-edge `q_i` needs to support p.
    pub support: u32,
    /// Branch mode's straightness tolerance in circle steps.
    pub straight_tol: u32,
    /// Distance from every side within which no pixel is tested (>= 7).
    pub border: u32,
}

impl LfastParams {
    /// The corner-test fields of a config.
    pub fn from_config(c: &crate::Config) -> Self {
        Self { mode: c.mode, support: c.support, straight_tol: c.straight_tol, border: c.border }
    }
}

/// Step 4: does circle point `t` (offset index) support the corner at p?
/// `q = 2t - p` supports it when it is an edge, or when at least `support` of
/// its 8 neighbours are. Reads reach 7 pixels from p: p must be >= 7 from every side.
#[inline]
pub fn supports(e: &Plane<u8>, px: i32, py: i32, t: usize, support: u32) -> bool {
    let w = e.width as isize;
    let (dx, dy) = CIRCLE[t];
    let q = (py + 2 * dy) as isize * w + (px + 2 * dx) as isize;
    let at = |o: isize| (e.data[(q + o) as usize] == EDGE) as u32;
    if at(0) == 1 {
        return true;
    }
    let n = at(-w - 1) + at(-w) + at(-w + 1) + at(-1) + at(1) + at(w - 1) + at(w) + at(w + 1);
    n >= support
}

/// The 16-bit mask of edge pixels on the circle around p (bit i = `CIRCLE[i]`).
#[inline]
pub fn circle_mask(e: &Plane<u8>, px: i32, py: i32) -> u32 {
    let w = e.width as isize;
    let c = py as isize * w + px as isize;
    let mut m = 0;
    for (i, &(dx, dy)) in CIRCLE.iter().enumerate() {
        m |= ((e.data[(c + dy as isize * w + dx as isize) as usize] == EDGE) as u32) << i;
    }
    m
}

/// Branches of a circle mask: `(start, len)` of each run of consecutive set
/// bits, cyclically, in order of start index. Empty for 0 and for all-16.
pub fn branches(mask: u32) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    for_each_branch(mask, |s, len| out.push((s, len)));
    out
}

/// Calls `f(start, len)` for each branch of `mask` in order of start index,
/// without allocating (the hot path of [`is_corner`]).
#[inline]
pub fn for_each_branch(mask: u32, mut f: impl FnMut(usize, usize)) {
    if mask == 0 || mask == 0xffff {
        return;
    }
    // bit s of `starts` is set where a run begins: s set, s-1 (cyclically) clear
    let prev = ((mask << 1) | (mask >> 15)) & 0xffff;
    let mut starts = mask & !prev;
    let doubled = mask | (mask << 16);
    while starts != 0 {
        let s = starts.trailing_zeros() as usize;
        // run length: trailing ones of the mask rotated to start at s
        let len = (!(doubled >> s)).trailing_zeros() as usize;
        f(s, len.min(16));
        starts &= starts - 1;
    }
}

/// The circle index a branch `(start, len)` stands for (SPEC 8): its middle
/// pixel, the lower of the two middles of an even run.
///
/// ```
/// assert_eq!(lfast::cpu::lfast::branch_mid(14, 4), 15); // 14, 15, 0, 1
/// assert_eq!(lfast::cpu::lfast::branch_mid(15, 3), 0); // 15, 0, 1
/// ```
#[inline]
pub fn branch_mid(start: usize, len: usize) -> usize {
    (start + (len - 1) / 2) % 16
}

/// The L-FAST decision for edge pixel p (SPEC 8). p must lie >= 7 pixels from every side.
pub fn is_corner(e: &Plane<u8>, px: i32, py: i32, p: &LfastParams) -> bool {
    let mask = circle_mask(e, px, py);
    match p.mode {
        Mode::Paper => {
            let n = mask.count_ones();
            if n < 2 {
                return false;
            }
            if n == 2 {
                let a = mask.trailing_zeros();
                let b = 31 - mask.leading_zeros();
                if b - a == 8 {
                    return false; // p on the line of the only two points
                }
            }
            let mut supported = 0;
            let mut m = mask;
            while m != 0 {
                let t = m.trailing_zeros() as usize;
                m &= m - 1;
                if supports(e, px, py, t, p.support) {
                    supported += 1;
                    if supported >= 2 {
                        return true;
                    }
                }
            }
            false
        }
        Mode::Branch => {
            // Fewer than two branches, or exactly two on a straight line, can
            // never make a corner, whatever Step 4 says: skip its reads.
            let mut mids = [0usize; 8];
            let mut nb = 0;
            for_each_branch(mask, |s, len| {
                mids[nb] = branch_mid(s, len);
                nb += 1;
            });
            let straight = |a: usize, b: usize| {
                let d = a.abs_diff(b);
                d.min(16 - d) >= 8 - p.straight_tol as usize
            };
            if nb < 2 || (nb == 2 && straight(mids[0], mids[1])) {
                return false;
            }
            // at most 8 branches fit on 16 positions
            let mut ts = [0usize; 8];
            let mut n = 0;
            for &t in &mids[..nb] {
                if supports(e, px, py, t, p.support) {
                    ts[n] = t;
                    n += 1;
                }
            }
            match n {
                0 | 1 => false,
                2 => !straight(ts[0], ts[1]),
                _ => true,
            }
        }
    }
}

/// All L-FAST candidates of an edge map, in raster order: edge pixels at least
/// `border` from every side, on in `mask` (if any), that pass [`is_corner`].
pub fn lfast(e: &Plane<u8>, mask: Option<&Plane<u8>>, p: &LfastParams) -> Vec<[u32; 2]> {
    let b = p.border.max(7);
    if e.width <= 2 * b || e.height <= 2 * b {
        return Vec::new();
    }
    let (x0, x1) = (b as usize, (e.width - b) as usize);
    // Step 4 for a band's rows and the seven above and below it at once,
    // where rows are wide enough for the scanner, into this thread's buffer
    // (taken, so a call nested by rayon's work stealing finds none and
    // allocates its own): 78 rows per thread, not a level's map (8 MB at
    // 3840x2160, one per thread).
    thread_local!(static SUPPORT_ROWS: std::cell::Cell<Vec<u8>> = const { std::cell::Cell::new(Vec::new()) });
    let wide = x1 - x0 >= 32;
    let (y0, y1) = (b as usize, (e.height - b) as usize);
    // one Vec per band, appended in order: raster order
    (0..(y1 - y0).div_ceil(SCAN_BAND))
        .into_par_iter()
        .fold(Vec::new, |mut out, k| {
            let (ya, yb) = (y0 + k * SCAN_BAND, (y0 + (k + 1) * SCAN_BAND).min(y1));
            let r0 = ya - 7;
            let mut rows = SUPPORT_ROWS.take();
            if wide {
                scan::support_rows_into(e, p.support, r0, yb + 7, &mut rows);
            }
            for y in ya..yb {
                let mrow = mask.map(|m| m.row(y as u32));
                match scan::Window::in_band(e, &rows, y, r0) {
                    Some(win) if wide => scan::scan_row(&win, y as u32, x0, x1, mrow, p, &mut out),
                    _ => scan_row_reference(e, y as u32, x0, x1, mrow, p, &mut out),
                }
            }
            SUPPORT_ROWS.set(rows);
            out
        })
        .reduce(Vec::new, |mut a, mut b| {
            a.append(&mut b);
            a
        })
}

/// Rows per task of [`lfast`]'s scan.
const SCAN_BAND: usize = 64;

/// The plain row scan: [`is_corner`] at each edge pixel. For rows narrower than a chunk.
fn scan_row_reference(
    e: &Plane<u8>,
    y: u32,
    x0: usize,
    x1: usize,
    mrow: Option<&[u8]>,
    p: &LfastParams,
    out: &mut Vec<[u32; 2]>,
) {
    let row = e.row(y);
    for x in x0..x1 {
        if row[x] == EDGE && mrow.is_none_or(|m| m[x] != 0) && is_corner(e, x as i32, y as i32, p) {
            out.push([x as u32, y]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 31x31 edge map with the given edge pixels.
    fn map(pts: impl IntoIterator<Item = (i32, i32)>) -> Plane<u8> {
        let mut e = Plane::<u8>::new(31, 31);
        for (x, y) in pts {
            e.data[(y * 31 + x) as usize] = EDGE;
        }
        e
    }

    fn params(mode: Mode) -> LfastParams {
        LfastParams { mode, support: 4, straight_tol: 1, border: 7 }
    }

    const C: i32 = 15;

    #[test]
    fn l_corner_found_both_modes() {
        // Two 1-pixel-wide arms from (15,15): right and down.
        let e = map((0..12).map(|i| (C + i, C)).chain((1..12).map(|i| (C, C + i))));
        for mode in [Mode::Paper, Mode::Branch] {
            assert!(is_corner(&e, C, C, &params(mode)), "{mode:?}");
            assert_eq!(lfast(&e, None, &params(mode)), vec![[C as u32, C as u32]], "{mode:?}");
        }
    }

    #[test]
    fn t_junction_found_both_modes() {
        // A horizontal line through p and a stem going down.
        let e = map((-12..12).map(|i| (C + i, C)).chain((1..12).map(|i| (C, C + i))));
        for mode in [Mode::Paper, Mode::Branch] {
            assert!(is_corner(&e, C, C, &params(mode)), "{mode:?}");
        }
    }

    #[test]
    fn straight_line_rejected_both_modes() {
        for pts in [
            (-12..12).map(|i| (C + i, C)).collect::<Vec<_>>(), // horizontal
            (-12..12).map(|i| (C, C + i)).collect(),           // vertical
            (-12..12).map(|i| (C + i, C + i)).collect(),       // diagonal
        ] {
            let e = map(pts);
            for mode in [Mode::Paper, Mode::Branch] {
                assert!(!is_corner(&e, C, C, &params(mode)), "{mode:?}");
                assert!(lfast(&e, None, &params(mode)).is_empty(), "{mode:?}");
            }
        }
    }

    #[test]
    fn thick_line_paper_vs_branch() {
        // A 2-pixel-thick horizontal line: the circle meets it at 4 pixels, two
        // per side. Paper mode sees 4 points, not 2 opposite ones, and accepts;
        // Branch sees two opposite branches and rejects (the reason Branch exists).
        let e = map((-12..12).flat_map(|i| [(C + i, C), (C + i, C + 1)]));
        assert_eq!(circle_mask(&e, C, C).count_ones(), 4);
        assert!(is_corner(&e, C, C, &params(Mode::Paper)));
        assert!(!is_corner(&e, C, C, &params(Mode::Branch)));
    }

    #[test]
    fn isolated_point_and_full_circle_rejected() {
        let e = map([(C, C)]);
        assert!(!is_corner(&e, C, C, &params(Mode::Paper)));
        assert!(!is_corner(&e, C, C, &params(Mode::Branch)));
        // a filled disc: all 16 circle pixels are edge -> no branch
        let e = map((-7..=7).flat_map(|dy| (-7..=7).map(move |dx| (C + dx, C + dy))));
        assert_eq!(circle_mask(&e, C, C), 0xffff);
        assert!(!is_corner(&e, C, C, &params(Mode::Branch)));
    }

    #[test]
    fn support_by_neighbours() {
        // Arms that stop at the circle: q = 2t - p is not an edge; its 8
        // neighbours decide. With support 4, a q with 3 edge neighbours fails.
        let mut pts = vec![(C, C), (C + 1, C), (C + 2, C), (C + 3, C), (C, C + 1), (C, C + 2), (C, C + 3)];
        let e = map(pts.clone());
        assert!(!is_corner(&e, C, C, &params(Mode::Branch)));
        // give q = (21, 15) four edge neighbours, and q = (15, 21) four too
        pts.extend([(C + 5, C - 1), (C + 5, C), (C + 5, C + 1), (C + 7, C)]);
        pts.extend([(C - 1, C + 5), (C, C + 5), (C + 1, C + 5), (C, C + 7)]);
        let e = map(pts);
        assert!(supports(&e, C, C, 4, 4) && supports(&e, C, C, 8, 4));
        assert!(!supports(&e, C, C, 4, 5));
        assert!(is_corner(&e, C, C, &params(Mode::Branch)));
        assert!(is_corner(&e, C, C, &params(Mode::Paper)));
    }

    #[test]
    fn branch_middles_and_straightness() {
        assert_eq!(branches(0b0000_0000_0000_0111), vec![(0, 3)]);
        // wrap-around branch 15, 0, 1: starts at 15
        assert_eq!(branches(0b1000_0000_0000_0011), vec![(15, 3)]);
        assert_eq!(branches(0b0000_0001_0000_0001), vec![(0, 1), (8, 1)]);
        assert_eq!(branches(0xffff), vec![]);
        assert_eq!(branches(0x7fff), vec![(0, 15)]);
        assert_eq!(branches(0xfffe), vec![(1, 15)]);
        assert_eq!(branches(0b1010_1010_1010_1010), (0..8).map(|i| (2 * i + 1, 1)).collect::<Vec<_>>());
        // against a plain walk round the circle, for every mask
        for m in 1..0xffffu32 {
            let bit = |i: usize| m >> (i % 16) & 1 == 1;
            let want: Vec<(usize, usize)> = (0..16)
                .filter(|&s| bit(s) && !bit(s + 15))
                .map(|s| (s, (0..16).take_while(|&k| bit(s + k)).count()))
                .collect();
            assert_eq!(branches(m), want, "{m:016b}");
        }
        // Two branches 7 steps apart (157.5°) are a line at straight_tol 1, 6 are not.
        let arm = |t: usize| (1..12).map(move |k| (C + CIRCLE[t].0 * k / 3, C + CIRCLE[t].1 * k / 3));
        let e7 = map(arm(0).chain(arm(7)).chain([(C, C)]));
        assert!(!is_corner(&e7, C, C, &params(Mode::Branch)));
        let e6 = map(arm(0).chain(arm(6)).chain([(C, C)]));
        assert!(is_corner(&e6, C, C, &params(Mode::Branch)));
        let tol0 = LfastParams { straight_tol: 0, ..params(Mode::Branch) };
        assert!(is_corner(&e7, C, C, &tol0));
    }

    #[test]
    fn border_and_mask_respected() {
        let e = map((0..12).map(|i| (C + i, C)).chain((1..12).map(|i| (C, C + i))));
        let far = LfastParams { border: 16, ..params(Mode::Branch) };
        assert!(lfast(&e, None, &far).is_empty());
        let mut m = Plane::<u8>::new(31, 31);
        assert!(lfast(&e, Some(&m), &params(Mode::Branch)).is_empty());
        m.data[(C * 31 + C) as usize] = 7;
        assert_eq!(lfast(&e, Some(&m), &params(Mode::Branch)).len(), 1);
    }
}
