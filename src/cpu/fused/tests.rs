//! Tests of the fast edge path (`super`): fused == staged, and each row kernel
//! against its scalar definition.

use super::*;
use crate::cpu::edge_map_with;

#[test]
fn sqrt_floor_is_exact_over_the_gradient_range() {
    for s in 0..=2 * 510 * 510u32 {
        assert_eq!(sqrt_floor(s), s.isqrt(), "{s}");
    }
}

#[test]
fn median_rows_equal_the_scalar_definition() {
    assert_eq!(small_ratio(1000, 10_000), Some((1, 10)));
    assert_eq!(small_ratio(1234, 10_000), None);
    assert_eq!(small_ratio(2570, 10), Some((257, 1)));
    // every (g, n) pair, for ratios at and inside the 16-bit bounds
    let row: Vec<u8> = (0..=255u8).collect();
    for (num, den) in [(1, 10), (257, 257), (257, 1), (1, 257), (3, 7), (100, 100)] {
        let (p, q) = small_ratio(num, den).unwrap();
        for n in 0..=255u8 {
            let other = vec![n; 256];
            let (mut o32, mut o16) = (vec![0; 256], vec![0; 256]);
            median_row(&other, &row, &other, &mut o32, num, den);
            median_row16(&other, &row, &other, &mut o16, p, q);
            assert_eq!(o32[1..255], o16[1..255], "{num}/{den} n={n}");
            // the scalar definition: the median (here n) where flagged
            let img = Plane::from_vec(256, 3, [&other[..], &row, &other].concat()).unwrap();
            for x in 1..255u32 {
                let want = if median::is_noise(&img, x, 1, num, den) { median::median3x3(&img, x, 1) } else { x as u8 };
                assert_eq!(o32[x as usize], want, "{num}/{den} n={n} x={x}");
            }
        }
    }
}

/// [`gradient_row`] at `tier`, one the CPU has.
fn row_at<const S_SEC: bool, const M8: bool>(
    tier: crate::cpu::simd::Tier,
    r0: &[u8],
    r1: &[u8],
    s: &mut [u32],
    sec: &mut [u8],
    m8: &mut [u8],
) {
    assert!(tier <= crate::cpu::simd::detected_tier());
    // SAFETY: the CPU has the tier, asserted above.
    unsafe { gradient_row_at::<S_SEC, M8>(tier, r0, r1, s, sec, m8) }
}

#[test]
fn gradient_row_vector_equals_scalar() {
    // rows with every extreme (0 and 255 next to each other) and random bytes,
    // widths around the 16-pixel steps
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    let mut byte = || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        match seed >> 61 {
            0 => 0,
            1 => 255,
            _ => (seed >> 40) as u8,
        }
    };
    let best = crate::cpu::simd::detected_tier();
    for tier in crate::cpu::simd::Tier::ALL.into_iter().filter(|&t| t <= best) {
        for w in (1..=70).chain([95, 96, 97, 255, 256, 257, 1241]) {
            for _ in 0..20 {
                let (r0, r1): (Vec<u8>, Vec<u8>) = (0..w).map(|_| (byte(), byte())).unzip();
                let (mut s, mut sec, mut m8) = (vec![0; w], vec![0; w], vec![0; w]);
                let (mut s2, mut sec2, mut m82) = (vec![1; w], vec![9; w], vec![7; w]);
                row_at::<true, true>(tier, &r0, &r1, &mut s, &mut sec, &mut m8);
                gradient_tail(&r0, &r1, &mut s2, &mut sec2, &mut m82, 0);
                assert_eq!((&s, &sec, &m8), (&s2, &sec2, &m82), "w {w}, tier {tier:?}");
                // each pass of a large level: its outputs alike
                let (mut s3, mut sec3, mut m83) = (vec![5; w], vec![5; w], vec![5; w]);
                row_at::<false, true>(tier, &r0, &r1, &mut s3, &mut sec3, &mut m83);
                assert_eq!(m83, m8, "w {w}, M8 only");
                row_at::<true, false>(tier, &r0, &r1, &mut s3, &mut sec3, &mut m83);
                assert_eq!((&s3, &sec3), (&s, &sec), "w {w}, S and sector only");
            }
        }
    }
}

