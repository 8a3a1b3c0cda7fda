//! The detector reuses per-frame buffers through a pool. These tests make sure
//! no stale data leaks between frames of different sizes, between the
//! different entry points, or between threads sharing one detector.

mod common;

use lfast::cpu::CpuDetector;
use lfast::{Config, Plane};

fn images() -> Vec<(String, Plane<u8>)> {
    ["camera_cc0_v0.18plus.png", "coins.png", "text.png", "chessboard_GRAY.png", "astronaut_256.png"]
        .iter()
        .map(|n| (n.to_string(), lfast::image::load_gray(common::data(n)).unwrap()))
        .collect()
}

#[test]
fn reused_workspace_equals_fresh_detector_across_sizes_and_entry_points() {
    let shared = CpuDetector::new(Config::default()).unwrap();
    let imgs = images();
    // big, small, big again, and every entry point in between
    for pass in 0..2 {
        for (name, img) in imgs.iter().chain(imgs.iter().rev()) {
            let fresh = CpuDetector::new(Config::default()).unwrap();
            let want = fresh.detect_and_compute(img.view(), None).unwrap();
            assert_eq!(shared.detect_and_compute(img.view(), None).unwrap(), want, "{name} pass {pass}");
            assert_eq!(shared.detect(img.view(), None).unwrap(), want.0, "{name}");
            assert_eq!(shared.compute(img.view(), &want.0).unwrap(), want.1, "{name}");
            assert_eq!(shared.edge_image(img.view()).unwrap(), fresh.edges(img.view()).unwrap().edges, "{name}");
        }
    }
}

#[test]
fn threads_sharing_one_detector_get_the_sequential_results() {
    let det = CpuDetector::new(Config::default()).unwrap();
    let imgs = images();
    let want: Vec<_> = imgs.iter().map(|(_, i)| det.detect_and_compute(i.view(), None).unwrap()).collect();
    std::thread::scope(|s| {
        for t in 0..4 {
            let (det, imgs, want) = (&det, &imgs, &want);
            s.spawn(move || {
                for round in 0..3 {
                    for k in 0..imgs.len() {
                        let k = (k + t) % imgs.len(); // different threads on different images at once
                        let got = det.detect_and_compute(imgs[k].1.view(), None).unwrap();
                        assert_eq!(got, want[k], "thread {t} round {round} image {}", imgs[k].0);
                    }
                }
            });
        }
    });
}

#[test]
fn cloned_detector_starts_with_its_own_pool() {
    let det = CpuDetector::new(Config::default()).unwrap();
    let img = &images()[1].1;
    let a = det.detect_and_compute(img.view(), None).unwrap();
    let b = det.clone().detect_and_compute(img.view(), None).unwrap();
    assert_eq!(a, b);
}
