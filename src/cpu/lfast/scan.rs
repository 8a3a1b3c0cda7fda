//! The row scanner behind [`lfast`](super::lfast): the same decisions as
//! [`is_corner`](super::is_corner), with fewer instructions. Per chunk of 32
//! pixels of a row it builds all 32 circle masks at once (16 compares of 32
//! bytes, which LLVM vectorises), then decides each edge pixel of the chunk
//! from its mask (in paper mode all 32 at once, [`paper_bits`]). Step 4 is
//! one byte read from a support map, computed for every pixel beforehand in
//! one vectorised pass ([`support_map_into`]).
//! Reads go through [`Window`], which checks once per row what every read relies on.

use super::{CIRCLE, LfastParams};
use crate::config::Mode;
use crate::cpu::classify::EDGE;
use crate::cpu::simd::{CHUNK, dispatch, dispatch_avx2, eq_bits};
use crate::image::Plane;

/// The rows `y-7..=y+7` of an edge map and of its support map, for reads
/// without bounds checks.
///
/// Invariant (checked in [`Window::new`]): `w >= 15`, `7 <= y` and rows
/// `y-7..=y+7` lie in `d` and in `s`, i.e. `(y + 8) * w <= d.len(), s.len()`.
pub(super) struct Window<'a> {
    d: &'a [u8],
    s: &'a [u8],
    w: usize,
    /// Index of `(0, y)` in `d`.
    c: usize,
    /// Index of `(0, y)` in `s`.
    cs: usize,
}

impl<'a> Window<'a> {
    /// The window around row `y` of `e` and of its support map `s` (as made by
    /// [`support_map_into`]); `None` where rows `y-7..=y+7` are not all in both.
    #[cfg(test)]
    pub(super) fn new(e: &'a Plane<u8>, s: &'a [u8], y: usize) -> Option<Self> {
        Self::in_band(e, s, y, 0)
    }

    /// [`Window::new`] with `s` holding the support map's rows from `r0` on
    /// (as [`support_rows_into`] makes them); `None` where rows `y-7..=y+7`
    /// are not all in `e` and in `s`.
    pub(super) fn in_band(e: &'a Plane<u8>, s: &'a [u8], y: usize, r0: usize) -> Option<Self> {
        let w = e.width as usize;
        let fits = w >= 15
            && y >= 7
            && y - 7 >= r0
            && (y + 8).checked_mul(w).is_some_and(|end| end <= e.data.len() && end - r0 * w <= s.len());
        fits.then_some(Self { d: &e.data, s, w, c: y * w, cs: (y - r0) * w })
    }

