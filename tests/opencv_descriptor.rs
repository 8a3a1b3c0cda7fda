//! `descriptor = "opencv"` (docs/algorithm.md, SPEC 11): the same keypoints as
//! the default, descriptors from src/cpu/opencv, `compute` consistent with
//! `detect_and_compute`, the GPU refusing rather than differing. Equality with
//! cv2 itself is python/tests/test_opencv_descriptor.py and
//! scripts/opencv_descriptors.py (they need cv2).

mod common;

use common::data;
use lfast::cpu::CpuDetector;
use lfast::image::load_gray;
use lfast::{Backend, Config, DescriptorKind, Detector, hamming};

fn opencv() -> Config {
    Config { descriptor: DescriptorKind::Opencv, ..Config::default() }
}

#[test]
fn same_keypoints_other_descriptors() {
    let img = load_gray(data("coins.png")).unwrap();
    let (k0, d0) = CpuDetector::new(Config::default()).unwrap().detect_and_compute(img.view(), None).unwrap();
    let det = CpuDetector::new(opencv()).unwrap();
    let (k1, d1) = det.detect_and_compute(img.view(), None).unwrap();
    assert!(!k0.is_empty());
    assert_eq!(k0, k1);
    assert_eq!(d1.len(), k1.len());
    // lfast's Q8 blur and 30 angle bins differ from OpenCV's by a few bits
    let off: u32 = d0.iter().zip(&d1).map(|(a, b)| hamming(a, b)).sum();
    assert!(off > 0);
    // compute() on those keypoints gives detect_and_compute's descriptors
    assert_eq!(det.compute(img.view(), &k1).unwrap(), d1);
}

#[test]
fn compute_uses_the_given_angle_and_keeps_border_keypoints() {
    let img = load_gray(data("text.png")).unwrap();
    let det = CpuDetector::new(opencv()).unwrap();
    let mut kps = det.detect(img.view(), None).unwrap();
    assert!(kps.len() > 2);
    let d = det.compute(img.view(), &kps).unwrap();
    // another angle, another descriptor (the angle is read, not recomputed)
    kps[0].angle = (kps[0].angle + 90.0) % 360.0;
    let d2 = det.compute(img.view(), &kps).unwrap();
    assert_ne!(d[0], d2[0]);
    assert_eq!(d[1..], d2[1..]);
    // a keypoint at the corner (cv2 drops it) is described, in its place
    let mut corner = kps[1];
    corner.pt = glam::Vec2::new(0.0, 0.0);
    let d3 = det.compute(img.view(), &[kps[2], corner, kps[2]]).unwrap();
    assert_eq!((d3.len(), d3[0]), (3, d3[2]));
    assert_eq!(d3[0], d[2]);
}

#[test]
fn the_option_reads_and_writes_as_toml() {
    let cfg = Config::from_toml_str("descriptor = \"opencv\"").unwrap();
    assert_eq!(cfg.descriptor, DescriptorKind::Opencv);
    assert_eq!(Config::from_toml_str(&cfg.to_toml_string()).unwrap(), cfg);
    assert_eq!(Config::default().descriptor, DescriptorKind::Lfast);
    let e = Config::from_toml_str("descriptor = \"sift\"").unwrap_err().to_string();
    assert!(e.contains("sift"), "{e}");
}

#[test]
fn gpu_refuses_and_auto_describes_on_the_cpu() {
    // lavapipe in CI (REQUIRE_GPU=1 makes its absence a failure there)
    let Some(ctx) = lfast::testing::context() else { return };
    let img = load_gray(data("coins.png")).unwrap();
    let cpu = Detector::new(opencv(), Backend::Cpu).unwrap();
    let (want_k, want_d) = cpu.detect_and_compute(img.view(), None).unwrap();
    let gpu = Detector::from_context(ctx.clone(), opencv()).unwrap();
    // keypoints do not depend on the descriptor: the GPU gives them
    assert_eq!(gpu.detect(img.view(), None).unwrap(), want_k);
    let e = gpu.detect_and_compute(img.view(), None).unwrap_err().to_string();
    assert!(e.contains("descriptor") && e.contains("CPU-only"), "{e}");
    // the GPU pipeline itself refuses the option rather than describe otherwise
    let Err(e) = lfast::gpu::detector::GpuDetector::new(ctx.clone(), opencv()) else {
        panic!("GpuDetector took descriptor = opencv");
    };
    let e = e.to_string();
    assert!(e.contains("descriptor") && e.contains("CPU-only"), "{e}");
    let auto = Detector::from_context_with_fallback(ctx, opencv()).unwrap();
    assert_eq!(auto.detect_and_compute(img.view(), None).unwrap(), (want_k, want_d));
}

#[test]
fn equals_cv2_orb_compute_on_its_own_keypoints() {
    // tests/data/orb_opencv/*.json: scripts/opencv_orb_golden.py (cv2 5.0.0)
    let det = CpuDetector::new(opencv()).unwrap();
    for name in ["coins", "text"] {
        let img = load_gray(data(&format!("{name}.png"))).unwrap();
        let text = std::fs::read_to_string(data(&format!("orb_opencv/{name}.json"))).unwrap();
        let rows: Vec<(f32, f32, f32, i32, String)> = serde_json::from_str(&text).unwrap();
        assert!(rows.len() > 200, "{name}");
        assert!(rows.iter().any(|r| r.3 > 0), "{name}: keypoints of several octaves");
        let kps: Vec<lfast::KeyPoint> = rows
            .iter()
            .map(|&(x, y, angle, octave, _)| lfast::KeyPoint { angle, octave, ..lfast::KeyPoint::new(x, y, 31.0) })
            .collect();
        let got = det.compute(img.view(), &kps).unwrap();
        for (i, (d, r)) in got.iter().zip(&rows).enumerate() {
            let hex: String = d.iter().map(|b| format!("{b:02x}")).collect();
            assert_eq!(hex, r.4, "{name}: keypoint {i} {:?}", kps[i]);
        }
    }
}
