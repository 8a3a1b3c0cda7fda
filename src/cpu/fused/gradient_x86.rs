//! The gradient row of [`super::gradient_row`] with AVX2: 16 pixels per step
//! on 16-bit lanes (`|dx|, |dy| <= 510`). S and both sector tests are sums of
//! two 16-bit products in 32 bits (`pmaddwd`):
//! - S = dx·dx + dy·dy;
//! - horizontal, `ay·32768 < 13573·ax`, is `13573·ax − 32768·ay > 0`;
//! - vertical, `ay·32768 > 79109·ax` with 79109 = 2·32768 + 13573, is
//!   `−32768·(2ax − ay) − 13573·ax > 0`, where `2ax − ay` fits i16.
//!
//! M8 = min(isqrt(S) >> 1, 255) by f32 as in [`super::sqrt_floor`].
//! [`gradient_cols_avx512`] does the same 32 pixels per step, the sector
//! tests' results as mask registers. Both end with a step that overlaps the
//! one before (recomputing a few columns) so that only the last column is
//! left to the scalar tail. Checked against the scalar kernel at every tier
//! in `super::tests::gradient_row_vector_equals_scalar`.

use std::arch::x86_64::*;

/// Columns `0..n` of a gradient row (S and the sector when `S_SEC`, M8 when
/// `M8`; the other slices are left as they are), `n = w - 1` (0 when `w <
/// 17`): 16 columns a step, the last step at `w - 17`; returns `n`. The
/// slices have length `w` at least (`r0`'s length is `w`).
///
/// # Safety
/// The CPU has AVX2.
#[target_feature(enable = "avx2")]
pub(super) unsafe fn gradient_cols<const S_SEC: bool, const M8: bool>(
    r0: &[u8],
    r1: &[u8],
    s: &mut [u32],
    sec: &mut [u8],
    m8: &mut [u8],
) -> usize {
    let w = r0.len();
    let n = if w >= 17 { w - 1 } else { 0 };
    assert!(r1.len() >= w && s.len() >= w && sec.len() >= w && m8.len() >= w, "gradient_cols: short rows");
    // (13573, -32768) and (-32768, -13573) as i16 pairs, low half first
    let k_h = _mm256_set1_epi32(((0x8000u32 << 16) | 13573) as i32);
    let k_v = _mm256_set1_epi32((((-13573i32 as u32) & 0xffff) << 16 | 0x8000) as i32);
    let zero = _mm256_setzero_si256();
    let one = _mm256_set1_epi16(1);
    let two = _mm256_set1_epi16(2);
    let mut x = 0;
    while x < n {
        // the last step overlaps the one before: it ends at column n - 1
        x = x.min(n - 16);
        // SAFETY: x + 17 <= n + 1 = w, so every 16-byte load (at x
        // and x + 1) and every store (16 u32 at s[x], 16 bytes at sec[x], m8[x])
        // lies inside slices of length >= w, asserted above.
        unsafe {
            let ld = |r: &[u8], at: usize| _mm256_cvtepu8_epi16(_mm_loadu_si128(r.as_ptr().add(at).cast::<__m128i>()));
            let (a, b, c, e) = (ld(r0, x), ld(r0, x + 1), ld(r1, x), ld(r1, x + 1));
            let dx = _mm256_sub_epi16(_mm256_sub_epi16(_mm256_add_epi16(b, e), a), c);
            let dy = _mm256_sub_epi16(_mm256_sub_epi16(_mm256_add_epi16(c, e), a), b);
            // pairs interleave within 128-bit lanes: `lo` holds pixels 0-3 and 8-11, `hi` 4-7 and 12-15
            let (lo, hi) = (_mm256_unpacklo_epi16(dx, dy), _mm256_unpackhi_epi16(dx, dy));
            let (s_lo, s_hi) = (_mm256_madd_epi16(lo, lo), _mm256_madd_epi16(hi, hi));
            let s0 = _mm256_permute2x128_si256::<0x20>(s_lo, s_hi); // pixels 0-7
            let s1 = _mm256_permute2x128_si256::<0x31>(s_lo, s_hi); // pixels 8-15
            if M8 {
                // M8: f32 holds S exactly and its rounded square root truncates to isqrt(S)
                let q = |v: __m256i| _mm256_srli_epi32::<1>(_mm256_cvttps_epi32(_mm256_sqrt_ps(_mm256_cvtepi32_ps(v))));
                // packus pairs lanes: [0-3, 8-11 | 4-7, 12-15] -> reorder the 64-bit quarters
                let q16 = _mm256_permute4x64_epi64::<0b11_01_10_00>(_mm256_packus_epi32(q(s0), q(s1)));
                store16(m8, x, _mm256_packus_epi16(q16, q16)); // saturates at 255
            }
            if !S_SEC {
                x += 16;
                continue;
            }
            _mm256_storeu_si256(s.as_mut_ptr().add(x).cast::<__m256i>(), s0);
            _mm256_storeu_si256(s.as_mut_ptr().add(x + 8).cast::<__m256i>(), s1);
            // sector code: vertical 1, horizontal 0, else 2 + (signs differ)
            let (ax, ay) = (_mm256_abs_epi16(dx), _mm256_abs_epi16(dy));
            let test = |p: __m256i, q: __m256i, k: __m256i| {
                let lo = _mm256_cmpgt_epi32(_mm256_madd_epi16(_mm256_unpacklo_epi16(p, q), k), zero);
                let hi = _mm256_cmpgt_epi32(_mm256_madd_epi16(_mm256_unpackhi_epi16(p, q), k), zero);
                _mm256_packs_epi32(lo, hi) // back to pixel order, as 16-bit masks
            };
            let horizontal = test(ax, ay, k_h);
            let vertical = test(_mm256_sub_epi16(_mm256_add_epi16(ax, ax), ay), ax, k_v);
            let opposite = _mm256_xor_si256(_mm256_cmpgt_epi16(dx, zero), _mm256_cmpgt_epi16(dy, zero));
            let diagonal = _mm256_add_epi16(two, _mm256_and_si256(opposite, one));
            let code = _mm256_or_si256(
                _mm256_and_si256(vertical, one),
                _mm256_andnot_si256(_mm256_or_si256(horizontal, vertical), diagonal),
            );
            store16(sec, x, _mm256_packs_epi16(code, code));
        }
        x += 16;
    }
    n
}