    /// The `N` support-map bytes at columns `cx..cx+N` of row `y + dy`.
    ///
    /// # Safety
    /// `-7 <= dy <= 7` and `cx + N <= w`.
    #[inline(always)]
    unsafe fn support_bytes<const N: usize>(&self, cx: usize, dy: isize) -> &'a [u8; N] {
        debug_assert!((-7..=7).contains(&dy) && cx + N <= self.w);
        let row = (self.cs as isize + dy * self.w as isize) as usize;
        // SAFETY: as in `bytes`, with s and cs (y - 7 >= r0 and rows up to
        // y + 7 in s: the invariant of `in_band`).
        unsafe { &*self.s.as_ptr().add(row + cx).cast::<[u8; N]>() }
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

dispatch! {
    /// One row of [`support_map_into`]: `out[c] = 1` where `mid[c]` is an
    /// edge, or at least `support` pixels of the 3x3 around it are (which, as
    /// `mid[c]` is then not one, are its 8 neighbours), for `c` in `1..w-1`;
    /// `top`, `bot` are the rows above and below, all of width `w = out.len()`.
    fn support_row(top: &[u8], mid: &[u8], bot: &[u8], support: u32, out: &mut [u8]) {
        let w = out.len();
        if w < 3 {
            return;
        }
        let n = w - 2;
        // the three columns c-1, c, c+1 of each row, as equal-length slices
        let (t, m, b) = (cols3(top, n), cols3(mid, n), cols3(bot, n));
        // at most 9 edges: a threshold above 9 is never met, as with the u32
        let thr = support.min(10) as u8;
        for (i, o) in out[1..n + 1].iter_mut().enumerate() {
            let mut count = 0u8;
            for r in [&t, &m, &b] {
                for col in r {
                    count += (col[i] == EDGE) as u8;
                }
            }
            *o = (m[1][i] == EDGE || count >= thr) as u8;
        }
    }
}

/// Columns `c-1`, `c`, `c+1` of `row` for `c` in `1..=n`, as three slices of length `n`.
#[inline(always)]
fn cols3(row: &[u8], n: usize) -> [&[u8]; 3] {
    [&row[0..n], &row[1..n + 1], &row[2..n + 2]]
}

/// Step 4 for every pixel q of `e` (see [`super::supports`]), in the first
/// `w * h` bytes of `s` (grown to hold them, never shrunk): 1 where q is an
/// edge or at least `support` of its 8 neighbours are, else 0. Only the first and last row and column are left
/// as they were (corner tests never read them: q lies at most 6 pixels from
/// p, p at least 7 from every side), so `s` can be reused without clearing.
#[cfg(test)]
pub(super) fn support_map_into(e: &Plane<u8>, support: u32, s: &mut Vec<u8>) {
    use rayon::prelude::*;
    let (w, h) = (e.width as usize, e.height as usize);
    // a smaller level after a larger one clears nothing; a larger one takes
    // a fresh zeroed allocation (no copy of the old map, no clearing)
    if s.len() < w * h {
        *s = vec![0; w * h];
    }
    if w >= 3 && h >= 3 {
        s[w..(h - 1) * w].par_chunks_mut(w).enumerate().for_each(|(k, out)| {
            let rows = &e.data[k * w..(k + 3) * w];
            support_row(&rows[..w], &rows[w..2 * w], &rows[2 * w..], support, out);
        });
    }
}

/// [`support_map_into`]'s rows `r0..r1` only (clamped to the plane), row
/// `r0` first, in `s` (grown to hold them, never shrunk; the first and last
/// row and column of the plane are left as they were, as there): what a band
/// of the L-FAST scan reads, rows `y-7..=y+7` of each of its rows y. A band
/// of 64 rows computes 78 support rows (the seven above and below again),
/// and a thread keeps a buffer of 78 rows instead of a level's map.
pub(super) fn support_rows_into(e: &Plane<u8>, support: u32, r0: usize, r1: usize, s: &mut Vec<u8>) {
    let (w, h) = (e.width as usize, e.height as usize);
    let r1 = r1.min(h);
    if r1 <= r0 {
        return;
    }
    if s.len() < (r1 - r0) * w {
        *s = vec![0; (r1 - r0) * w];
    }
    if w < 3 || h < 3 {
        return;
    }
    for y in r0.max(1)..r1.min(h - 1) {
        let rows = &e.data[(y - 1) * w..(y + 2) * w];
        let out = &mut s[(y - r0) * w..(y - r0 + 1) * w];
        support_row(&rows[..w], &rows[w..2 * w], &rows[2 * w..], support, out);
    }
}

/// Per circle mask, bit t set where t is the middle of one of its branches
/// ([`super::branch_mid`] of each of [`super::for_each_branch`]):
/// 128 KiB, built once. Branch mode decides from it without a data-dependent
/// loop or branch per pixel.
fn branch_mids() -> &'static [u16; 65536] {
    static MIDS: std::sync::OnceLock<Box<[u16; 65536]>> = std::sync::OnceLock::new();
    MIDS.get_or_init(|| {
        let mut t = Box::new([0u16; 65536]);
        for (mask, mids) in t.iter_mut().enumerate() {
            super::for_each_branch(mask as u32, |s, len| *mids |= 1 << super::branch_mid(s, len));
        }
        t
    })
}

/// [`super::is_corner`]'s decision from p's circle mask and its support mask
/// (bit t set where `q_t` supports p, [`super::supports`]), branch-free.
#[inline(always)]
pub(super) fn decide(mask: u32, sup: u32, p: &LfastParams, mids: &[u16; 65536]) -> bool {
    match p.mode {
        Mode::Paper => {
            // at least two points, not just two opposite ones, and two supported
            let n = mask.count_ones();
            let opposite = 31u32.wrapping_sub(mask.leading_zeros()).wrapping_sub(mask.trailing_zeros()) == 8;
            (n > 2) | ((n == 2) & !opposite) && (mask & sup).count_ones() >= 2
        }
        Mode::Branch => {
            // supported branch middles: three, or two that are not a straight line
            // (one branch, none, and the full circle have fewer than two middles)
            let s = mids[mask as usize & 0xffff] as u32 & sup;
            // the two middles' distance (meaningless, and unused, unless c == 2)
            let d = 31u32.wrapping_sub(s.leading_zeros()).wrapping_sub(s.trailing_zeros());
            let straight = d.min(16u32.wrapping_sub(d)) >= 8u32.saturating_sub(p.straight_tol);
            let c = s.count_ones();
            (c >= 3) | ((c == 2) & !straight)
        }
    }
}

