//! The GPU workspace's memory (src/gpu/footprint.rs): the report is exactly what
//! a workspace allocates; the buffers that share an allocation are the ones the
//! report names; the workspace stays within its budget per pixel and a 4K
//! frame fits wgpu's default limits; and the sharing changes no output: the
//! mask allocated by the first mask (and the stages bound to it anew), frames
//! of several sizes through one workspace, each equal to the CPU.

mod common;

use lfast::config::Config;
use lfast::cpu::CpuDetector;
use lfast::gpu::detector::{Frame, GpuDetector};
use lfast::gpu::{Buffers, workspace_report};
use lfast::testing as t;
use lfast::wgpu;
use lfast::{KeyPoint, Plane};

/// Every buffer of `b`, by field name.
fn fields(b: &Buffers) -> Vec<(&'static str, &wgpu::Buffer)> {
    vec![
        ("params", &b.params),
        ("level_index", &b.level_index),
        ("input", &b.input),
        ("gray", &b.gray),
        ("mask", &b.mask),
        ("denoised", &b.denoised),
        ("m", &b.m),
        ("nms", &b.nms),
        ("hist", &b.hist),
        ("otsu", &b.otsu),
        ("grid", &b.grid),
        ("windows", &b.windows),
        ("cell_hist", &b.cell_hist),
        ("classes", &b.classes),
        ("ruled", &b.ruled),
        ("walks", &b.walks),
        ("labels", &b.labels),
        ("flags", &b.flags),
        ("edges", &b.edges),
        ("edge_bits", &b.edge_bits),
        ("blur_tiles", &b.blur_tiles),
        ("cand", &b.cand),
        ("cand_list", &b.cand_list),
        ("edge_list", &b.edge_list),
        ("resp", &b.resp),
        ("corners", &b.corners),
        ("ranks", &b.ranks),
        ("sel_buckets", &b.sel_buckets),
        ("sel_members", &b.sel_members),
        ("keypoints", &b.keypoints),
        ("descriptors", &b.descriptors),
        ("counters", &b.counters),
        ("indirect", &b.indirect),
        ("smooth", &b.smooth),
        ("patterns", &b.patterns),
        ("angle_bounds", &b.angle_bounds),
    ]
}

#[test]
fn the_report_is_what_a_workspace_allocates() {
    let Some(ctx) = t::context() else { return };
    let cfgs = [Config::default(), Config { n_features: 500, orientation_bins: 0, ..Config::default() }];
    for cfg in &cfgs {
        for (w, h) in [(1u32, 1u32), (17, 33), (640, 480), (1241, 376)] {
            let what = format!("{w}x{h}, n_features {}", cfg.n_features);
            let b = Buffers::new(&ctx.device, cfg, w, h).unwrap();
            let report = workspace_report(cfg, w, h).unwrap();
            // the allocations: fields grouped by the buffer they are
            let mut groups: Vec<(Vec<&str>, &wgpu::Buffer)> = Vec::new();
            for (name, buf) in fields(&b) {
                match groups.iter_mut().find(|g| g.1 == buf) {
                    Some(g) => g.0.push(name),
                    None => groups.push((vec![name], buf)),
                }
            }
            let mut got: Vec<(String, u64)> = groups.iter().map(|(n, buf)| (n.join(" = "), buf.size())).collect();
            let mut want: Vec<(String, u64)> = report.buffers.iter().map(|&(n, s)| (n.to_string(), s)).collect();
            got.sort();
            want.sort();
            assert_eq!(got, want, "{what}");
            // final keypoint slots: the cap when there is one
            let slots = b.keypoints.size() / 48;
            if cfg.n_features > 0 {
                assert!(slots >= cfg.n_features.min(b.layout.capacity) as u64 && slots <= 500, "{what}: {slots}");
            } else {
                assert_eq!(slots, b.layout.capacity as u64, "{what}");
            }
        }
    }
}

#[test]
fn the_workspace_stays_within_its_budget_and_4k_fits_the_default_limits() {
    // Bytes per pixel before planes shared allocations (BENCHMARKS.md "GPU
    // workspace", `lfast info --size` at 06a9c26); the budget is 60% of that.
    let cfg = Config::default();
    for (w, h, before) in [(640u32, 480u32, 116.8), (1241, 376, 113.5), (1920, 1080, 109.9), (3840, 2160, 109.4)] {
        let r = workspace_report(&cfg, w, h).unwrap();
        assert!(r.bytes_per_pixel() <= 0.6 * before, "{w}x{h}: {:.1} bytes per pixel", r.bytes_per_pixel());
    }
    let r = workspace_report(&cfg, 3840, 2160).unwrap();
    r.fits(&wgpu::Limits::default()).unwrap();
    let e = workspace_report(&cfg, 4000, 3000).unwrap().fits(&wgpu::Limits::default()).unwrap_err().to_string();
    for part in ["4000x3000", "148596868", "max_storage_buffer_binding_size 134217728"] {
        assert!(e.contains(part), "{e}");
    }
}

fn assert_same(what: &str, gpu: &Frame, cpu: &(Vec<KeyPoint>, Vec<[u8; 32]>)) {
    assert_eq!(gpu.keypoints, cpu.0, "{what}: keypoints");
    assert_eq!(gpu.descriptors, cpu.1, "{what}: descriptors");
}

#[test]
fn shared_allocations_and_the_late_mask_change_no_output() {
    let Some(ctx) = t::context() else { return };
    for cfg in [Config::default(), Config { n_features: 300, ..Config::default() }] {
        let gpu = GpuDetector::new(ctx.clone(), cfg.clone()).unwrap();
        let cpu = CpuDetector::new(cfg.clone()).unwrap();
        let mut ws = None;
        // frames without a mask first (the mask plane is not allocated), then
        // with one (allocated, the stages bound anew), then without, across a
        // shrink (buffers reused) and a grow (reallocated)
        for (i, (w, h, masked)) in [
            (256u32, 200u32, false),
            (256, 200, true),
            (256, 200, false),
            (130, 97, true),
            (300, 260, true),
            (300, 260, false),
        ]
        .into_iter()
        .enumerate()
        {
            let img = t::test_image(w, h, 40 + i as u32);
            let mut mask = Plane::<u8>::new(w, h);
            for (k, m) in mask.data.iter_mut().enumerate() {
                let (x, y) = (k as u32 % w, k as u32 / w);
                *m = (x * 3 > w && y * 4 < 3 * h) as u8 * 255;
            }
            let m = masked.then(|| mask.view());
            let g = gpu.detect_and_compute(&mut ws, img.view(), m).unwrap();
            let c = cpu.detect_and_compute(img.view(), m).unwrap();
            assert!(!c.0.is_empty());
            assert_same(&format!("frame {i}: {w}x{h}, mask {masked}, n_features {}", cfg.n_features), &g, &c);
        }
    }
}
