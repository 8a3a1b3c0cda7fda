//! Empty and inconsistent planes through every public stage: no panic.

use lfast::cpu::{self, CpuDetector};
use lfast::{Config, Plane};

fn planes() -> Vec<Plane<u8>> {
    vec![
        Plane::new(0, 0),
        Plane::new(0, 5),
        Plane::new(5, 0),
        // inconsistent: fields are public, so a caller can build this
        Plane { width: 10, height: 10, data: vec![0; 7] },
    ]
}

#[test]
fn detector_rejects_bad_planes_with_errors() {
    let det = CpuDetector::new(Config::default()).unwrap();
    for p in planes() {
        let v = p.view();
        assert!(det.edges(v).is_err(), "{}x{}", p.width, p.height);
        assert!(det.detect(v, None).is_err());
        assert!(det.detect_and_compute(v, None).is_err());
        assert!(det.compute(v, &[]).is_err());
        let orb = lfast::baseline::orb::OrbDetector::new(Default::default()).unwrap();
        assert!(orb.detect_and_compute(v).is_err());
    }
}

#[test]
fn stage_functions_return_empty_results() {
    for p in planes().into_iter().filter(|p| p.data.len() == p.width as usize * p.height as usize) {
        let em = cpu::edge_map(&p, &Config::default());
        assert!(em.edges.data.is_empty());
        assert!(cpu::fused::edges_fused(&p, 1000, 10_000, 35).edges.data.is_empty());
        assert!(cpu::blur::gaussian_blur(&p, &cpu::blur::ORB_KERNEL).data.is_empty());
        assert!(lfast::baseline::canny::canny(&p, &Default::default()).data.is_empty());
        assert!(lfast::baseline::fast::fast9(&p, 20, true).is_empty());
        assert!(cpu::pyramid::resize(&p, 0, 0).data.is_empty());
    }
}