/// [`decide`] in paper mode for 32 pixels at once, in u16 lanes (LLVM
/// vectorises the loop): bit j set where `masks[j]`, `sups[j]` make a
/// corner. With `s = mask & sup`, "two supported" is `s & (s - 1) != 0`, and
/// it implies n >= 2; the one case it then leaves out, exactly two points
/// and opposite (bits t and t + 8), is `lo == hi` with one bit in `lo` (the
/// mask's low and high bytes). Checked against [`decide`] in
/// `tests::paper_bits_equals_decide`.
#[inline(always)]
fn paper_bits(masks: &[u16; CHUNK], sups: &[u16; CHUNK]) -> u32 {
    let mut ok = [0u8; CHUNK];
    for (o, (&m, &sup)) in ok.iter_mut().zip(masks.iter().zip(sups)) {
        let s = m & sup;
        let (lo, hi) = (m & 0xff, m >> 8);
        let two_supported = s & s.wrapping_sub(1) != 0;
        let two_opposite = (lo == hi) & (lo & lo.wrapping_sub(1) == 0);
        *o = (two_supported & !two_opposite) as u8;
    }
    eq_bits(&ok, 1)
}

/// Circle masks of the 32 pixels `xs..xs+32` of the window's row.
///
/// # Safety
/// `7 <= xs` and `xs + 32 <= w - 7`.
#[inline(always)]
unsafe fn chunk_masks<const AVX2: bool>(win: &Window<'_>, xs: usize) -> [u16; CHUNK] {
    // SAFETY: |dx|, |dy| <= 3, so xs + dx >= 4 and xs + dx + 32 <= w - 4.
    let rows: [&[u8; CHUNK]; 16] = std::array::from_fn(|i| unsafe {
        win.bytes((xs as isize + CIRCLE[i].0 as isize) as usize, CIRCLE[i].1 as isize)
    });
    // SAFETY: AVX2 is only set by `scan_row`'s AVX2 build
    unsafe { masks_of::<AVX2>(&rows, EDGE) }
}

/// Support masks of the 32 pixels `xs..xs+32`: bit t of entry j set where
/// `q_t = p + 2 CIRCLE[t]` of p = (xs + j, y) supports p (the support map is 1 there).
///
/// # Safety
/// `7 <= xs` and `xs + 32 <= w - 7`.
#[inline(always)]
unsafe fn chunk_supports<const AVX2: bool>(win: &Window<'_>, xs: usize) -> [u16; CHUNK] {
    // SAFETY: |2dx|, |2dy| <= 6, so xs + 2dx >= 1 and xs + 2dx + 32 <= w - 1.
    let rows: [&[u8; CHUNK]; 16] = std::array::from_fn(|i| unsafe {
        win.support_bytes((xs as isize + 2 * CIRCLE[i].0 as isize) as usize, 2 * CIRCLE[i].1 as isize)
    });
    // SAFETY: as in chunk_masks
    unsafe { masks_of::<AVX2>(&rows, 1) }
}

/// [`bit_masks`], by [`bit_masks_avx2`] when `AVX2`.
///
/// # Safety
/// With `AVX2`, the CPU has AVX2.
#[inline(always)]
unsafe fn masks_of<const AVX2: bool>(rows: &[&[u8; CHUNK]; 16], v: u8) -> [u16; CHUNK] {
    #[cfg(target_arch = "x86_64")]
    if AVX2 {
        // SAFETY: the caller's contract
        return unsafe { bit_masks_avx2(rows, v) };
    }
    bit_masks(rows, v)
}

