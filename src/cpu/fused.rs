//! The fast path of SPEC 1-7 that detection uses: the same function as the
//! staged modules (median -> ... -> hysteresis), computed in two row-parallel
//! passes, a small serial step between them and a serial seam flood, with
//! vectorisable row kernels instead of nine full-image stages
//! (docs/algorithm.md, "The fast path", says why each rewrite is exact).
//! `tests` and the golden files check that it is bit-identical to [`edge_map`](super::edge_map).
//!
//! 1. per cell row: median rows -> D (plus the next band's first row,
//!    recomputed), then
//! 2. LSD gradient rows -> M8 + cell histograms, and S and the direction
//!    sector in padded planes on a small level (see [`KEEP_GRADIENT_MAX`];
//!    a large level's rows here compute M8 alone)
//! 3. Otsu and window statistics from the cell histograms (tiny), turned into
//!    four integer thresholds on S per run of columns: S >= hi is STRONG, >= lo WEAK_STRONG, ...
//! 4. per band of rows: S and sector rows from those planes, or on a large
//!    level the gradient rows of D again into a ring of three padded S and
//!    sector rows (S and the sector alone); NMS + classification into a ring of three padded class
//!    rows, rules rows -> ruled classes in E and the list of WEAK pixels, then
//!    hysteresis within the band
//! 5. hysteresis across the bands' seams -> E
//!
//! So on a large level the only full planes are D and E (docs/pipeline.md,
//! "Memory"): a plane of S (u32) and one of sectors would cost 5 bytes per
//! pixel, more to fault in and stream through memory than the gradient costs
//! to compute twice. A small level's planes stay in cache, where computing
//! the gradient twice costs more than keeping them.

use super::classify::{EDGE, NONE, STRONG, WEAK, WEAK_STRONG, WEAK_WEAK};
use super::local_threshold::{BandHistograms, Cells};
use super::simd::{CHUNK, chunk, chunk_n, chunk_starts, chunk_starts_n, dispatch, for_each_eq};
use super::{hysteresis, median};
use crate::image::{GrayView, Plane};
use rayon::prelude::*;

#[cfg(target_arch = "x86_64")]
mod gradient_x86;

/// D and E of one image.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FastEdges {
    /// The flagged-median output (SPEC 1).
    pub denoised: Plane<u8>,
    /// The edge map (SPEC 7): 255 on edges.
    pub edges: Plane<u8>,
}

/// `isqrt(s)` for `s <= 2 * 510^2`: f32 holds s exactly and the correctly
/// rounded square root never reaches the next integer below 2^20 (tested
/// over the whole range), and it vectorises.
#[inline(always)]
pub fn sqrt_floor(s: u32) -> u32 {
    let r = (s.min(2 * 510 * 510) as i32 as f32).sqrt();
    // SAFETY: r is finite and in [0, 722] (the min keeps any input in range), so the truncating conversion is
    // defined; unlike `as`, it needs no saturation checks and vectorises.
    unsafe { r.to_int_unchecked::<i32>() as u32 }
}

/// SPEC 3's sector as a code: 0 horizontal, 1 vertical, 2 diagonal with equal
/// signs, 3 diagonal with opposite signs.
#[inline(always)]
fn sector_code(dx: i32, dy: i32) -> u8 {
    let ax = dx.unsigned_abs();
    let ay = dy.unsigned_abs();
    let horizontal = (ay * 32768 < 13573 * ax) as u8;
    let vertical = (ay * 32768 > 79109 * ax) as u8;
    let opposite = ((dx > 0) != (dy > 0)) as u8;
    let diagonal = 1 - (horizontal | vertical);
    vertical + diagonal * (2 + opposite)
}

/// `num / den` in lowest terms when both fit the 16-bit median kernel
/// (`den * |g - n|` and `num * g` at most 255 * 257 < 2^16), else `None`.
fn small_ratio(num: u32, den: u32) -> Option<(u16, u16)> {
    let g = {
        let (mut a, mut b) = (num, den);
        while b != 0 {
            (a, b) = (b, a % b);
        }
        a.max(1)
    };
    let (p, q) = (num / g, den / g);
    (p <= 257 && q <= 257).then_some((p as u16, q as u16))
}

