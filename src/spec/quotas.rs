//! SPEC 9: how the `n_features` cap is shared among pyramid levels.

/// Quotas for `n` features over levels of the given sizes, proportional to
/// area: `floor(n * A_l / sum A)`, the remainder handed out one by one from level 0.
///
/// ```
/// let q = lfast::spec::level_quotas(100, &[(100, 100), (50, 50)]);
/// assert_eq!(q, vec![80, 20]);
/// ```
pub fn level_quotas(n: u32, sizes: &[(u32, u32)]) -> Vec<u32> {
    let areas: Vec<u64> = sizes.iter().map(|&(w, h)| w as u64 * h as u64).collect();
    let total: u64 = areas.iter().sum::<u64>().max(1);
    let mut q: Vec<u32> = areas.iter().map(|&a| (n as u64 * a / total) as u32).collect();
    // Each floor loses less than one, so the remainder is below the level count.
    let rest = (n - q.iter().sum::<u32>()) as usize;
    q.iter_mut().take(rest).for_each(|v| *v += 1);
    q
}
