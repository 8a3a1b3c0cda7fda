//! The GPU matcher (shaders/matcher.wgsl) against the CPU matcher
//! (src/cpu/matcher.rs): identical matches, ties included.
use lfast::cpu::matcher::{self, Match, MatchOptions};
use lfast::gpu::matcher::GpuMatcher;
use lfast::testing as t;
use lfast::{Backend, Config, Descriptor, Detector};

/// Descriptors with few set bits drawn from a small pool, so that equal
/// distances (ties) are everywhere.
fn tied(n: usize, seed: u64) -> Vec<Descriptor> {
    let mut s = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
    let mut next = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        s
    };
    (0..n)
        .map(|_| {
            let mut d = [0u8; 32];
            for _ in 0..(next() % 6) {
                let b = (next() % 24) as usize; // bits 0..24 only
                d[b / 8] |= 1 << (b % 8);
            }
            d
        })
        .collect()
}

/// Uniformly random descriptors.
fn random(n: usize, seed: u64) -> Vec<Descriptor> {
    let mut s = seed.wrapping_mul(0x2545_f491_4f6c_dd1d) | 1;
    (0..n)
        .map(|_| {
            std::array::from_fn(|_| {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                (s >> 24) as u8
            })
        })
        .collect()
}

fn option_sets() -> Vec<MatchOptions> {
    vec![
        MatchOptions { cross_check: false, ratio: None, max_distance: 256 },
        MatchOptions { cross_check: true, ratio: None, max_distance: 256 },
        MatchOptions { cross_check: true, ratio: Some(0.8), max_distance: 64 },
        MatchOptions { cross_check: false, ratio: Some(0.7), max_distance: 3 },
        MatchOptions { cross_check: true, ratio: Some(1.0), max_distance: 0 },
    ]
}

#[test]
fn gpu_matches_equal_cpu_matches_with_ties_across_tile_boundaries() {
    let Some(ctx) = t::context() else { return };
    let m = GpuMatcher::new(ctx).unwrap();
    // sizes around the 64-descriptor tile and workgroup
    for (nq, nt, seed) in [(1, 1, 1), (63, 65, 2), (64, 64, 3), (65, 1, 4), (1, 200, 5), (130, 129, 6), (500, 700, 7)] {
        for (make, kind) in [(tied as fn(usize, u64) -> Vec<Descriptor>, "tied"), (random, "random")] {
            let (q, tr) = (make(nq, seed), make(nt, seed + 100));
            for o in option_sets() {
                let want = matcher::match_descriptors(&q, &tr, &o).unwrap();
                let got = m.match_descriptors(&q, &tr, &o).unwrap();
                assert_eq!(got, want, "{kind} {nq}x{nt} {o:?}");
            }
        }
    }
}

#[test]
fn ties_resolve_to_the_lowest_index_on_the_gpu() {
    let Some(ctx) = t::context() else { return };
    let m = GpuMatcher::new(ctx).unwrap();
    // 100 identical train descriptors: every query's nearest is train 0 (d2 == d1)
    let train = vec![[0x0fu8; 32]; 100];
    let query = vec![[0x0fu8; 32], [0x1fu8; 32]];
    let o = MatchOptions { cross_check: false, ratio: None, max_distance: 256 };
    let want = vec![Match { query: 0, train: 0, distance: 0 }, Match { query: 1, train: 0, distance: 32 }];
    assert_eq!(m.match_descriptors(&query, &train, &o).unwrap(), want);
    // cross-check: train 0's nearest query is query 0 (distance 0), so query 1 goes
    let o = MatchOptions { cross_check: true, ..o };
    assert_eq!(m.match_descriptors(&query, &train, &o).unwrap(), want[..1]);
    // ratio test: a tie fails it
    let o = MatchOptions { cross_check: false, ratio: Some(1.0), max_distance: 256 };
    assert!(m.match_descriptors(&query, &train, &o).unwrap().is_empty());
}

#[test]
fn empty_sets_and_bad_options() {
    let Some(ctx) = t::context() else { return };
    let m = GpuMatcher::new(ctx).unwrap();
    let d = random(10, 1);
    let o = MatchOptions::default();
    assert!(m.match_descriptors(&[], &d, &o).unwrap().is_empty());
    assert!(m.match_descriptors(&d, &[], &o).unwrap().is_empty());
    let bad = MatchOptions { ratio: Some(0.0), ..o };
    assert!(matches!(m.match_descriptors(&d, &d, &bad), Err(lfast::Error::InvalidConfig { field: "ratio", .. })));
    // buffers grow, then a smaller job reuses them
    let big = random(300, 2);
    assert_eq!(m.match_descriptors(&big, &big, &o).unwrap(), matcher::match_descriptors(&big, &big, &o).unwrap());
    assert_eq!(m.match_descriptors(&d, &big, &o).unwrap(), matcher::match_descriptors(&d, &big, &o).unwrap());
}

#[test]
fn real_descriptors_of_two_views_match_identically() {
    let Some(ctx) = t::context() else { return };
    let m = GpuMatcher::new(ctx).unwrap();
    let img = lfast::image::load_gray(
        std::env::var_os("LFAST_ROOT")
            .map_or_else(|| std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")), std::path::PathBuf::from)
            .join("tests/data/astronaut_256.png"),
    )
    .unwrap();
    // second view: the image shifted by (3, 2) pixels
    let mut shifted = lfast::Plane::<u8>::new(img.width, img.height);
    for y in 0..img.height {
        for x in 0..img.width {
            shifted.data[(y * img.width + x) as usize] = img.clamped(x as i32 - 3, y as i32 - 2);
        }
    }
    let det = Detector::new(Config::default(), Backend::Cpu).unwrap();
    let (k1, d1) = det.detect_and_compute(img.view(), None).unwrap();
    let (k2, d2) = det.detect_and_compute(shifted.view(), None).unwrap();
    assert!(d1.len() > 50 && d2.len() > 50, "{} and {} keypoints", d1.len(), d2.len());
    for o in option_sets() {
        assert_eq!(
            m.match_descriptors(&d1, &d2, &o).unwrap(),
            matcher::match_descriptors(&d1, &d2, &o).unwrap(),
            "{o:?}"
        );
    }
    // and the matches are right: most cross-checked, ratio-tested matches follow the shift
    let good = matcher::match_descriptors(&d1, &d2, &MatchOptions::default()).unwrap();
    let follow = good
        .iter()
        .filter(|mm| {
            let (ka, kb) = (&k1[mm.query as usize], &k2[mm.train as usize]);
            // a keypoint on level l is located to about 1.2^l pixels
            let tol = 1.0 + 1.2f32.powi(ka.octave.max(kb.octave));
            (kb.pt.x - ka.pt.x - 3.0).abs() < tol && (kb.pt.y - ka.pt.y - 2.0).abs() < tol
        })
        .count();
    assert!(good.len() > 30 && follow * 10 >= good.len() * 9, "{follow} of {} matches follow the shift", good.len());
}
