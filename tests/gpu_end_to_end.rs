//! The whole GPU pipeline against the CPU reference: edge maps and candidate
//! sets bit-identical on every level, keypoints and descriptors identical,
//! on the golden images, a KITTI frame and random images whose sizes cross
//! workgroup boundaries; workspace reuse across sizes; masks; the cap; the
//! texture input; frames in flight through the readback ring.

mod common;

use lfast::config::{Config, Mode};
use lfast::cpu::CpuDetector;
use lfast::gpu::detector::{Frame, GpuDetector, GpuDetectorOptions, GpuInput, GpuWorkspace};
use lfast::image::load_gray;
use lfast::testing as t;
use lfast::wgpu;
use lfast::{Error, KeyPoint, Plane};

fn golden_images() -> Vec<(String, Plane<u8>)> {
    let mut v: Vec<(String, Plane<u8>)> =
        ["astronaut_256.png", "camera_cc0_v0.18plus.png", "chessboard_GRAY.png", "coins.png", "text.png"]
            .iter()
            .map(|n| (n.to_string(), load_gray(common::data(n)).unwrap()))
            .collect();
    if let Some(p) = common::shared("kitti/seq01_000000-000050/image_0/000020.png") {
        v.push(("kitti 000020".into(), load_gray(p).unwrap()));
    }
    v
}

/// Asserts GPU == CPU for keypoints (every field) and descriptors.
fn assert_same(what: &str, gpu: &Frame, cpu: &(Vec<KeyPoint>, Vec<[u8; 32]>)) {
    assert_eq!(gpu.keypoints.len(), cpu.0.len(), "{what}: keypoint count");
    for (i, (g, c)) in gpu.keypoints.iter().zip(&cpu.0).enumerate() {
        assert_eq!(g, c, "{what}: keypoint {i}");
    }
    for (i, (g, c)) in gpu.descriptors.iter().zip(&cpu.1).enumerate() {
        assert_eq!(g, c, "{what}: descriptor {i} of {:?}", gpu.keypoints[i]);
    }
}

/// Pairs of keypoints whose responses differ by at most one f32 ulp but
/// are not equal: where a GPU/CPU rounding difference could swap the order.
fn near_ties(kps: &[KeyPoint]) -> usize {
    kps.windows(2)
        .filter(|w| {
            w[0].response != w[1].response
                && (w[0].response.to_bits() as i64 - w[1].response.to_bits() as i64).abs() <= 1
        })
        .count()
}

#[test]
fn keypoints_and_descriptors_equal_the_cpu_on_the_golden_images() {
    let Some(ctx) = t::context() else { return };
    for mode in [Mode::Branch, Mode::Paper] {
        let cfg = Config { mode, ..Config::default() };
        let gpu = GpuDetector::new(ctx.clone(), cfg.clone()).unwrap();
        let cpu = CpuDetector::new(cfg).unwrap();
        let mut ws = None;
        for (name, img) in golden_images() {
            let g = gpu.detect_and_compute(&mut ws, img.view(), None).unwrap();
            let c = cpu.detect_and_compute(img.view(), None).unwrap();
            assert_same(&format!("{name} {mode:?}"), &g, &c);
            assert!(!g.keypoints.is_empty() || name.contains("chess"), "{name}: no keypoints at all");
            eprintln!(
                "{name} {mode:?}: {} keypoints, identical; near-ties within 1 ulp: {}",
                g.keypoints.len(),
                near_ties(&c.0)
            );
        }
    }
}

#[test]
fn edge_maps_and_candidates_equal_the_cpu_on_every_level() {
    let Some(ctx) = t::context() else { return };
    let cfg = Config::default();
    let gpu = GpuDetector::new(ctx.clone(), cfg.clone()).unwrap();
    let params = lfast::cpu::lfast::LfastParams::from_config(&cfg);
    let mut ws: Option<GpuWorkspace> = None;
    for (name, img) in golden_images() {
        gpu.detect_and_compute(&mut ws, img.view(), None).unwrap();
        let w = ws.as_ref().unwrap();
        let levels = t::cpu_levels(&cfg, &img);
        for (l, lv) in levels.iter().enumerate() {
            let em = lfast::cpu::edge_map(lv, &cfg);
            let e: Vec<u32> = em.edges.data.iter().map(|&v| v as u32).collect();
            assert_eq!(
                t::download_packed(&ctx, &w.buffers, &w.buffers.edges, l).unwrap(),
                e,
                "{name}: edges of level {l}"
            );
            let cands = lfast::cpu::lfast::lfast(&em.edges, None, &params);
            let got = t::download_packed(&ctx, &w.buffers, &w.buffers.cand, l).unwrap();
            let (lw, _) = cfg.level_sizes(img.width, img.height)[l];
            let gpu_cands: Vec<[u32; 2]> =
                got.iter().enumerate().filter(|(_, v)| **v != 0).map(|(i, _)| [i as u32 % lw, i as u32 / lw]).collect();
            let mut cpu_cands = cands.clone();
            cpu_cands.sort_by_key(|c| (c[1], c[0]));
            assert_eq!(gpu_cands, cpu_cands, "{name}: candidates of level {l}");
        }
    }
}