/// Stores bytes 0-7 and 16-23 of `v` (the two lanes' low halves) at `out[at..at + 16]`.
///
/// # Safety
/// The CPU has AVX2 and `at + 16 <= out.len()`.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn store16(out: &mut [u8], at: usize, v: __m256i) {
    debug_assert!(at + 16 <= out.len());
    // SAFETY: 16 bytes at out[at], in bounds by the contract.
    unsafe {
        let v = _mm256_permute4x64_epi64::<0b00_00_10_00>(v);
        _mm_storeu_si128(out.as_mut_ptr().add(at).cast::<__m128i>(), _mm256_castsi256_si128(v));
    }
}

/// [`gradient_cols`] with AVX-512 (F, BW), 32 columns a step, the last step
/// at `w - 33`; rows narrower than 33 go to [`gradient_cols`]. Returns `w - 1`
/// (0 when `w < 17`).
///
/// # Safety
/// The CPU has the AVX-512 tier ([`crate::cpu::simd::Tier::Avx512`]).
#[target_feature(enable = "avx512f,avx512bw,avx512cd,avx512dq,avx512vl,avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
pub(super) unsafe fn gradient_cols_avx512<const S_SEC: bool, const M8: bool>(
    r0: &[u8],
    r1: &[u8],
    s: &mut [u32],
    sec: &mut [u8],
    m8: &mut [u8],
) -> usize {
    let w = r0.len();
    if w < 33 {
        // SAFETY: AVX2, by the contract.
        return unsafe { gradient_cols::<S_SEC, M8>(r0, r1, s, sec, m8) };
    }
    let n = w - 1;
    assert!(r1.len() >= w && s.len() >= w && sec.len() >= w && m8.len() >= w, "gradient_cols_avx512: short rows");
    let k_h = _mm512_set1_epi32(((0x8000u32 << 16) | 13573) as i32);
    let k_v = _mm512_set1_epi32((((-13573i32 as u32) & 0xffff) << 16 | 0x8000) as i32);
    let zero = _mm512_setzero_si512();
    // unpacklo/hi interleave within 128-bit lanes: lane k of `lo` holds pixels
    // 8k..8k+3, of `hi` 8k+4..8k+7; these pick pixels 0-15 and 16-31 (an index
    // of 16 and up reads `hi`)
    let order = |first: i32| {
        let mut idx = [0i32; 16];
        for (p, v) in idx.iter_mut().enumerate() {
            let p = first + p as i32;
            let (k, j) = (p / 8, p % 8);
            *v = if j < 4 { 4 * k + j } else { 16 + 4 * k + j - 4 };
        }
        // SAFETY: 64 bytes read from a [i32; 16].
        unsafe { _mm512_loadu_si512(idx.as_ptr().cast()) }
    };
    let (first, second) = (order(0), order(16));
    let mut x = 0;
    while x < n {
        x = x.min(n - 32);
        // SAFETY: x + 33 <= n + 1 = w, so every 32-byte load (at x and x + 1)
        // and every store (32 u32 at s[x], 32 bytes at sec[x], m8[x]) lies
        // inside slices of length >= w, asserted above.
        unsafe {
            let ld =
                |r: &[u8], at: usize| _mm512_cvtepu8_epi16(_mm256_loadu_si256(r.as_ptr().add(at).cast::<__m256i>()));
            let (a, b, c, e) = (ld(r0, x), ld(r0, x + 1), ld(r1, x), ld(r1, x + 1));
            let dx = _mm512_sub_epi16(_mm512_sub_epi16(_mm512_add_epi16(b, e), a), c);
            let dy = _mm512_sub_epi16(_mm512_sub_epi16(_mm512_add_epi16(c, e), a), b);
            // sums of pairs' products in pixel order: pixels 0-15 and 16-31
            let madd = |p: __m512i, q: __m512i, k: Option<__m512i>| {
                let (lo, hi) = (_mm512_unpacklo_epi16(p, q), _mm512_unpackhi_epi16(p, q));
                let (lo, hi) = match k {
                    Some(k) => (_mm512_madd_epi16(lo, k), _mm512_madd_epi16(hi, k)),
                    None => (_mm512_madd_epi16(lo, lo), _mm512_madd_epi16(hi, hi)),
                };
                (_mm512_permutex2var_epi32(lo, first, hi), _mm512_permutex2var_epi32(lo, second, hi))
            };
            let (s0, s1) = madd(dx, dy, None);
            if M8 {
                // as gradient_cols; vpmovusdb saturates at 255
                let q = |v: __m512i| _mm512_srli_epi32::<1>(_mm512_cvttps_epi32(_mm512_sqrt_ps(_mm512_cvtepi32_ps(v))));
                let out = m8.as_mut_ptr().add(x).cast::<__m128i>();
                _mm_storeu_si128(out, _mm512_cvtusepi32_epi8(q(s0)));
                _mm_storeu_si128(out.add(1), _mm512_cvtusepi32_epi8(q(s1)));
            }
            if !S_SEC {
                x += 32;
                continue;
            }
            _mm512_storeu_si512(s.as_mut_ptr().add(x).cast(), s0);
            _mm512_storeu_si512(s.as_mut_ptr().add(x + 16).cast(), s1);
            let (ax, ay) = (_mm512_abs_epi16(dx), _mm512_abs_epi16(dy));
            // a test's 32 pixels as a mask, pixel p at bit p
            let test = |p: __m512i, q: __m512i, k: __m512i| {
                let (t0, t1) = madd(p, q, Some(k));
                let (m0, m1) = (_mm512_cmpgt_epi32_mask(t0, zero), _mm512_cmpgt_epi32_mask(t1, zero));
                (m0 as u32) | (m1 as u32) << 16
            };
            let horizontal = test(ax, ay, k_h);
            let vertical = test(_mm512_sub_epi16(_mm512_add_epi16(ax, ax), ay), ax, k_v);
            let opposite = _mm512_cmpgt_epi16_mask(dx, zero) ^ _mm512_cmpgt_epi16_mask(dy, zero);
            // sector code: vertical 1, horizontal 0, else 2 + (signs differ)
            let code = _mm256_mask_blend_epi8(opposite, _mm256_set1_epi8(2), _mm256_set1_epi8(3));
            let code = _mm256_mask_blend_epi8(horizontal, code, _mm256_setzero_si256());
            let code = _mm256_mask_blend_epi8(vertical, code, _mm256_set1_epi8(1));
            _mm256_storeu_si256(sec.as_mut_ptr().add(x).cast::<__m256i>(), code);
        }
        x += 32;
    }
    n
}
