//! The FAST fill (`Config::fill_fast_ini`, docs/algorithm.md "Fill"): a level
//! short of its quota is topped up with FAST corners (`class_id` 1) after
//! every L-FAST corner it has; off, nothing changes; CPU only.

mod common;

use lfast::cpu::CpuDetector;
use lfast::cpu::select::level_quotas;
use lfast::{Backend, Config, Detector, Error};

fn camera() -> lfast::Plane<u8> {
    lfast::image::load_gray(common::data("camera_cc0_v0.18plus.png")).unwrap()
}

fn with_fill(n: u32, distribution: bool) -> Config {
    Config { n_features: n, distribution, fill_fast_ini: 20, fill_fast_min: 7, ..Config::default() }
}

#[test]
fn a_short_level_keeps_every_l_fast_corner_and_fills_up_to_its_quota() {
    let img = camera();
    for distribution in [false, true] {
        let n = 4000;
        let filled = CpuDetector::new(with_fill(n, distribution)).unwrap();
        let plain = CpuDetector::new(Config { n_features: 0, ..with_fill(n, distribution) }.without_fill()).unwrap();
        let (kps, desc) = filled.detect_and_compute(img.view(), None).unwrap();
        let all_lfast = plain.detect_and_compute(img.view(), None).unwrap();
        let sizes = filled.config().level_sizes(img.width, img.height);
        let quotas = level_quotas(n, &sizes);
        // the bundled 512x512 image has far fewer L-FAST corners than 4000
        assert!(all_lfast.0.len() < 2000, "{} L-FAST corners", all_lfast.0.len());
        assert!(kps.iter().any(|k| k.class_id == 1), "the fill found nothing");
        assert!(kps.iter().all(|k| k.class_id == 1 || k.class_id == -1));
        for (l, &q) in quotas.iter().enumerate() {
            let lf: Vec<_> = all_lfast.0.iter().filter(|k| k.octave == l as i32).collect();
            let got_lf = kps.iter().filter(|k| k.octave == l as i32 && k.class_id == -1).count();
            let got_fill = kps.iter().filter(|k| k.octave == l as i32 && k.class_id == 1).count();
            if lf.len() < q as usize {
                // (a level may take more fill corners than its quota leaves: the
                // quota other levels cannot use goes to the best remaining corners)
                assert_eq!(got_lf, lf.len(), "level {l}: every L-FAST corner is kept");
            } else {
                assert_eq!(got_fill, 0, "level {l} has enough L-FAST corners: no fill");
            }
        }
        // each L-FAST keypoint, and its descriptor, as without the fill
        for (k, d) in kps.iter().zip(&desc).filter(|(k, _)| k.class_id == -1) {
            let i = all_lfast.0.iter().position(|a| a == k).unwrap_or_else(|| panic!("{k:?} not an L-FAST keypoint"));
            assert_eq!(&all_lfast.1[i], d);
        }
        // the capped result without the fill is part of the result with it
        let capped = CpuDetector::new(with_fill(n, distribution).without_fill()).unwrap();
        for k in capped.detect(img.view(), None).unwrap() {
            assert!(kps.contains(&k), "{k:?} of the result without the fill is missing");
        }
        // SPEC 9 order over both kinds, within the cap, and more keypoints than L-FAST alone gives
        assert!(kps.windows(2).all(|w| w[0].response >= w[1].response));
        assert!(kps.len() <= n as usize);
        assert!(kps.len() > all_lfast.0.len() + 500, "{} with the fill, {} without", kps.len(), all_lfast.0.len());
    }
}

#[test]
fn with_enough_l_fast_corners_the_fill_changes_nothing() {
    // a cap that L-FAST meets on its own, on a textured image: no FAST corner
    let img = common::noise(320, 240, 9);
    let n = 200;
    let on = CpuDetector::new(with_fill(n, true)).unwrap().detect_and_compute(img.view(), None).unwrap();
    let off =
        CpuDetector::new(with_fill(n, true).without_fill()).unwrap().detect_and_compute(img.view(), None).unwrap();
    assert_eq!(on.0.len(), n as usize);
    assert_eq!(on, off);
}

#[test]
fn off_by_default_and_refused_without_a_cap_or_with_bad_thresholds() {
    assert!(!Config::default().fills());
    let img = camera();
    // a cap that L-FAST fills alone: the fill changes nothing
    let small = CpuDetector::new(with_fill(50, true)).unwrap().detect_and_compute(img.view(), None).unwrap();
    let off =
        CpuDetector::new(with_fill(50, true).without_fill()).unwrap().detect_and_compute(img.view(), None).unwrap();
    assert_eq!(small, off);
    for (ini, min, n, field) in [
        (20, 7, 0, "fill_fast_ini"),
        (7, 20, 100, "fill_fast_min"),
        (0, 7, 100, "fill_fast_min"),
        (20, 0, 100, "fill_fast_min"),
        (256, 7, 100, "fill_fast_ini"),
    ] {
        let c = Config { n_features: n, fill_fast_ini: ini, fill_fast_min: min, ..Config::default() };
        match c.validate() {
            Err(Error::InvalidConfig { field: f, .. }) => assert_eq!(f, field, "{ini}/{min}/{n}"),
            other => panic!("{ini}/{min}/{n}: {other:?}"),
        }
    }
}

#[test]
fn the_gpu_refuses_the_fill_by_name_and_auto_runs_it_on_the_cpu() {
    let cfg = with_fill(3000, true);
    match Detector::new(cfg.clone(), Backend::Gpu) {
        Err(Error::InvalidConfig { field, reason }) => {
            assert_eq!(field, "fill_fast_ini");
            assert!(reason.contains("CPU-only"), "{reason}");
        }
        other => panic!("Backend::Gpu with the fill: {other:?}"),
    }
    let auto = Detector::new(cfg.clone(), Backend::Auto).unwrap();
    assert_eq!(auto.backend_name(), "cpu");
    let img = camera();
    assert_eq!(
        auto.detect_and_compute(img.view(), None).unwrap(),
        CpuDetector::new(cfg).unwrap().detect_and_compute(img.view(), None).unwrap()
    );
}