#[test]
fn random_images_across_workgroup_boundaries() {
    let Some(ctx) = t::context() else { return };
    let cfg = Config { n_levels: 4, ..Config::default() };
    let gpu = GpuDetector::new(ctx, cfg.clone()).unwrap();
    let cpu = CpuDetector::new(cfg).unwrap();
    let mut ws = None;
    // the same workspace through growing and shrinking sizes
    for (i, (w, h)) in
        [(100, 77), (257, 129), (33, 33), (160, 90), (16, 16), (1, 1), (300, 17), (129, 257)].into_iter().enumerate()
    {
        let img = t::test_image(w, h, 100 + i as u32);
        let g = gpu.detect_and_compute(&mut ws, img.view(), None).unwrap();
        let c = cpu.detect_and_compute(img.view(), None).unwrap();
        assert_same(&format!("{w}x{h}"), &g, &c);
    }
}

#[test]
fn masks_and_caps_equal_the_cpu() {
    let Some(ctx) = t::context() else { return };
    let img = load_gray(common::data("astronaut_256.png")).unwrap();
    let mut mask = Plane::<u8>::new(img.width, img.height);
    for y in 0..img.height {
        for x in 0..img.width {
            mask.data[(y * img.width + x) as usize] = (x < 180 && y > 30) as u8 * 255;
        }
    }
    for n_features in [0, 1, 50, 200] {
        let cfg = Config { n_features, ..Config::default() };
        let gpu = GpuDetector::new(ctx.clone(), cfg.clone()).unwrap();
        let cpu = CpuDetector::new(cfg).unwrap();
        let mut ws = None;
        for m in [Some(mask.view()), None] {
            let g = gpu.detect_and_compute(&mut ws, img.view(), m).unwrap();
            let c = cpu.detect_and_compute(img.view(), m).unwrap();
            assert_same(&format!("n_features {n_features}, mask {}", m.is_some()), &g, &c);
            if n_features > 0 {
                assert!(g.keypoints.len() <= n_features as usize);
            }
        }
    }
}

#[test]
fn snapped_corners_equal_the_cpu() {
    let Some(ctx) = t::context() else { return };
    let astronaut = load_gray(common::data("astronaut_256.png")).unwrap();
    let mut mask = Plane::<u8>::new(astronaut.width, astronaut.height);
    for (i, m) in mask.data.iter_mut().enumerate() {
        *m = ((i as u32 % astronaut.width) > 70) as u8;
    }
    for (nms_radius, snap_radius, n_features, mode) in
        [(3, 1, 0, Mode::Branch), (4, 2, 0, Mode::Paper), (2, 1, 100, Mode::Branch)]
    {
        let cfg = Config { nms_radius, snap_radius, n_features, mode, support: 3, ..Config::default() };
        let gpu = GpuDetector::new(ctx.clone(), cfg.clone()).unwrap();
        let cpu = CpuDetector::new(cfg).unwrap();
        let unsnapped = CpuDetector::new(Config { snap_radius: 0, ..cpu.config().clone() }).unwrap();
        let mut ws = None;
        for (name, img) in golden_images() {
            for m in [None, Some(mask.view())] {
                if m.is_some() && (img.width, img.height) != (mask.width, mask.height) {
                    continue;
                }
                let what =
                    format!("{name}, nms {nms_radius}, snap {snap_radius}, cap {n_features}, mask {}", m.is_some());
                let g = gpu.detect_and_compute(&mut ws, img.view(), m).unwrap();
                let c = cpu.detect_and_compute(img.view(), m).unwrap();
                assert_same(&what, &g, &c);
                // the snap moved some corners (else this test would check nothing new)
                let before = unsnapped.detect(img.view(), m).unwrap();
                let at = |k: &KeyPoint| (k.octave, k.pt.x.to_bits(), k.pt.y.to_bits());
                let old: std::collections::HashSet<_> = before.iter().map(at).collect();
                let moved = c.0.iter().filter(|k| !old.contains(&at(k))).count();
                assert!(moved > 0 || c.0.is_empty(), "{what}: nothing moved");
                // and located some between pixels (1/16 steps off the half-pixel grid)
                let between =
                    c.0.iter()
                        .filter(|k| {
                            let s = cpu.config().level_scale(k.octave as u32);
                            let f = (k.pt.x as f64 / s - 0.5).rem_euclid(1.0);
                            f > 1e-3 && f < 1.0 - 1e-3
                        })
                        .count();
                assert!(between > 0 || c.0.is_empty(), "{what}: no sub-pixel offset");
                eprintln!(
                    "{what}: {} keypoints, {moved} not at an unsnapped position, {between} between pixels, identical",
                    c.0.len()
                );
            }
        }
    }
}