#[test]
fn gradient_row_vector_equals_scalar_for_every_gradient() {
    // pixel 2k of these rows sees (a, b, c, e) = (a, b, c, k): with a in {0, 255}
    // and b, c, k over all bytes, e - a and b - c take every value in -255..=255,
    // so (dx, dy) = (e - a + b - c, e - a - b + c) takes every value there is
    let w = 2 * 256 + 1;
    let (mut s, mut sec, mut m8) = (vec![0; w], vec![0; w], vec![0; w]);
    let (mut s2, mut sec2, mut m82) = (vec![0; w], vec![0; w], vec![0; w]);
    let best = crate::cpu::simd::detected_tier();
    for tier in crate::cpu::simd::Tier::ALL.into_iter().filter(|&t| t <= best) {
        for a in [0u8, 255] {
            for b in 0..=255u8 {
                for c in 0..=255u8 {
                    let r0: Vec<u8> = (0..w).map(|x| if x % 2 == 0 { a } else { b }).collect();
                    let r1: Vec<u8> = (0..w).map(|x| if x % 2 == 0 { c } else { (x / 2) as u8 }).collect();
                    row_at::<true, true>(tier, &r0, &r1, &mut s, &mut sec, &mut m8);
                    gradient_tail(&r0, &r1, &mut s2, &mut sec2, &mut m82, 0);
                    assert!(s == s2 && sec == sec2 && m8 == m82, "a {a} b {b} c {c}, tier {tier:?}");
                    s2.fill(u32::MAX);
                    sec2.fill(9);
                    m82.fill(7);
                    row_at::<false, true>(tier, &r0, &r1, &mut s2, &mut sec2, &mut m82);
                    row_at::<true, false>(tier, &r0, &r1, &mut s2, &mut sec2, &mut m82);
                    assert!(s == s2 && sec == sec2 && m8 == m82, "passes: a {a} b {b} c {c}, tier {tier:?}");
                }
            }
        }
    }
}

#[test]
fn sector_code_matches_nms_sector() {
    let codes = [((-1, 0), (1, 0)), ((0, -1), (0, 1)), ((-1, -1), (1, 1)), ((1, -1), (-1, 1))];
    for dx in -510..=510 {
        for dy in (-510..=510).step_by(7) {
            assert_eq!(codes[sector_code(dx, dy) as usize], super::super::nms::sector(dx, dy), "{dx} {dy}");
        }
    }
}

fn noise_image(w: u32, h: u32, seed: u64, levels: u64) -> Plane<u8> {
    let mut s = seed;
    let data = (0..w * h)
        .map(|i| {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            // blocky structure plus noise, so every class occurs
            let block = ((i % w) / 5 + (i / w) / 4) as u64 * 37 % 255;
            ((block + (s >> 59) * levels) % 256) as u8
        })
        .collect();
    Plane::from_vec(w, h, data).unwrap()
}

#[test]
fn equals_the_staged_pipeline_on_real_images() {
    for name in ["camera_cc0_v0.18plus.png", "coins.png", "text.png", "chessboard_GRAY.png"] {
        let path = format!("{}/tests/data/{name}", env!("CARGO_MANIFEST_DIR"));
        let img = crate::image::load_gray(&path).unwrap();
        let em = edge_map_with(&img, 1000, 10_000, 35);
        let f = edges_fused(&img, 1000, 10_000, 35);
        assert!(em.edges.data.iter().filter(|&&v| v == EDGE).count() > 1000, "{name}");
        assert_eq!(f.denoised, em.denoised, "{name}");
        assert_eq!(f.edges, em.edges, "{name}");
        let mut sc = EdgeScratch::default();
        edges_fused_keeping(img.view(), 1000, 10_000, 35, 0, &mut sc);
        assert_eq!((&sc.denoised, &sc.edges), (&em.denoised, &em.edges), "{name}, S recomputed");
    }
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(200))]
    #[test]
    fn equals_the_staged_pipeline(w in 1u32..70, h in 1u32..110, seed in proptest::prelude::any::<u64>(),
                                  levels in 0u64..40, alpha in 0u32..100, num in 1u32..3000) {
        let img = noise_image(w, h, seed, levels);
        let em = edge_map_with(&img, num, 10_000, alpha);
        let f = edges_fused(&img, num, 10_000, alpha);
        proptest::prop_assert_eq!(&f.denoised, &em.denoised);
        proptest::prop_assert_eq!(&f.edges, &em.edges);
        // the other way of getting S (planes kept on these small images, so the
        // ring of recomputed rows), into the same buffers
        let mut sc = EdgeScratch::default();
        for keep_max in [0, usize::MAX, 0] {
            edges_fused_keeping(img.view(), num, 10_000, alpha, keep_max, &mut sc);
            proptest::prop_assert_eq!(&sc.denoised, &em.denoised);
            proptest::prop_assert_eq!(&sc.edges, &em.edges);
        }
    }
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(24))]
    /// Widths from 320 on give threshold runs of 32 columns and more, so
    /// the chunked kernels (and their overlapping last chunk) run.
    #[test]
    fn equals_the_staged_pipeline_when_wide(w in 320u32..700, h in 1u32..40, seed in proptest::prelude::any::<u64>(),
                                            levels in 0u64..40, alpha in 0u32..100) {
        let img = noise_image(w, h, seed, levels);
        let em = edge_map_with(&img, 1000, 10_000, alpha);
        let f = edges_fused(&img, 1000, 10_000, alpha);
        proptest::prop_assert_eq!(&f.denoised, &em.denoised);
        proptest::prop_assert_eq!(&f.edges, &em.edges);
        let mut sc = EdgeScratch::default();
        edges_fused_keeping(img.view(), 1000, 10_000, alpha, 0, &mut sc);
        proptest::prop_assert_eq!(&sc.edges, &em.edges);
    }
}
