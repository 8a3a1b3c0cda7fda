//! The row scanner behind [`lfast`](super::lfast): the same decisions as
//! [`is_corner`](super::is_corner), with fewer instructions. Per chunk of 32
//! pixels of a row it builds all 32 circle masks at once (16 compares of 32
//! bytes, which LLVM vectorises), then decides each edge pixel of the chunk
//! from its mask, reading Step 4's 3x3 neighbourhoods as three 4-byte words.
//! Reads go through [`Window`], which checks once per row what every read relies on.

use super::{CIRCLE, LfastParams};
use crate::config::Mode;
use crate::cpu::classify::EDGE;
use crate::cpu::simd::dispatch;
use crate::image::Plane;

/// Pixels per chunk of the vectorised circle masks.
const CHUNK: usize = 32;

/// The rows `y-7..=y+7` of an edge map, for reads without bounds checks.
///
/// Invariant (checked in [`Window::new`]): `w >= 15`, `7 <= y` and rows
/// `y-7..=y+7` lie in `d`, i.e. `(y + 8) * w <= d.len()`.
pub(super) struct Window<'a> {
    d: &'a [u8],
    w: usize,
    /// Index of `(0, y)`.
    c: usize,
}

impl<'a> Window<'a> {
    /// The window around row `y`; `None` where rows `y-7..=y+7` are not all in `e`.
    pub(super) fn new(e: &'a Plane<u8>, y: usize) -> Option<Self> {
        let w = e.width as usize;
        let fits = w >= 15 && y >= 7 && (y + 8).checked_mul(w).is_some_and(|end| end <= e.data.len());
        fits.then_some(Self { d: &e.data, w, c: y * w })
    }

    /// The `N` bytes at columns `cx..cx+N` of row `y + dy`.
    ///
    /// # Safety
    /// `-7 <= dy <= 7` and `cx + N <= w`.
    #[inline(always)]
    unsafe fn bytes<const N: usize>(&self, cx: usize, dy: isize) -> &'a [u8; N] {
        debug_assert!((-7..=7).contains(&dy) && cx + N <= self.w);
        let row = (self.c as isize + dy * self.w as isize) as usize;
        // SAFETY: y >= 7 and |dy| <= 7 give row >= 0; the row ends at
        // row + w <= (y + 8) * w <= d.len() (the invariant), and cx + N <= w,
        // so the N bytes at row + cx lie in d, borrowed for 'a. [u8; N] has alignment 1.
        unsafe { &*self.d.as_ptr().add(row + cx).cast::<[u8; N]>() }
    }
}

/// Per circle index t, Step 4's 3x3 around `q = p + 2 CIRCLE[t]` as three
/// 4-byte words at rows `2dy-1, 2dy, 2dy+1`: the column offset from p of the
/// words' first byte, and the byte (0..4) of q in them. Words start at
/// `qx - 1`, or at `qx - 2` right of p, so that none reaches past `px + 8`.
const Q_WORDS: [(isize, isize, u32); 16] = {
    let mut t = [(0, 0, 0); 16];
    let mut i = 0;
    while i < 16 {
        let (dx, dy) = CIRCLE[i];
        let (dx, dy) = (dx as isize, dy as isize);
        t[i] = if dx > 0 { (2 * dx - 2, 2 * dy, 2) } else { (2 * dx - 1, 2 * dy, 1) };
        i += 1;
    }
    t
};

/// 0x01 in each byte of `v` that equals [`EDGE`] (0xff), 0x00 elsewhere.
#[inline(always)]
fn edge_bytes(v: u32) -> u32 {
    const _: () = assert!(EDGE == 0xff);
    let x = !v; // zero bytes where v is EDGE
    let nonzero = ((x & 0x7f7f_7f7f) + 0x7f7f_7f7f) | x; // high bit set where x's byte != 0
    (!nonzero >> 7) & 0x0101_0101
}

