//! `Detector::stream` (src/stream.rs): frames in flight on the GPU give the
//! results of one call per frame on the CPU, frame for frame, through size
//! changes, refused frames and readback overruns; and the ring API reports an
//! overrun instead of returning another frame's keypoints.
//!
//! Run with `WGPU_ADAPTER_NAME=llvmpipe REQUIRE_GPU=1 cargo test --test gpu_stream`.

use lfast::config::Config;
use lfast::cpu::CpuDetector;
use lfast::gpu::detector::{GpuDetector, GpuDetectorOptions, GpuInput};
use lfast::image::load_gray;
use lfast::testing as t;
use lfast::{Backend, Detector, Error, Plane};

/// A `w x h` frame: flat (no keypoints), or the camera picture's window at
/// (`seed` * 13, `seed` * 7) (hundreds of keypoints).
fn frame(w: u32, h: u32, seed: u32, flat: bool) -> Plane<u8> {
    if flat {
        return Plane::from_vec(w, h, vec![90; (w * h) as usize]).unwrap();
    }
    let cam = load_gray(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/camera_cc0_v0.18plus.png")).unwrap();
    let (x0, y0) = ((seed * 13) % (cam.width - w), (seed * 7) % (cam.height - h));
    let data = (y0..y0 + h).flat_map(|y| cam.view().row(y)[x0 as usize..(x0 + w) as usize].to_vec()).collect();
    Plane::from_vec(w, h, data).unwrap()
}

/// Streams `frames` through `det` and checks each result against the CPU's.
fn check_stream(det: &Detector, cpu: &CpuDetector, frames: &[Plane<u8>]) -> usize {
    // three in flight, whatever the adapter (one is lavapipe's default)
    let mut stream = det.stream_with::<usize>(3);
    assert!(stream.on_gpu(), "a detector on a GPU context streams on the GPU");
    let mut done = Vec::new();
    for (i, f) in frames.iter().enumerate() {
        done.extend(stream.push(i, f.clone()));
        assert!(stream.in_flight() <= 3, "no more frames in flight than asked");
    }
    done.extend(stream.finish());
    let mut tags: Vec<usize> = done.iter().map(|d| d.tag).collect();
    tags.sort();
    assert_eq!(tags, (0..frames.len()).collect::<Vec<_>>(), "every frame comes back once");
    let mut keypoints = 0;
    for d in done {
        let f = &frames[d.tag];
        assert_eq!(&d.image, f, "frame {} handed back changed", d.tag);
        let want = cpu.detect_and_compute(f.view(), None);
        match (d.result, want) {
            (Ok(got), Ok(want)) => {
                assert_eq!(got.0, want.0, "frame {}: keypoints", d.tag);
                assert_eq!(got.1, want.1, "frame {}: descriptors", d.tag);
                keypoints += got.0.len();
            }
            (Err(e), Err(w)) => assert_eq!(e.to_string(), w.to_string(), "frame {}", d.tag),
            (got, want) => {
                panic!("frame {}: stream {:?}, CPU {:?}", d.tag, got.map(|r| r.0.len()), want.map(|r| r.0.len()))
            }
        }
    }
    keypoints
}

#[test]
fn stream_matches_one_call_per_frame() {
    let Some(ctx) = t::context() else { return };
    let cfg = Config::default();
    let det = Detector::from_context(ctx, cfg.clone()).unwrap();
    let cpu = CpuDetector::new(cfg).unwrap();
    // three flat frames, so the fourth's readback is sized for a handful of
    // keypoints and spills; frames 5 and 6 are recorded before it is read
    // back (an overrun: it runs once more); then a new size, an empty and a
    // bad frame (the caller's errors, in their place), and the first size again
    let mut frames: Vec<Plane<u8>> = (0..3).map(|i| frame(400, 300, i, true)).collect();
    frames.extend((0..4).map(|i| frame(400, 300, 10 + i, false)));
    frames.extend((0..2).map(|i| frame(131, 67, 20 + i, false)));
    frames.push(Plane { width: 0, height: 0, data: Vec::new() });
    frames.push(Plane { width: 40, height: 30, data: vec![7; 100] });
    frames.extend((0..2).map(|i| frame(400, 300, 30 + i, false)));
    // the fourth frame's copy holds 256 keypoints (the flat frames' 0, plus 64,
    // in whole steps of 256): it spills
    let spills = cpu.detect_and_compute(frames[3].view(), None).unwrap().0.len();
    assert!(spills > 256, "frame 3 spills ({spills} keypoints)");
    let n = check_stream(&det, &cpu, &frames);
    assert!(n > 2000, "the textured frames have keypoints ({n})");
    // the workspace is free again: a plain call works after the stream
    let one = det.detect_and_compute(frames[5].view(), None).unwrap();
    assert_eq!(one, cpu.detect_and_compute(frames[5].view(), None).unwrap());
    // the default depth (one on a software adapter), and one frame at a time
    for depth in [0, 1] {
        let mut stream = det.stream_with::<usize>(depth);
        let mut done = Vec::new();
        for (i, f) in frames[3..9].iter().enumerate() {
            done.extend(stream.push(i, f.clone()));
            if depth == 1 {
                assert!(stream.in_flight() <= 1);
            }
        }
        done.extend(stream.finish());
        assert_eq!(done.len(), 6);
        for d in done {
            let r = d.result.unwrap();
            assert_eq!(
                r,
                cpu.detect_and_compute(frames[3 + d.tag].view(), None).unwrap(),
                "depth {depth}, frame {}",
                d.tag
            );
        }
    }
}

#[test]
fn stream_on_the_cpu_runs_each_frame_when_pushed() {
    let cfg = Config::default();
    let det = Detector::new(cfg.clone(), Backend::Cpu).unwrap();
    let cpu = CpuDetector::new(cfg).unwrap();
    let mut stream = det.stream();
    assert!(!stream.on_gpu());
    for (i, f) in [frame(90, 70, 1, false), Plane { width: 5, height: 5, data: vec![] }].into_iter().enumerate() {
        let want = cpu.detect_and_compute(f.view(), None);
        let done = stream.push(i, f.clone());
        assert_eq!(done.len(), 1);
        assert_eq!(stream.in_flight(), 0);
        assert_eq!((done[0].tag, &done[0].image), (i, &f));
        match (&done[0].result, &want) {
            (Ok(a), Ok(b)) => assert_eq!(a, b),
            (Err(a), Err(b)) => assert!(matches!(a, Error::InvalidImage { .. }) && a.to_string() == b.to_string()),
            _ => panic!("frame {i}: stream and CPU disagree"),
        }
    }
    assert!(stream.finish().is_empty());
}

#[test]
fn ring_reports_an_overrun_instead_of_another_frames_keypoints() {
    let Some(ctx) = t::context() else { return };
    let cfg = Config::default();
    // the first copy sized for 1 keypoint: a textured frame spills
    let opts = GpuDetectorOptions { ring: 2, readback_hint: 1, ..Default::default() };
    let gpu = GpuDetector::with_options(ctx.clone(), cfg.clone(), opts).unwrap();
    let cpu = CpuDetector::new(cfg).unwrap();
    let (a, b) = (frame(200, 150, 4, false), frame(200, 150, 5, false));
    let mut ws = gpu.workspace(200, 150).unwrap();
    let mut tickets = Vec::new();
    for f in [&a, &b] {
        ws.write_gray(&ctx.queue, f.view()).unwrap();
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        gpu.encode(&mut enc, GpuInput::Written, &mut ws).unwrap();
        tickets.push(gpu.encode_readback(&mut enc, &mut ws).unwrap());
        ctx.queue.submit([enc.finish()]);
    }
    for &tk in &tickets {
        gpu.start_readback(&mut ws, tk).unwrap();
    }
    // a's rest was in the spill, which b has overwritten
    let Err(e) = gpu.finish_readback(&mut ws, tickets[0]) else { panic!("an overrun is an error, not a frame") };
    assert!(matches!(&e, Error::Gpu { reason } if reason.contains("overwritten")), "{e}");
    // b was recorded last: its spill is whole
    let got = gpu.finish_readback(&mut ws, tickets[1]).unwrap();
    let want = cpu.detect_and_compute(b.view(), None).unwrap();
    assert!(want.0.len() > 1, "frame b spills ({} keypoints)", want.0.len());
    assert_eq!((got.keypoints, got.descriptors), want);
}