#[test]
fn texture_input_equals_gray_input() {
    let Some(ctx) = t::context() else { return };
    let rgb = image::open(common::data("astronaut_256.png")).unwrap().to_rgba8();
    let (w, h) = rgb.dimensions();
    let gray = lfast::image::to_gray(&image::DynamicImage::ImageRgba8(rgb.clone())).unwrap();
    let cfg = Config::default();
    let gpu = GpuDetector::new(ctx.clone(), cfg.clone()).unwrap();
    let tex = ctx.device.create_texture(&wgpu::TextureDescriptor {
        label: None,
        size: wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Rgba8Unorm,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    ctx.queue.write_texture(
        tex.as_image_copy(),
        &rgb,
        wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(4 * w), rows_per_image: Some(h) },
        tex.size(),
    );
    let view = tex.create_view(&Default::default());
    let mut ws = gpu.workspace(w, h).unwrap();
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    gpu.encode(&mut enc, GpuInput::Texture(&view, wgpu::TextureFormat::Rgba8Unorm), &mut ws).unwrap();
    let tk = gpu.encode_readback(&mut enc, &mut ws).unwrap();
    ctx.queue.submit([enc.finish()]);
    gpu.start_readback(&mut ws, tk).unwrap();
    let g = gpu.finish_readback(&mut ws, tk).unwrap();
    let c = CpuDetector::new(cfg).unwrap().detect_and_compute(gray.view(), None).unwrap();
    assert_same("rgba texture", &g, &c);
}

#[test]
fn frames_in_flight_through_the_ring() {
    let Some(ctx) = t::context() else { return };
    let cfg = Config::default();
    let gpu = GpuDetector::with_options(
        ctx.clone(),
        cfg.clone(),
        GpuDetectorOptions { ring: 3, profile: true, ..Default::default() },
    )
    .unwrap();
    let cpu = CpuDetector::new(cfg).unwrap();
    let frames: Vec<Plane<u8>> = (0..5).map(|i| t::test_image(200, 120, 7 + i)).collect();
    let mut ws = gpu.workspace(200, 120).unwrap();
    let mut pending = std::collections::VecDeque::new();
    let mut results = Vec::new();
    for f in &frames {
        if pending.len() == ws.ring_len() {
            let tk = pending.pop_front().unwrap();
            results.push(gpu.finish_readback(&mut ws, tk).unwrap());
        }
        ws.write_gray(&ctx.queue, f.view()).unwrap();
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        gpu.encode(&mut enc, GpuInput::Written, &mut ws).unwrap();
        let tk = gpu.encode_readback(&mut enc, &mut ws).unwrap();
        ctx.queue.submit([enc.finish()]);
        gpu.start_readback(&mut ws, tk).unwrap();
        pending.push_back(tk);
    }
    while let Some(tk) = pending.pop_front() {
        results.push(gpu.finish_readback(&mut ws, tk).unwrap());
    }
    for (i, (g, f)) in results.iter().zip(&frames).enumerate() {
        assert_same(&format!("frame {i}"), g, &cpu.detect_and_compute(f.view(), None).unwrap());
        if ctx.has_timestamps() {
            assert_eq!(g.pass_ms.len(), lfast::gpu::detector::STAGES.len());
        }
    }
}

#[test]
fn frames_with_more_keypoints_than_the_readback_hint_are_complete() {
    // The staging copy holds 16 keypoints; the rest comes from the device-side
    // spill copy, which the frame recorded last holds: with two frames in
    // flight the first is an overrun error (naming it), never the second's
    // keypoints (tests/gpu_stream.rs: different frames; Detector::stream runs
    // such a frame again).
    let Some(ctx) = t::context() else { return };
    let cfg = Config::default();
    let opts = GpuDetectorOptions { ring: 2, readback_hint: 16, ..Default::default() };
    let gpu = GpuDetector::with_options(ctx.clone(), cfg.clone(), opts).unwrap();
    let cpu = CpuDetector::new(cfg).unwrap();
    let frames: Vec<Plane<u8>> = golden_images().into_iter().take(3).map(|(_, p)| p).collect();
    for f in &frames {
        // a new workspace copies the hint's 16 keypoints first
        let g = gpu.detect_and_compute(&mut None, f.view(), None).unwrap();
        let c = cpu.detect_and_compute(f.view(), None).unwrap();
        assert!(c.0.len() > 16, "the test needs frames over the hint");
        assert_same("hint 16, blocking", &g, &c);
        assert_eq!(g.count as usize, c.0.len());
    }
    let (w, h) = (frames[0].width, frames[0].height);
    let mut ws = gpu.workspace(w, h).unwrap();
    let mut tickets = Vec::new();
    for _ in 0..2 {
        ws.write_gray(&ctx.queue, frames[0].view()).unwrap();
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        gpu.encode(&mut enc, GpuInput::Written, &mut ws).unwrap();
        tickets.push(gpu.encode_readback(&mut enc, &mut ws).unwrap());
        ctx.queue.submit([enc.finish()]);
    }
    for tk in &tickets {
        gpu.start_readback(&mut ws, *tk).unwrap();
    }
    let c = cpu.detect_and_compute(frames[0].view(), None).unwrap();
    match gpu.finish_readback(&mut ws, tickets[0]) {
        Err(Error::Gpu { reason }) => assert!(reason.contains("overwritten"), "{reason}"),
        Err(e) => panic!("hint 16, in flight, first frame: {e}"),
        Ok(_) => panic!("hint 16, in flight: the first frame's spill was overwritten, yet it came back"),
    }
    assert_same("hint 16, in flight, recorded last", &gpu.finish_readback(&mut ws, tickets[1]).unwrap(), &c);
}

#[test]
fn readback_copies_follow_the_counts_and_stay_complete() {
    // Each copy is sized from the counts before it: a blank frame shrinks the
    // next copy below a rich frame's count (completed from the spill), which
    // then grows the copies; every frame stays whole through the changes.
    let Some(ctx) = t::context() else { return };
    let cfg = Config::default();
    let opts = GpuDetectorOptions { ring: 1, readback_hint: 16, ..Default::default() };
    let gpu = GpuDetector::with_options(ctx, cfg.clone(), opts).unwrap();
    let cpu = CpuDetector::new(cfg).unwrap();
    let rich = golden_images().into_iter().map(|(_, p)| p).max_by_key(|p| p.width as u64 * p.height as u64).unwrap();
    let blank = Plane::<u8>::new(rich.width, rich.height);
    let n_rich = cpu.detect_and_compute(rich.view(), None).unwrap().0.len();
    assert!(n_rich > 256, "the test needs a frame over the smallest copy (256), not {n_rich}");
    let order = [&rich, &blank, &rich, &blank, &blank, &blank, &blank, &rich, &rich];
    let mut ws = None;
    for (i, f) in order.into_iter().enumerate() {
        let g = gpu.detect_and_compute(&mut ws, f.view(), None).unwrap();
        let c = cpu.detect_and_compute(f.view(), None).unwrap();
        assert_same(&format!("frame {i} of the sequence"), &g, &c);
        assert_eq!(g.count as usize, c.0.len());
    }
}

#[test]
fn continuous_orientation_differs_in_few_bits_at_most() {
    let Some(ctx) = t::context() else { return };
    let cfg = Config { orientation_bins: 0, ..Config::default() };
    let gpu = GpuDetector::new(ctx, cfg.clone()).unwrap();
    let cpu = CpuDetector::new(cfg).unwrap();
    let img = load_gray(common::data("astronaut_256.png")).unwrap();
    let g = gpu.detect_and_compute(&mut None, img.view(), None).unwrap();
    let c = cpu.detect_and_compute(img.view(), None).unwrap();
    assert_eq!(g.keypoints, c.0, "keypoints (angles come from the same integer moments)");
    let worst = g.descriptors.iter().zip(&c.1).map(|(a, b)| lfast::hamming(a, b)).max().unwrap_or(0);
    eprintln!("orientation_bins = 0: worst descriptor difference {worst} bits of 256");
    assert!(worst <= 8, "{worst} bits differ");
}

#[test]
fn bad_input_is_a_typed_error() {
    let Some(ctx) = t::context() else { return };
    let gpu = GpuDetector::new(ctx.clone(), Config::default()).unwrap();
    let mut ws = gpu.workspace(64, 48).unwrap();
    let img = Plane::<u8>::new(65, 48);
    assert!(matches!(ws.write_gray(&ctx.queue, img.view()), Err(lfast::Error::InvalidImage { .. })));
    let mask = Plane::<u8>::new(10, 10);
    assert!(matches!(gpu.set_mask(&mut ws, Some(mask.view())), Err(lfast::Error::MaskSize { .. })));
    let e = GpuDetector::new(ctx, Config { distribution: true, n_features: 100, ..Config::default() }).unwrap_err();
    assert!(matches!(e, lfast::Error::Unsupported { .. }), "{e}");
    // a ticket cannot be redeemed before it is started
    let mut enc = gpu.context().device.create_command_encoder(&Default::default());
    let tk = gpu.encode_readback(&mut enc, &mut ws).unwrap();
    assert!(gpu.try_finish_readback(&mut ws, tk).is_err());
}