/// [`super::supports`] for p = (x, y), from three word loads.
///
/// # Safety
/// `7 <= x < w - 7` (`w` the window's width).
#[inline(always)]
unsafe fn supports_at(win: &Window<'_>, x: usize, t: usize, support: u32) -> bool {
    let (ox, qy, qbyte) = Q_WORDS[t & 15];
    let cx = (x as isize + ox) as usize;
    // SAFETY: |CIRCLE| entries are <= 3 (tested), so qy = 2dy is in -6..=6 and
    // qy +- 1 in -7..=7. ox is 2dx - 1 >= -7 for dx <= 0, so cx >= x - 7 >= 0,
    // and cx + 4 = x + 2dx + 3 <= x + 3 < w; ox is 2dx - 2 in 0..=4 for dx > 0,
    // so cx + 4 <= x + 8 <= w as x < w - 7.
    let (a, b, c) = unsafe {
        (
            u32::from_le_bytes(*win.bytes::<4>(cx, qy - 1)),
            u32::from_le_bytes(*win.bytes::<4>(cx, qy)),
            u32::from_le_bytes(*win.bytes::<4>(cx, qy + 1)),
        )
    };
    let mid = edge_bytes(b);
    if mid >> (8 * qbyte) & 1 == 1 {
        return true; // q itself is an edge
    }
    // q is not an edge: the 3x3 count is the count of its 8 neighbours
    let keep = 0x00ff_ffffu32 << (8 * (qbyte - 1));
    let n = ((edge_bytes(a) + mid + edge_bytes(c)) & keep).wrapping_mul(0x0101_0101) >> 24;
    n >= support
}

/// The middle index of the branch starting at `s` of `mask` (as [`super::is_corner`]).
#[inline(always)]
fn branch_mid(mask: u32, s: u32) -> usize {
    let doubled = mask | (mask << 16);
    let len = (!(doubled >> s)).trailing_zeros().min(16);
    ((s + (len - 1) / 2) % 16) as usize
}

/// [`super::is_corner`]'s decision from p's circle mask, `sup(t)` deciding Step 4.
/// Returns what it returns; `sup` is called only where its answer can matter.
#[inline(always)]
pub(super) fn decide(mask: u32, p: &LfastParams, mut sup: impl FnMut(usize) -> bool) -> bool {
    match p.mode {
        Mode::Paper => {
            // fewer than two points; or two opposite ones with p on their line
            let rest = mask & mask.wrapping_sub(1);
            if rest == 0 {
                return false;
            }
            if rest & (rest - 1) == 0 && rest.trailing_zeros() - mask.trailing_zeros() == 8 {
                return false;
            }
            let mut supported = 0;
            let mut m = mask;
            while m != 0 {
                let t = m.trailing_zeros() as usize;
                m &= m - 1;
                if sup(t) {
                    supported += 1;
                    if supported >= 2 {
                        return true;
                    }
                }
            }
            false
        }
        Mode::Branch => {
            if mask == 0 || mask == 0xffff {
                return false;
            }
            let straight = |a: usize, b: usize| {
                let d = a.abs_diff(b);
                d.min(16 - d) >= 8 - p.straight_tol as usize
            };
            let prev = ((mask << 1) | (mask >> 15)) & 0xffff;
            let starts = mask & !prev;
            let rest = starts & (starts - 1);
            if rest == 0 {
                return false; // one branch
            }
            let m0 = branch_mid(mask, starts.trailing_zeros());
            if rest & (rest - 1) == 0 {
                // Two branches: a corner iff they are not straight and both supported.
                let m1 = branch_mid(mask, rest.trailing_zeros());
                return !straight(m0, m1) && sup(m0) && sup(m1);
            }
            // Three or more: a corner iff three are supported, or two that are not straight.
            let mut first = None;
            let mut n = 0;
            let mut s = starts;
            while s != 0 {
                let t = branch_mid(mask, s.trailing_zeros());
                s &= s - 1;
                if sup(t) {
                    n += 1;
                    match first {
                        None => first = Some(t),
                        Some(a) => {
                            if n >= 3 || !straight(a, t) {
                                return true;
                            }
                        }
                    }
                }
            }
            false
        }
    }
}

/// Circle masks of the 32 pixels `xs..xs+32` of the window's row.
///
/// # Safety
/// `7 <= xs` and `xs + 32 <= w - 7`.
#[inline(always)]
unsafe fn chunk_masks(win: &Window<'_>, xs: usize) -> [u16; CHUNK] {
    // SAFETY: |dx|, |dy| <= 3, so xs + dx >= 4 and xs + dx + 32 <= w - 4.
    let rows: [&[u8; CHUNK]; 16] = std::array::from_fn(|i| unsafe {
        win.bytes((xs as isize + CIRCLE[i].0 as isize) as usize, CIRCLE[i].1 as isize)
    });
    let mut masks = [0u16; CHUNK];
    for (j, m) in masks.iter_mut().enumerate() {
        // bytes, not u16 lanes: twice the pixels per vector
        let (mut lo, mut hi) = (0u8, 0u8);
        for i in 0..8 {
            lo |= ((rows[i][j] == EDGE) as u8) << i;
            hi |= ((rows[i + 8][j] == EDGE) as u8) << i;
        }
        *m = lo as u16 | (hi as u16) << 8;
    }
    masks
}