/// Interior of one median row (x in 1..w-1): flags noise pixels,
/// `den * |g - n| > num * g` for all four neighbours, in lanes of `T`, and
/// writes the 3x3 median where flagged, `mid` elsewhere. Per chunk of `C`
/// pixels (32, or 64 at the AVX-512 tier) the flags come first; a chunk with
/// any flag computes every pixel's median (branch-free, `C` lanes of u8
/// min/max) and selects, which costs less than one scalar median per flagged
/// pixel; a chunk without is a copy.
#[inline(always)]
fn median_interior<T, const C: usize>(up: &[u8], mid: &[u8], down: &[u8], out: &mut [u8], num: T, den: T)
where
    T: Copy + Ord + From<u8> + std::ops::Sub<Output = T> + std::ops::Mul<Output = T>,
{
    let w = mid.len();
    let (up, down, out) = (&up[..w], &down[..w], &mut out[..w]);
    let flag = |u: u8, l: u8, c: u8, r: u8, d: u8| {
        let g = T::from(c);
        let lim = num * g;
        let far = |n: u8| {
            let n = T::from(n);
            den * (g.max(n) - g.min(n)) > lim
        };
        far(u) & far(d) & far(l) & far(r)
    };
    let med = |x: usize| {
        median::median9([
            up[x - 1],
            up[x],
            up[x + 1],
            mid[x - 1],
            mid[x],
            mid[x + 1],
            down[x - 1],
            down[x],
            down[x + 1],
        ])
    };
    if w < C + 2 {
        for x in 1..w - 1 {
            out[x] = if flag(up[x], mid[x - 1], mid[x], mid[x + 1], down[x]) { med(x) } else { mid[x] };
        }
        return;
    }
    for x0 in chunk_starts_n::<C>(1, w - 1) {
        let (u, d) = (chunk_n::<C, _>(up, x0), chunk_n::<C, _>(down, x0));
        let (l, c, r) = (chunk_n::<C, _>(mid, x0 - 1), chunk_n::<C, _>(mid, x0), chunk_n::<C, _>(mid, x0 + 1));
        // A plain loop, not `array::from_fn`: that one is not inlined into
        // the AVX2 build and ran scalar (4% of a frame in perf).
        let mut flags = [false; C];
        for t in 0..C {
            flags[t] = flag(u[t], l[t], c[t], r[t], d[t]);
        }
        let o: &mut [u8; C] = (&mut out[x0..x0 + C]).try_into().expect("C bytes");
        if flags.iter().fold(false, |a, &f| a | f) {
            // (four calls, not an array's `map`: that one was called out of
            // line, with a vzeroupper and spills, once per chunk)
            let (ul, ur, dl, dr) = (
                chunk_n::<C, _>(up, x0 - 1),
                chunk_n::<C, _>(up, x0 + 1),
                chunk_n::<C, _>(down, x0 - 1),
                chunk_n::<C, _>(down, x0 + 1),
            );
            for t in 0..C {
                let m = median::median9([ul[t], u[t], ur[t], l[t], c[t], r[t], dl[t], d[t], dr[t]]);
                o[t] = if flags[t] { m } else { c[t] };
            }
        } else {
            *o = *c;
        }
    }
}

dispatch! {
    /// [`median_interior`] on 16-bit lanes, twice as many per vector, for a small
    /// ratio `num / den` (see [`small_ratio`]).
    fn median_row16(up: &[u8], mid: &[u8], down: &[u8], out: &mut [u8], num: u16, den: u16) {
        if wide_chunks(mid.len()) {
            median_interior::<_, 64>(up, mid, down, out, num, den)
        } else {
            median_interior::<_, CHUNK>(up, mid, down, out, num, den)
        }
    }
}

dispatch! {
    /// [`median_interior`] on 32-bit lanes, for any ratio.
    fn median_row(up: &[u8], mid: &[u8], down: &[u8], out: &mut [u8], num: u32, den: u32) {
        if wide_chunks(mid.len()) {
            median_interior::<_, 64>(up, mid, down, out, num, den)
        } else {
            median_interior::<_, CHUNK>(up, mid, down, out, num, den)
        }
    }
}

/// Whether a median or rules row of `w` pixels takes 64 pixels a step: at
/// the AVX-512 tier (a vector of 64 bytes; the median 1.5x faster than 32 a
/// step there), on rows of at least 66 pixels. Either width computes the
/// same bytes.
#[inline(always)]
fn wide_chunks(w: usize) -> bool {
    w >= 64 + 2 && super::simd::tier() == super::simd::Tier::Avx512
}

