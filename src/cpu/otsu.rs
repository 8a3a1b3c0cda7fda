//! SPEC 4, second half: Otsu's threshold, found with exact integer arithmetic so
//! that every implementation picks the same k. Mirrors shaders/otsu.wgsl.
//!
//! The between-class variance of a split at k is proportional to
//! `d^2 / (n0 * n1)` with `d = n*s0 - n0*sum = n0*n1*(mu0 - mu1)`. For images up
//! to 2^28 pixels `|d| < 2^62`, `d^2 < 2^124` and `n0*n1 < 2^54`, so two
//! candidates compare exactly as 192-bit cross products.

/// `a * b` as a 192-bit number `(high 128 bits, low 64 bits)`.
#[inline]
fn mul_wide(a: u128, b: u64) -> (u128, u64) {
    let lo = (a as u64 as u128) * b as u128;
    let hi = (a >> 64) * b as u128 + (lo >> 64);
    (hi, lo as u64)
}

/// Otsu's k over a histogram: the split maximising the between-class variance of
/// bins `0..=k` against `k+1..=255`, the smallest k on a tie. `None` when fewer
/// than two bins are non-empty (then the image has no edges).
///
/// ```
/// let mut h = [0u32; 256];
/// h[10] = 50;
/// h[200] = 50;
/// assert_eq!(lfast::cpu::otsu::otsu(&h), Some(10));
/// h[200] = 0;
/// assert_eq!(lfast::cpu::otsu::otsu(&h), None);
/// ```
pub fn otsu(hist: &[u32; 256]) -> Option<u8> {
    let n: u64 = hist.iter().map(|&c| c as u64).sum();
    let sum: u64 = hist.iter().enumerate().map(|(i, &c)| i as u64 * c as u64).sum();
    let (mut n0, mut s0) = (0u64, 0u64);
    // best so far as the fraction num / den
    let mut best: Option<(u8, u128, u64)> = None;
    for k in 0..255usize {
        n0 += hist[k] as u64;
        s0 += k as u64 * hist[k] as u64;
        let n1 = n - n0;
        if n0 == 0 || n1 == 0 {
            continue;
        }
        let d = (n as i128 * s0 as i128 - n0 as i128 * sum as i128).unsigned_abs();
        let num = d * d;
        let den = n0 * n1;
        let better = match best {
            None => true,
            // num/den > bnum/bden  <=>  num*bden > bnum*den
            Some((_, bnum, bden)) => mul_wide(num, bden) > mul_wide(bnum, den),
        };
        if better {
            best = Some((k as u8, num, den));
        }
    }
    best.map(|(k, _, _)| k)
}

/// Otsu in f64, the textbook formula; used by the tests to show the exact
/// version agrees with the usual one wherever the latter is not a near-tie.
pub fn otsu_f64(hist: &[u32; 256]) -> Option<u8> {
    let n: f64 = hist.iter().map(|&c| c as f64).sum();
    let sum: f64 = hist.iter().enumerate().map(|(i, &c)| i as f64 * c as f64).sum();
    let (mut w0, mut s0) = (0.0f64, 0.0f64);
    let mut best: Option<(u8, f64)> = None;
    for k in 0..255usize {
        w0 += hist[k] as f64;
        s0 += k as f64 * hist[k] as f64;
        let w1 = n - w0;
        if w0 == 0.0 || w1 == 0.0 {
            continue;
        }
        let mu0 = s0 / w0;
        let mu1 = (sum - s0) / w1;
        let v = w0 * w1 * (mu0 - mu1) * (mu0 - mu1);
        if best.is_none_or(|(_, b)| v > b) {
            best = Some((k as u8, v));
        }
    }
    best.map(|(k, _)| k)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bimodal() {
        // Two clusters: 20 pixels at 30..=34, 10 at 180..=184. Any k in 34..180
        // separates them perfectly; the smallest such k wins the tie.
        let mut h = [0u32; 256];
        for v in 30..35 {
            h[v] = 4;
        }
        for v in 180..185 {
            h[v] = 2;
        }
        assert_eq!(otsu(&h), Some(34));
        assert_eq!(otsu_f64(&h), Some(34));
    }

    #[test]
    fn two_bins_adjacent() {
        let mut h = [0u32; 256];
        h[0] = 1000;
        h[1] = 1;
        assert_eq!(otsu(&h), Some(0));
        h[255] = 7;
        h[1] = 0;
        assert_eq!(otsu(&h), Some(0));
    }

    #[test]
    fn single_bin_and_empty_have_no_threshold() {
        let mut h = [0u32; 256];
        assert_eq!(otsu(&h), None);
        h[255] = 9;
        assert_eq!(otsu(&h), None);
    }

    #[test]
    fn largest_image_does_not_overflow() {
        // 2^28 pixels split evenly between 0 and 255: the extreme of the bound.
        let mut h = [0u32; 256];
        h[0] = 1 << 27;
        h[255] = 1 << 27;
        assert_eq!(otsu(&h), Some(0));
        h[128] = 12345;
        h[0] -= 12345;
        assert_eq!(otsu(&h), otsu_f64(&h));
    }

    #[test]
    fn mul_wide_is_exact() {
        let a: u128 = (1u128 << 124) - 12345;
        let b: u64 = (1u64 << 54) + 99;
        let (hi, lo) = mul_wide(a, b);
        // check against a by-parts computation
        let a_hi = a >> 64;
        let a_lo = a & u64::MAX as u128;
        let p_lo = a_lo * b as u128;
        assert_eq!(lo, p_lo as u64);
        assert_eq!(hi, a_hi * b as u128 + (p_lo >> 64));
    }

    proptest::proptest! {
        #[test]
        fn agrees_with_f64_off_ties(bins in proptest::collection::vec(0u32..5000, 256)) {
            let mut h = [0u32; 256];
            h.copy_from_slice(&bins);
            let k = otsu(&h);
            let kf = otsu_f64(&h);
            // The exact and the float argmax agree unless two variances are
            // within float rounding of each other; check that case explicitly.
            if k != kf {
                let var = |k: u8| {
                    let (mut n0, mut s0, mut n, mut s) = (0f64, 0f64, 0f64, 0f64);
                    for (i, &c) in h.iter().enumerate() {
                        n += c as f64; s += i as f64 * c as f64;
                        if i <= k as usize { n0 += c as f64; s0 += i as f64 * c as f64; }
                    }
                    let n1 = n - n0;
                    n0 * n1 * (s0 / n0 - (s - s0) / n1).powi(2)
                };
                let (a, b) = (var(k.unwrap()), var(kf.unwrap()));
                proptest::prop_assert!((a - b).abs() <= 1e-9 * a.abs().max(b.abs()));
            }
        }
    }
}