/// Bit j set where `c[j]` is [`EDGE`].
#[inline(always)]
fn edge_bits(c: &[u8; CHUNK]) -> u32 {
    #[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
    {
        use std::arch::x86_64::{__m128i, _mm_cmpeq_epi8, _mm_loadu_si128, _mm_movemask_epi8, _mm_set1_epi8};
        const _: () = assert!(EDGE as i8 == -1);
        // SAFETY: the cfg guarantees SSE2, all these intrinsics need; the two
        // unaligned 16-byte loads read c[0..16] and c[16..32], in bounds.
        unsafe {
            let ff = _mm_set1_epi8(-1);
            let a = _mm_loadu_si128(c.as_ptr().cast::<__m128i>());
            let b = _mm_loadu_si128(c.as_ptr().add(16).cast::<__m128i>());
            let lo = _mm_movemask_epi8(_mm_cmpeq_epi8(a, ff)) as u32 & 0xffff;
            let hi = _mm_movemask_epi8(_mm_cmpeq_epi8(b, ff)) as u32 & 0xffff;
            lo | hi << 16
        }
    }
    #[cfg(not(all(target_arch = "x86_64", target_feature = "sse2")))]
    {
        let mut bits = 0u32;
        for (j, &v) in c.iter().enumerate() {
            bits |= ((v == EDGE) as u32) << j;
        }
        bits
    }
}