/// One gradient row from D rows y and y+1 (clamped by the caller): S, the
/// sector code and M8 of each column. At the AVX2 and AVX-512 tiers the
/// columns before the last come from [`gradient_x86::gradient_cols`] or
/// [`gradient_x86::gradient_cols_avx512`], the last from [`gradient_tail`].
/// A large level's two passes each take only what they use: M8 for the
/// histograms (`S_SEC = false`), S and the sector for the NMS (`M8 =
/// false`); the slices of the other outputs then hold only the tail's columns.
fn gradient_row<const S_SEC: bool, const M8: bool>(r0: &[u8], r1: &[u8], s: &mut [u32], sec: &mut [u8], m8: &mut [u8]) {
    // SAFETY: `tier` never exceeds `detected_tier`.
    unsafe { gradient_row_at::<S_SEC, M8>(super::simd::tier(), r0, r1, s, sec, m8) }
}

/// [`gradient_row`] at tier `t` (the tests run each tier's kernel).
///
/// # Safety
/// `t <= detected_tier()`: the CPU has the tier's features.
#[inline(always)]
unsafe fn gradient_row_at<const S_SEC: bool, const M8: bool>(
    t: super::simd::Tier,
    r0: &[u8],
    r1: &[u8],
    s: &mut [u32],
    sec: &mut [u8],
    m8: &mut [u8],
) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: the tier's features are the CPU's, by the contract.
    let done = match t {
        super::simd::Tier::Avx512 => unsafe { gradient_x86::gradient_cols_avx512::<S_SEC, M8>(r0, r1, s, sec, m8) },
        super::simd::Tier::Avx2 => unsafe { gradient_x86::gradient_cols::<S_SEC, M8>(r0, r1, s, sec, m8) },
        super::simd::Tier::Baseline => 0,
    };
    #[cfg(not(target_arch = "x86_64"))]
    let done = {
        let _ = t;
        0
    };
    gradient_tail(r0, r1, s, sec, m8, done);
}

dispatch! {
    /// Columns `from..w` of [`gradient_row`] (the whole row from 0: the scalar reference).
    fn gradient_tail(r0: &[u8], r1: &[u8], s: &mut [u32], sec: &mut [u8], m8: &mut [u8], from: usize) {
        let w = r0.len();
        let (r1, s, sec, m8) = (&r1[..w], &mut s[..w], &mut sec[..w], &mut m8[..w]);
        for x in from..w - 1 {
            let (a, b, c, e) = (r0[x] as i32, r0[x + 1] as i32, r1[x] as i32, r1[x + 1] as i32);
            let dx = b + e - a - c;
            let dy = c + e - a - b;
            let sq = (dx * dx + dy * dy) as u32;
            s[x] = sq;
            sec[x] = sector_code(dx, dy);
            m8[x] = (sqrt_floor(sq) >> 1).min(255) as u8;
        }
        // last column: x + 1 clamps to x
        let l = w - 1;
        let dy = r1[l] as i32 - r0[l] as i32;
        let dy = 2 * dy;
        s[l] = (dy * dy) as u32;
        sec[l] = sector_code(0, dy);
        m8[l] = (sqrt_floor(s[l]) >> 1).min(255) as u8;
    }
}

/// The integer thresholds of one run of columns that use the same window, on
/// S = dx² + dy² so that no square root is taken per pixel: with
/// M = isqrt(S) >> 1, M >= t exactly when S >= (2t)². `t` is `[hi, lo, whi,
/// wlo]`: S >= hi is STRONG, else >= lo WEAK_STRONG, >= whi WEAK, >= wlo
/// WEAK_WEAK (SPEC 6 as integers). A window row is a list of such runs, about
/// W/10 columns each, so the row kernel compares against constants.
#[derive(Clone, Copy, Debug)]
struct Piece {
    x0: usize,
    x1: usize,
    t: [u32; 4],
}

/// The least S whose magnitude `isqrt(S) >> 1` reaches `t`.
#[inline(always)]
fn s_of_m(t: u32) -> u32 {
    (2 * t) * (2 * t)
}

/// All-ones when `c`, else 0 (for branch-free selects that vectorise).
#[inline(always)]
fn mask(c: bool) -> u32 {
    0u32.wrapping_sub(c as u32)
}

