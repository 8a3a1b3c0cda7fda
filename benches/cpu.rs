//! Criterion benchmarks of the CPU path: the improved Canny edge map, L-FAST
//! detection, detection + ORB description, and the SPEC 12 baselines.
//!
//! Run: `cargo bench --bench cpu` (a few minutes on 2 cores); one group:
//! `cargo bench --bench cpu -- kitti`. Under `cargo test --benches` (as
//! `.ci/run` does) each benchmark runs once, as a smoke test.
//!
//! Images: the bundled CC0 `tests/data/camera_cc0_v0.18plus.png` (512x512) and
//! KITTI seq01 frame 20 (1241x376) from the test data (`LFAST_TEST_DATA`, else
//! `../shared/data`); the KITTI group is skipped with a message when it is
//! absent (a plain clone), and fails under CI.

use criterion::{Criterion, criterion_group, criterion_main};
use lfast::baseline::canny::{CannyParams, canny};
use lfast::baseline::fast::fast9;
use lfast::baseline::orb::{OrbDetector, OrbParams};
use lfast::cpu::CpuDetector;
use lfast::{Config, Plane};
use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

// the integration tests' helpers: the test data folder and the skip log
#[path = "../tests/common/mod.rs"]
mod common;

/// Under the test data folder (`LFAST_TEST_DATA`, else `../shared/data`).
const KITTI: &str = "kitti/seq01_000000-000050/image_0/000020.png";

fn load(path: &Path) -> Plane<u8> {
    lfast::image::load_gray(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn bench_image(c: &mut Criterion, group: &str, img: &Plane<u8>) {
    let det = CpuDetector::new(Config::default()).expect("default config is valid");
    let orb = OrbDetector::new(OrbParams { n_features: 2000, ..OrbParams::default() }).expect("valid ORB params");
    let canny_params = CannyParams::default();

    let mut g = c.benchmark_group(format!("{group}_{}x{}", img.width, img.height));
    g.sample_size(20).warm_up_time(Duration::from_secs(1)).measurement_time(Duration::from_secs(3));
    g.bench_function("edges", |b| b.iter(|| det.edge_image(black_box(img.view())).unwrap()));
    g.bench_function("edges_with_intermediates", |b| b.iter(|| det.edges(black_box(img.view())).unwrap()));
    g.bench_function("detect", |b| b.iter(|| det.detect(black_box(img.view()), None).unwrap()));
    g.bench_function("detect_and_compute", |b| b.iter(|| det.detect_and_compute(black_box(img.view()), None).unwrap()));
    g.bench_function("baseline_canny", |b| b.iter(|| canny(black_box(img), &canny_params)));
    g.bench_function("baseline_fast9", |b| b.iter(|| fast9(black_box(img), 20, true)));
    g.bench_function("baseline_orb2000", |b| b.iter(|| orb.detect_and_compute(black_box(img.view())).unwrap()));
    g.finish();
}

/// `detect_and_compute` of the L-FAST variants docs/quality.md compares, and
/// the ORB-SLAM baseline, in one run (`cargo bench --bench cpu -- variants`).
fn bench_variants(c: &mut Criterion, img: &Plane<u8>) {
    use lfast::Mode;
    use lfast::baseline::orbslam::{OrbSlamDetector, OrbSlamParams};
    let d = Config::default();
    // spelled out in full, so that a row keeps its meaning when the defaults move
    let v = |mode, support, nms_radius, snap_radius, reject_edges| Config {
        mode,
        support,
        nms_radius,
        snap_radius,
        reject_edges,
        ..d.clone()
    };
    let variants = [
        ("default", d.clone()),
        ("branch_s4", v(Mode::Branch, 4, 3, 0, false)),
        ("paper_s3", v(Mode::Paper, 3, 3, 0, false)),
        ("paper_s3_snap1", v(Mode::Paper, 3, 3, 1, false)),
        ("paper_s3_snap1_noedges", v(Mode::Paper, 3, 3, 1, true)),
        ("paper_s3_nms4_snap2", v(Mode::Paper, 3, 4, 2, false)),
        ("paper_s3_nms4_snap2_noedges", v(Mode::Paper, 3, 4, 2, true)),
    ];
    let mut g = c.benchmark_group(format!("variants_{}x{}", img.width, img.height));
    g.sample_size(20).warm_up_time(Duration::from_secs(1)).measurement_time(Duration::from_secs(3));
    for (name, cfg) in variants {
        let det = CpuDetector::new(cfg).expect("valid config");
        g.bench_function(format!("detect_and_compute_{name}"), |b| {
            b.iter(|| det.detect_and_compute(black_box(img.view()), None).unwrap())
        });
    }
    let slam = OrbSlamDetector::new(OrbSlamParams { n_features: 2000, ..Default::default() }).expect("valid params");
    g.bench_function("baseline_orbslam2000", |b| b.iter(|| slam.detect_and_compute(black_box(img.view())).unwrap()));
    g.finish();
}

fn cpu(c: &mut Criterion) {
    // skipped with a message (and logged) when the data is absent, as in a plain clone
    if let Some(img) = common::shared(KITTI).map(|p| load(&p)) {
        bench_image(c, "kitti_seq01_000020", &img);
        bench_variants(c, &img);
    }
    let img = load(&common::data("camera_cc0_v0.18plus.png"));
    bench_image(c, "camera", &img);
}

criterion_group!(benches, cpu);
criterion_main!(benches);