dispatch! {
    /// Appends to `out` the corners `[x, y]` of the window's row `y` with x in
    /// `x0..x1` (raster order), where `mrow` (if any) is non-zero. Needs
    /// `7 <= x0`, `x1 + 7 <= w` and `x1 - x0 >= 32` (panics otherwise).
    pub(super) fn scan_row(win: &Window<'_>, y: u32, x0: usize, x1: usize, mrow: Option<&[u8]>,
                           p: &LfastParams, out: &mut Vec<[u32; 2]>) {
        assert!(x0 >= 7 && x1 + 7 <= win.w && x1 >= x0 + CHUNK, "scan_row: columns {x0}..{x1} of {}", win.w);
        let mut xs = x0;
        let mut skip = 0; // pixels at the start of this chunk done by the one before
        loop {
            // SAFETY: xs >= x0 >= 7 and xs + 32 <= x1, x1 + 7 <= w, asserted above
            let mut bits = edge_bits(unsafe { win.bytes(xs, 0) });
            if let Some(m) = mrow {
                for (j, &v) in m[xs..xs + CHUNK].iter().enumerate() {
                    bits &= !(((v == 0) as u32) << j);
                }
            }
            bits &= u32::MAX << skip;
            if bits != 0 {
                // SAFETY: as above
                let masks = unsafe { chunk_masks(win, xs) };
                while bits != 0 {
                    let j = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    let x = xs + j;
                    // SAFETY: 7 <= x0 <= x < x1 <= w - 7
                    if decide(masks[j] as u32, p, |t| unsafe { supports_at(win, x, t, p.support) }) {
                        out.push([x as u32, y]);
                    }
                }
            }
            if xs + CHUNK == x1 {
                break;
            }
            // the last chunk ends at x1, overlapping the one before
            let next = (xs + CHUNK).min(x1 - CHUNK);
            skip = xs + CHUNK - next;
            xs = next;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::{circle_mask, is_corner, lfast, supports};
    use super::*;
    use crate::rng::SplitMix64;

    /// A `w x h` edge map: each pixel EDGE with probability `density`/256,
    /// else 0, or (one in 16 non-edges) another value that is not EDGE.
    fn edge_map(w: u32, h: u32, density: u64, seed: u64) -> Plane<u8> {
        let mut r = SplitMix64::new(seed);
        let data = (0..w * h)
            .map(|_| {
                let v = r.next_u64();
                if v & 0xff < density {
                    EDGE
                } else if v >> 8 & 15 == 0 {
                    (v >> 16) as u8 % 255
                } else {
                    0
                }
            })
            .collect();
        Plane::from_vec(w, h, data).expect("plane size")
    }

    #[test]
    fn circle_offsets_within_three() {
        // the SAFETY arguments of supports_at and chunk_masks rely on this
        assert!(CIRCLE.iter().all(|&(dx, dy)| dx.abs() <= 3 && dy.abs() <= 3));
    }

    #[test]
    fn edge_bytes_exact() {
        for b in 0..=255u8 {
            let bytes = [b, 0xff, b ^ 0x80, 255 - b];
            let want = bytes.map(|v| (v == EDGE) as u8);
            assert_eq!(edge_bytes(u32::from_le_bytes(bytes)), u32::from_le_bytes(want), "{b}");
        }
    }

    #[test]
    fn window_refuses_missing_rows() {
        let e = Plane::<u8>::new(20, 20);
        assert!(Window::new(&e, 6).is_none());
        assert!(Window::new(&e, 7).is_some() && Window::new(&e, 12).is_some());
        assert!(Window::new(&e, 13).is_none());
        assert!(Window::new(&Plane::<u8>::new(14, 20), 10).is_none());
    }

    /// The reference scan: [`is_corner`] at every edge pixel of the border.
    fn naive(e: &Plane<u8>, m: Option<&Plane<u8>>, p: &LfastParams) -> Vec<[u32; 2]> {
        let (w, h, b) = (e.width, e.height, p.border.max(7));
        let mut want = Vec::new();
        for y in b..h.saturating_sub(b) {
            for x in b..w.saturating_sub(b) {
                let i = (y * w + x) as usize;
                if e.data[i] == EDGE && m.is_none_or(|m| m.data[i] != 0) && is_corner(e, x as i32, y as i32, p) {
                    want.push([x, y]);
                }
            }
        }
        want
    }

    #[test]
    fn lfast_matches_is_corner_on_canny_edges() {
        // edge maps of the real pipeline (thin lines, junctions) on random rectangles
        let cfg = crate::Config::default();
        for seed in 0..3u64 {
            let mut r = SplitMix64::new(seed);
            let (w, h) = (173, 121);
            let mut img = Plane::from_vec(w, h, vec![90u8; (w * h) as usize]).expect("plane size");
            for _ in 0..25 {
                let (x0, y0) = (r.next_u64() % w as u64, r.next_u64() % h as u64);
                let (rw, rh, v) = (5 + r.next_u64() % 60, 5 + r.next_u64() % 50, r.next_u64() as u8);
                for y in y0..(y0 + rh).min(h as u64) {
                    for x in x0..(x0 + rw).min(w as u64) {
                        img.data[(y * w as u64 + x) as usize] = v;
                    }
                }
            }
            let e =
                crate::cpu::fused::edges_fused(&img, cfg.delta_num(), crate::config::DELTA_DEN, cfg.alpha_pct).edges;
            let mut corners = 0;
            for mode in [Mode::Paper, Mode::Branch] {
                for support in 1..=8 {
                    for straight_tol in 0..=3 {
                        let p = LfastParams { mode, support, straight_tol, border: 7 };
                        let want = naive(&e, None, &p);
                        corners += want.len();
                        assert_eq!(lfast(&e, None, &p), want, "seed {seed} {p:?}");
                    }
                }
            }
            assert!(corners > 100, "seed {seed}: only {corners} corners, a weak test");
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(300))]
        #[test]
        fn masks_and_supports_match_reference(w in 46u32..100, h in 15u32..30, density in 0u64..256,
                                              seed in proptest::prelude::any::<u64>(), support in 1u32..=8) {
            let e = edge_map(w, h, density, seed);
            for y in 7..h as usize - 7 {
                let win = Window::new(&e, y).expect("rows inside");
                let mut xs = 7;
                while xs + CHUNK <= w as usize - 7 {
                    // SAFETY: 7 <= xs, xs + 32 <= w - 7
                    let masks = unsafe { chunk_masks(&win, xs) };
                    for (j, &m) in masks.iter().enumerate() {
                        let (x, yi) = ((xs + j) as i32, y as i32);
                        proptest::prop_assert_eq!(m as u32, circle_mask(&e, x, yi));
                        for t in 0..16 {
                            // SAFETY: 7 <= x < w - 7
                            let got = unsafe { supports_at(&win, xs + j, t, support) };
                            proptest::prop_assert_eq!(got, supports(&e, x, yi, t, support), "({}, {}) t {}", x, y, t);
                        }
                    }
                    xs += 7; // overlapping chunks: every column is covered
                }
            }
        }

        #[test]
        fn lfast_matches_is_corner_everywhere(w in 15u32..100, h in 15u32..40, density in 0u64..256,
                                              seed in proptest::prelude::any::<u64>(), paper in proptest::prelude::any::<bool>(),
                                              support in 1u32..=8, straight_tol in 0u32..=3, border in 7u32..10,
                                              masked in proptest::prelude::any::<bool>()) {
            let e = edge_map(w, h, density, seed);
            let m = masked.then(|| edge_map(w, h, 128, seed ^ 0x5eed));
            let p = LfastParams { mode: if paper { Mode::Paper } else { Mode::Branch }, support, straight_tol, border };
            let want = naive(&e, m.as_ref(), &p);
            proptest::prop_assert_eq!(lfast(&e, m.as_ref(), &p), want);
        }
    }
}