dispatch! {
    /// NMS and classification of one row. `su`, `s`, `sd`, `sec` and `out` are
    /// padded rows of `w + 2` (column x at index x + 1, zeros outside the
    /// image, so the borders need no special case); `pieces` cover 0..w.
    fn classify_row(su: &[u32], s: &[u32], sd: &[u32], sec: &[u8], pieces: &[Piece], out: &mut [u8]) {
        let w = s.len() - 2;
        // left, centre and right neighbours of column t, all of length w
        fn lcr(r: &[u32], w: usize) -> (&[u32], &[u32], &[u32]) {
            (&r[..w], &r[1..w + 1], &r[2..w + 2])
        }
        let ((ul, uc, ur), (sl, sc, sr), (dl, dc, dr)) = (lcr(su, w), lcr(s, w), lcr(sd, w));
        let (sec, out) = (&sec[1..w + 1], &mut out[1..w + 1]);
        for &Piece { x0, x1, t: th } in pieces {
            if x1 - x0 < CHUNK {
                for t in x0..x1 {
                    let n = [ul[t], uc[t], ur[t], sl[t], sc[t], sr[t], dl[t], dc[t], dr[t]];
                    out[t] = class_of_s(n, sec[t], th);
                }
                continue;
            }
            for t0 in chunk_starts(x0, x1) {
                let sc_ = chunk(sc, t0);
                let o: &mut [u8; CHUNK] = (&mut out[t0..t0 + CHUNK]).try_into().expect("CHUNK bytes");
                // Most pixels lie below every threshold: such a chunk is all NONE.
                if sc_.iter().fold(false, |a, &v| a | (v as i32 >= th[3] as i32)) {
                    let [ul, uc, ur, sl, sr, dl, dc, dr] = [ul, uc, ur, sl, sr, dl, dc, dr].map(|r| chunk(r, t0));
                    let sec = chunk(sec, t0);
                    for t in 0..CHUNK {
                        let n = [ul[t], uc[t], ur[t], sl[t], sc_[t], sr[t], dl[t], dc[t], dr[t]];
                        o[t] = class_of_s(n, sec[t], th);
                    }
                } else {
                    *o = [NONE; CHUNK];
                }
            }
        }
    }
}

/// NMS and classification of one pixel: `n` is S of its 3x3 neighbourhood in
/// row-major order, `k` its sector code, `t` its thresholds `[hi, lo, whi, wlo]`.
#[inline(always)]
fn class_of_s(n: [u32; 9], k: u8, t: [u32; 4]) -> u8 {
    // S <= 2 * 510² and the thresholds <= 510² fit i32: signed compares are
    // one instruction each in vector lanes, unsigned ones two or three
    let [ul, uc, ur, sl, v, sr, dl, dc, dr] = n.map(|s| s as i32);
    let [hi, lo, whi, wlo] = t.map(|s| s as i32);
    let (k0, k1, k2, k3) = (mask(k == 0) as i32, mask(k == 1) as i32, mask(k == 2) as i32, mask(k == 3) as i32);
    // neighbours across the gradient: `a` must be beaten, `b` matched
    let a = (sl & k0) | (uc & k1) | (ul & k2) | (ur & k3);
    let b = (sr & k0) | (dc & k1) | (dr & k2) | (dl & k3);
    let keep = ((v > 0) & (v > a) & (v >= b)) as u8;
    // hi >= lo and whi >= wlo, so first-match is: >= lo ? 3 + (>= hi) : (>= wlo) + (>= whi)
    let ge_lo = (v >= lo) as u8;
    let strongish = 3 + (v >= hi) as u8;
    let weakish = (v >= wlo) as u8 + (v >= whi) as u8;
    keep * (ge_lo * strongish + (1 - ge_lo) * weakish)
}

dispatch! {
    /// Rules 1 and 2 on one row, from padded class rows of `w + 2` (zeros
    /// outside the image: NONE is neither WEAK_STRONG nor WEAK_WEAK, so the
    /// borders need no special case) into `out` (`w`). STRONG is written as
    /// EDGE, which it becomes in hysteresis anyway (see `hysteresis::flood_seams`).
    fn rules_row(cu: &[u8], c: &[u8], cd: &[u8], out: &mut [u8]) {
        if wide_chunks(out.len()) {
            rules_in::<64>(cu, c, cd, out)
        } else {
            rules_in::<CHUNK>(cu, c, cd, out)
        }
    }
}