/// Bit i of entry j set where `rows[i][j] == v`.
#[inline(always)]
fn bit_masks(rows: &[&[u8; CHUNK]; 16], v: u8) -> [u16; CHUNK] {
    let mut masks = [0u16; CHUNK];
    for (j, m) in masks.iter_mut().enumerate() {
        // bytes, not u16 lanes: twice the pixels per vector
        let (mut lo, mut hi) = (0u8, 0u8);
        for i in 0..8 {
            lo |= ((rows[i][j] == v) as u8) << i;
            hi |= ((rows[i + 8][j] == v) as u8) << i;
        }
        *m = lo as u16 | (hi as u16) << 8;
    }
    masks
}

/// [`bit_masks`] with AVX2, in bytes: bits 0-7 of all 32 pixels in one
/// register and bits 8-15 in another (a compare, an AND and an OR per row),
/// then interleaved into the 32 u16. LLVM vectorises [`bit_masks`] in u16
/// lanes, half the pixels per instruction. Checked against it in
/// `tests::bit_masks_avx2_equals_scalar`.
///
/// # Safety
/// The CPU has AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn bit_masks_avx2(rows: &[&[u8; CHUNK]; 16], v: u8) -> [u16; CHUNK] {
    use std::arch::x86_64::*;
    let vv = _mm256_set1_epi8(v as i8);
    let (mut lo, mut hi) = (_mm256_setzero_si256(), _mm256_setzero_si256());
    for i in 0..8 {
        let bit = _mm256_set1_epi8(1 << i);
        // SAFETY: each row is 32 bytes, one unaligned 32-byte load
        let (a, b) = unsafe {
            (
                _mm256_loadu_si256(rows[i].as_ptr().cast::<__m256i>()),
                _mm256_loadu_si256(rows[i + 8].as_ptr().cast::<__m256i>()),
            )
        };
        lo = _mm256_or_si256(lo, _mm256_and_si256(_mm256_cmpeq_epi8(a, vv), bit));
        hi = _mm256_or_si256(hi, _mm256_and_si256(_mm256_cmpeq_epi8(b, vv), bit));
    }
    // per 128-bit lane, (lo, hi) byte pairs: pixels 0-7 | 16-23 and 8-15 | 24-31
    let (a, b) = (_mm256_unpacklo_epi8(lo, hi), _mm256_unpackhi_epi8(lo, hi));
    let mut masks = [0u16; CHUNK];
    // SAFETY: two unaligned 32-byte stores into the 64 bytes of `masks`
    unsafe {
        _mm256_storeu_si256(masks.as_mut_ptr().cast::<__m256i>(), _mm256_permute2x128_si256(a, b, 0x20));
        _mm256_storeu_si256(masks.as_mut_ptr().add(16).cast::<__m256i>(), _mm256_permute2x128_si256(a, b, 0x31));
    }
    masks
}