/// [`rules_row`]'s loop, `C` columns a step, the last step overlapping the
/// one before (no scalar remainder, which had been up to 63 columns a row).
#[inline(always)]
fn rules_in<const C: usize>(cu: &[u8], c: &[u8], cd: &[u8], out: &mut [u8]) {
    let w = out.len();
    let (cu, c, cd) = (&cu[..w + 2], &c[..w + 2], &cd[..w + 2]);
    if w < C {
        for x in 0..w {
            let n = [cu[x], cu[x + 1], cu[x + 2], c[x], c[x + 2], cd[x], cd[x + 1], cd[x + 2]];
            out[x] = rule_of(n, c[x + 1]);
        }
        return;
    }
    for x0 in chunk_starts_n::<C>(0, w) {
        let o: &mut [u8; C] = (&mut out[x0..x0 + C]).try_into().expect("C bytes");
        let v = chunk_n::<C, _>(c, x0 + 1);
        // most chunks are all NONE, which stays NONE
        if v.iter().fold(0, |a, &b| a | b) == NONE {
            *o = [NONE; C];
            continue;
        }
        // (calls, not an array's `map`, which is not inlined: see median_interior)
        fn at<const C: usize>(row: &[u8], x: usize) -> &[u8; C] {
            chunk_n::<C, u8>(row, x)
        }
        let (ul, uc, ur) = (at::<C>(cu, x0), at::<C>(cu, x0 + 1), at::<C>(cu, x0 + 2));
        let (l, r) = (at::<C>(c, x0), at::<C>(c, x0 + 2));
        let (dl, dc, dr) = (at::<C>(cd, x0), at::<C>(cd, x0 + 1), at::<C>(cd, x0 + 2));
        for t in 0..C {
            o[t] = rule_of([ul[t], uc[t], ur[t], l[t], r[t], dl[t], dc[t], dr[t]], v[t]);
        }
    }
}

/// Rules 1 and 2 for one pixel of class `v` whose 8 neighbours' classes are `n`.
#[inline(always)]
fn rule_of(n: [u8; 8], v: u8) -> u8 {
    let mut ws = false;
    let mut ww = false;
    for c in n {
        ws |= c == WEAK_STRONG;
        ww |= c == WEAK_WEAK;
    }
    if v == WEAK_STRONG {
        if ws { EDGE } else { WEAK }
    } else if v == WEAK_WEAK {
        if ww { NONE } else { WEAK }
    } else if v == STRONG {
        EDGE
    } else {
        v
    }
}

/// Calls `f(x)` for each nonzero byte of `v`, skipping zero runs 8 bytes at a
/// time (flags and classes are mostly zero).
#[inline]
pub(crate) fn for_each_nonzero(v: &[u8], mut f: impl FnMut(usize)) {
    let mut x = 0;
    while x + 8 <= v.len() {
        let word = u64::from_le_bytes(v[x..x + 8].try_into().expect("8 bytes"));
        let mut bits = word;
        while bits != 0 {
            let k = bits.trailing_zeros() as usize / 8;
            f(x + k);
            bits &= !(0xffu64 << (8 * k));
        }
        x += 8;
    }
    for (k, &b) in v[x..].iter().enumerate() {
        if b != 0 {
            f(x + k);
        }
    }
}

/// Splits a plane's rows at the given row cuts into mutable bands.
fn bands<'a, T>(data: &'a mut [T], w: usize, cuts: &[u32]) -> Vec<&'a mut [T]> {
    let mut rest = data;
    let mut out = Vec::with_capacity(cuts.len());
    for k in 0..cuts.len() - 1 {
        let (band, tail) = rest.split_at_mut((cuts[k + 1] - cuts[k]) as usize * w);
        out.push(band);
        rest = tail;
    }
    out
}

/// [`bands`] of a kept plane, or one `None` per band when it is not kept.
fn kept_bands<'a, T>(keep: bool, data: &'a mut [T], w: usize, cuts: &[u32]) -> Vec<Option<&'a mut [T]>> {
    if keep { bands(data, w, cuts).into_iter().map(Some).collect() } else { (1..cuts.len()).map(|_| None).collect() }
}

/// Buffers of the fused path, reused from frame to frame: allocating them per
/// frame cost more in page faults than the passes themselves.
#[derive(Clone, Debug, Default)]
pub struct EdgeScratch {
    /// D after [`edges_fused_into`].
    pub denoised: Plane<u8>,
    /// E after [`edges_fused_into`].
    pub edges: Plane<u8>,
    /// S and the sector in padded rows of w + 2, on a level of at most
    /// [`KEEP_GRADIENT_MAX`] pixels; empty on a larger one.
    s: Vec<u32>,
    sec: Vec<u8>,
    thresholds: Vec<Vec<Piece>>,
    /// The window and cell layout of the last image size (levels keep their sizes from frame to frame).
    cells: Option<Cells>,
}

/// Levels of at most this many pixels keep S and the sector as planes from
/// pass 2 to pass 4 (5 bytes per pixel: 2.3 MB at KITTI's 1241x376, which
/// fits in cache); larger ones compute the gradient rows again in pass 4
/// (docs/pipeline.md, "Memory"). Outputs are the same either way.
pub const KEEP_GRADIENT_MAX: usize = 1 << 19;

/// S and sector rows as [`classify_row`] reads them, padded (column x at
/// index x + 1, zeros outside the image, an all-zero S row above the first
/// row and below the last): from the kept planes, or computed from D on
/// demand into three slots (row y in slot y % 3), so that classifying rows in
/// order computes each gradient row once.
struct GradientRing<'a> {
    planes: Option<(&'a [u32], &'a [u8])>,
    s: [Vec<u32>; 3],
    sec: [Vec<u8>; 3],
    /// The row each slot holds.
    row: [Option<usize>; 3],
    zeros: Vec<u32>,
    m8: Vec<u8>,
}

impl<'a> GradientRing<'a> {
    fn new(w: usize, planes: Option<(&'a [u32], &'a [u8])>) -> Self {
        let ring = if planes.is_some() { 0 } else { w + 2 };
        Self {
            planes,
            s: std::array::from_fn(|_| vec![0; ring]),
            sec: std::array::from_fn(|_| vec![0; ring]),
            row: [None; 3],
            zeros: vec![0; w + 2],
            m8: vec![0; ring.saturating_sub(2)],
        }
    }

    /// Computes gradient row `y` of `d` into its slot unless it is there.
    fn fill(&mut self, d: &Plane<u8>, y: usize) {
        let k = y % 3;
        if self.row[k] == Some(y) {
            return;
        }
        let (w, h) = (d.width as usize, d.height as usize);
        // y + 1 clamps to the last row
        let below = d.row((y + 1).min(h - 1) as u32);
        gradient_row::<true, false>(
            d.row(y as u32),
            below,
            &mut self.s[k][1..=w],
            &mut self.sec[k][1..=w],
            &mut self.m8,
        );
        self.row[k] = Some(y);
    }

    /// S of rows y - 1, y, y + 1 and the sectors of row y, padded.
    fn rows(&mut self, d: &Plane<u8>, y: usize) -> (&[u32], &[u32], &[u32], &[u8]) {
        let h = d.height as usize;
        if let Some((s, sec)) = self.planes {
            let ws = d.width as usize + 2;
            let row = |yy: usize| &s[yy * ws..(yy + 1) * ws];
            let up = if y == 0 { &self.zeros[..] } else { row(y - 1) };
            let down = if y + 1 == h { &self.zeros[..] } else { row(y + 1) };
            return (up, row(y), down, &sec[y * ws..(y + 1) * ws]);
        }
        for yy in y.saturating_sub(1)..=(y + 1).min(h - 1) {
            self.fill(d, yy);
        }
        let Self { s, sec, zeros, .. } = self;
        let up = if y == 0 { &zeros[..] } else { &s[(y - 1) % 3][..] };
        let down = if y + 1 == h { &zeros[..] } else { &s[(y + 1) % 3][..] };
        (up, &s[y % 3], down, &sec[y % 3])
    }
}

/// Rows per task of the NMS + classification + rules pass (each task
/// classifies two rows more than it rules).
const BAND_ROWS: usize = 32;

/// D and E of `img` (SPEC 1-7), equal to [`edge_map`](super::edge_map)'s.
pub fn edges_fused(img: &Plane<u8>, delta_num: u32, delta_den: u32, alpha_pct: u32) -> FastEdges {
    let mut sc = EdgeScratch::default();
    edges_fused_into(img.view(), delta_num, delta_den, alpha_pct, &mut sc);
    FastEdges { denoised: sc.denoised, edges: sc.edges }
}