dispatch_avx2! {
    /// Appends to `out` the corners `[x, y]` of the window's row `y` with x in
    /// `x0..x1` (raster order), where `mrow` (if any) is non-zero. Needs
    /// `7 <= x0`, `x1 + 7 <= w` and `x1 - x0 >= 32` (panics otherwise).
    pub(super) fn scan_row<const AVX2>(win: &Window<'_>, y: u32, x0: usize, x1: usize, mrow: Option<&[u8]>,
                                       p: &LfastParams, out: &mut Vec<[u32; 2]>) {
        assert!(x0 >= 7 && x1 + 7 <= win.w && x1 >= x0 + CHUNK, "scan_row: columns {x0}..{x1} of {}", win.w);
        let mids = branch_mids();
        let mut xs = x0;
        let mut skip = 0; // pixels at the start of this chunk done by the one before
        loop {
            // SAFETY: xs >= x0 >= 7 and xs + 32 <= x1, x1 + 7 <= w, asserted above
            let mut bits = eq_bits(unsafe { win.bytes(xs, 0) }, EDGE);
            if let Some(m) = mrow {
                for (j, &v) in m[xs..xs + CHUNK].iter().enumerate() {
                    bits &= !(((v == 0) as u32) << j);
                }
            }
            bits &= u32::MAX << skip;
            if bits != 0 {
                // SAFETY: as above; AVX2 only from the AVX2 build
                let (masks, sups) = unsafe { (chunk_masks::<AVX2>(win, xs), chunk_supports::<AVX2>(win, xs)) };
                if p.mode == Mode::Paper {
                    // all 32 decisions at once, then only the corners visited
                    bits &= paper_bits(&masks, &sups);
                    while bits != 0 {
                        out.push([(xs + bits.trailing_zeros() as usize) as u32, y]);
                        bits &= bits - 1;
                    }
                } else {
                    while bits != 0 {
                        let j = bits.trailing_zeros() as usize;
                        bits &= bits - 1;
                        if decide(masks[j] as u32, sups[j] as u32, p, mids) {
                            out.push([(xs + j) as u32, y]);
                        }
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
    #[cfg(target_arch = "x86_64")]
    fn bit_masks_avx2_equals_scalar() {
        if !std::is_x86_feature_detected!("avx2") {
            return;
        }
        let mut r = SplitMix64::new(7);
        for round in 0..200 {
            // values around the two compared (EDGE, 1), and all bytes
            let rows: Vec<[u8; CHUNK]> = (0..16)
                .map(|_| {
                    std::array::from_fn(|_| {
                        let v = r.next_u64();
                        if round % 2 == 0 { [0, 1, 2, EDGE, 254][(v % 5) as usize] } else { v as u8 }
                    })
                })
                .collect();
            let refs: [&[u8; CHUNK]; 16] = std::array::from_fn(|i| &rows[i]);
            for v in [EDGE, 1, 0] {
                // SAFETY: AVX2 checked above
                assert_eq!(unsafe { bit_masks_avx2(&refs, v) }, bit_masks(&refs, v), "round {round} value {v}");
            }
        }
    }

    #[test]
    fn paper_bits_equals_decide() {
        let p = LfastParams { mode: Mode::Paper, support: 3, straight_tol: 1, border: 7 };
        let mids = branch_mids();
        let mut r = SplitMix64::new(11);
        // every mask, each with supports: none, all, itself, random, random subsets of it
        for chunk in 0..65536 / CHUNK {
            let masks: [u16; CHUNK] = std::array::from_fn(|j| (chunk * CHUNK + j) as u16);
            for k in 0..8 {
                let sups: [u16; CHUNK] = std::array::from_fn(|j| match k {
                    0 => 0,
                    1 => u16::MAX,
                    2 => masks[j],
                    3 | 4 => r.next_u64() as u16,
                    _ => masks[j] & r.next_u64() as u16 & r.next_u64() as u16,
                });
                let want =
                    (0..CHUNK).fold(0u32, |b, j| b | (decide(masks[j] as u32, sups[j] as u32, &p, mids) as u32) << j);
                assert_eq!(paper_bits(&masks, &sups), want, "masks from {} sups kind {k}", chunk * CHUNK);
            }
        }
    }

    #[test]
    fn circle_offsets_within_three() {
        // the SAFETY arguments of chunk_masks and chunk_supports rely on this
        assert!(CIRCLE.iter().all(|&(dx, dy)| dx.abs() <= 3 && dy.abs() <= 3));
    }

    #[test]
    fn window_refuses_missing_rows() {
        let e = Plane::<u8>::new(20, 20);
        let s = vec![0u8; 400];
        assert!(Window::new(&e, &s, 6).is_none());
        assert!(Window::new(&e, &s, 7).is_some() && Window::new(&e, &s, 12).is_some());
        assert!(Window::new(&e, &s, 13).is_none());
        assert!(Window::new(&e, &s[..399], 12).is_none());
        assert!(Window::new(&Plane::<u8>::new(14, 20), &s, 10).is_none());
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
            let mut smap = Vec::new();
            support_map_into(&e, support, &mut smap);
            for y in 7..h as usize - 7 {
                let win = Window::new(&e, &smap, y).expect("rows inside");
                let mut xs = 7;
                while xs + CHUNK <= w as usize - 7 {
                    // SAFETY: 7 <= xs, xs + 32 <= w - 7
                    let (masks, sups) = unsafe { (chunk_masks::<false>(&win, xs), chunk_supports::<false>(&win, xs)) };
                    for (j, (&m, &sup)) in masks.iter().zip(&sups).enumerate() {
                        let (x, yi) = ((xs + j) as i32, y as i32);
                        proptest::prop_assert_eq!(m as u32, circle_mask(&e, x, yi));
                        for t in 0..16 {
                            let got = sup >> t & 1 == 1;
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