/// [`edges_fused`] into reused buffers: D and E end up in `sc.denoised` and `sc.edges`.
/// `img` is borrowed row by row (any stride), so a caller's frame needs no copy.
pub fn edges_fused_into(img: GrayView<'_>, delta_num: u32, delta_den: u32, alpha_pct: u32, sc: &mut EdgeScratch) {
    edges_fused_keeping(img, delta_num, delta_den, alpha_pct, KEEP_GRADIENT_MAX, sc)
}

/// [`edges_fused_into`] with S and the sector kept as planes when the image
/// has at most `keep_max` pixels (the tests run both ways on every size).
fn edges_fused_keeping(
    img: GrayView<'_>,
    delta_num: u32,
    delta_den: u32,
    alpha_pct: u32,
    keep_max: usize,
    sc: &mut EdgeScratch,
) {
    let (w, h) = (img.width() as usize, img.height() as usize);
    if w < 3 || h == 0 {
        // The row kernels need an interior; tiny images take the staged path.
        let em = super::edge_map_with(&img.to_plane(), delta_num, delta_den, alpha_pct);
        sc.denoised = em.denoised;
        sc.edges = em.edges;
        return;
    }
    let EdgeScratch { denoised: d, edges, s, sec, thresholds, cells: layout } = sc;

    // 1. and 2. per cell row, one task each: the band's median rows -> D (and
    //    the first row of the next band, recomputed, for the gradient's y + 1),
    //    then its gradient rows -> the cell histograms of M8, and on a small
    //    level S and the sector in padded rows of w + 2 (see `classify_row`).
    let ratio16 = small_ratio(delta_num, delta_den);
    let median = |y: usize, out: &mut [u8]| {
        let up = img.row(y.saturating_sub(1) as u32);
        let mid = img.row(y as u32);
        let down = img.row((y + 1).min(h - 1) as u32);
        match ratio16 {
            Some((p, q)) => median_row16(up, mid, down, out, p, q),
            None => median_row(up, mid, down, out, delta_num, delta_den),
        }
        // A border pixel is its own clamped left or right neighbour, |G - G| = 0
        // is never above delta G, so it is never noise.
        (out[0], out[w - 1]) = (mid[0], mid[w - 1]);
    };
    let ws = w + 2;
    if layout.as_ref().is_none_or(|c| (c.cx.last(), c.cy.last()) != (Some(&img.width()), Some(&img.height()))) {
        *layout = Some(Cells::new(img.width(), img.height()));
    }
    let layout = layout.as_ref().expect("set just above");
    d.reshape(img.width(), img.height());
    let keep = w * h <= keep_max;
    if keep {
        s.resize(ws * h, 0);
        sec.resize(ws * h, 0);
    } else {
        (*s, *sec) = (Vec::new(), Vec::new());
    }
    let (cx, cy) = (&layout.cx, &layout.cy);
    let (s_bands, sec_bands) = (kept_bands(keep, s, ws, cy), kept_bands(keep, sec, ws, cy));
    let cells: Vec<Vec<[u32; 256]>> = bands(&mut d.data, w, cy)
        .into_par_iter()
        .zip(s_bands)
        .zip(sec_bands)
        .enumerate()
        .map(|(j, ((d_band, mut s_band), mut sec_band))| {
            let (y0, y1) = (cy[j] as usize, cy[j + 1] as usize);
            for (k, out) in d_band.chunks_mut(w).enumerate() {
                median(y0 + k, out);
            }
            let mut next = vec![0u8; w];
            if y1 < h {
                median(y1, &mut next);
            }
            let d_band = &*d_band;
            let d_row = |y: usize| if y < y1 { &d_band[(y - y0) * w..(y - y0 + 1) * w] } else { &next[..] };
            let mut band = BandHistograms::new(cx);
            // a large level's S and sector rows are dropped once counted
            let scratch = if keep { 0 } else { w };
            let (mut s_tmp, mut sec_tmp, mut m8) = (vec![0u32; scratch], vec![0u8; scratch], vec![0u8; w]);
            for y in y0..y1 {
                // y + 1 clamps to the last row
                let below = if y + 1 < h { d_row(y + 1) } else { d_row(y) };
                let k = (y - y0) * ws;
                let (s_row, sec_row) = match (s_band.as_deref_mut(), sec_band.as_deref_mut()) {
                    (Some(sb), Some(secb)) => {
                        (sb[k], sb[k + w + 1]) = (0, 0);
                        (&mut sb[k + 1..=k + w], &mut secb[k + 1..=k + w])
                    }
                    _ => (&mut s_tmp[..], &mut sec_tmp[..]),
                };
                if keep {
                    gradient_row::<true, true>(d_row(y), below, s_row, sec_row, &mut m8);
                } else {
                    gradient_row::<false, true>(d_row(y), below, s_row, sec_row, &mut m8);
                }
                band.add_row(cx, &m8);
            }
            band.finish()
        })
        .collect();

    // 3. Otsu and window statistics -> per-column thresholds per window row
    let mut hist = [0u32; 256];
    for cell in cells.iter().flatten() {
        for (a, &c) in hist.iter_mut().zip(cell) {
            *a += c;
        }
    }
    let Some(k) = super::otsu::otsu(&hist) else {
        edges.reshape(img.width(), img.height());
        edges.data.fill(0);
        return;
    };
    let t1 = k as u32 + 1;
    let t2 = t1.div_ceil(2); // 2M >= T1  <=>  M >= ceil(T1 / 2)
    let stats = layout.stats(&cells);
    let win = &layout.windows;
    let nx = win.xs.len();
    thresholds.resize_with(win.ys.len(), Default::default);
    for (j, pieces) in thresholds.iter_mut().enumerate() {
        pieces.clear();
        // one set of thresholds per run of columns that use the same window
        let mut x0 = 0;
        while x0 < w {
            let i = win.col_window[x0];
            let x1 = x0 + win.col_window[x0..].iter().take_while(|&&c| c == i).count();
            let v3 = stats[j * nx + i as usize].v3();
            // 300 M >= (100 ± alpha) V3  <=>  M >= ceil((100 ± alpha) V3 / 300)
            let tl1 = ((100 + alpha_pct) * v3).div_ceil(300).min(255);
            let tl2 = ((100 - alpha_pct) * v3).div_ceil(300);
            let t = [t1.max(tl1), t1.min(tl1), t2.max(tl2), t2.min(tl2)].map(s_of_m);
            pieces.push(Piece { x0, x1, t });
            x0 = x1;
        }
    }

    // 4. NMS + classification + rules, a band of rows per task: S and sector
    //    rows from the kept planes or, on a large level, the band's gradient
    //    rows again in a ring of three padded rows (the band's first and last
    //    rows classify one row beyond it, which needs S one row further); a
    //    ring of three padded class rows, no class plane; lists the WEAK
    //    pixels for the flood.
    let (d, thresholds) = (&*d, &*thresholds);
    let planes = keep.then_some((&s[..], &sec[..]));
    edges.reshape(img.width(), img.height());
    let band_rows = BAND_ROWS.min(h);
    let weak: Vec<Vec<(u32, u32)>> = edges
        .data
        .par_chunks_mut(band_rows * w)
        .enumerate()
        .map(|(b, out)| {
            let y0 = b * band_rows;
            let mut grad = GradientRing::new(w, planes);
            let mut classify = |y: isize, out: &mut [u8]| {
                if y < 0 || y >= h as isize {
                    out.fill(0);
                    return;
                }
                let y = y as usize;
                let pieces = &thresholds[win.row_window[y] as usize];
                let (su, s, sd, sec) = grad.rows(d, y);
                classify_row(su, s, sd, sec, pieces, out);
                (out[0], out[w + 1]) = (0, 0);
            };
            let mut ring = [vec![0u8; ws], vec![0u8; ws], vec![0u8; ws]];
            classify(y0 as isize - 1, &mut ring[0]);
            classify(y0 as isize, &mut ring[1]);
            let mut weak = Vec::new();
            for (k, out) in out.chunks_mut(w).enumerate() {
                let y = y0 + k;
                classify(y as isize + 1, &mut ring[2]);
                rules_row(&ring[0], &ring[1], &ring[2], out);
                for_each_eq(out, WEAK, |x| weak.push((x as u32, y as u32)));
                ring.rotate_left(1);
            }
            // hysteresis within the band while it is in cache; the seams follow
            hysteresis::flood_band(out, w, y0 as u32, &weak);
            weak
        })
        .collect();

    // 5. hysteresis across the bands' seams (each band flooded itself in 4);
    //    E is the ruled plane afterwards
    hysteresis::flood_seams(edges, &weak, band_rows);
    debug_assert!(edges.data.iter().all(|&v| v == 0 || v == EDGE));
}

#[cfg(test)]
mod tests;
