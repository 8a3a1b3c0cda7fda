//! Race stress: the whole pipeline, GPU == CPU on every run, on sizes that
//! cross workgroup (64 invocations, 16-row tiles, quads of four columns) and
//! word (four rows per packed word, 32 pixels per flag word) boundaries,
//! each frame run several times, fresh and in a reused workspace, with
//! frames in flight. lavapipe runs it with as many threads as it is given:
//! this test asks for 16 (`LP_NUM_THREADS`, when the environment does not
//! set it), more than the cores of a CI runner, so that invocations of one
//! dispatch interleave as much as they can there. The shaders' headers state
//! why no two invocations write one word without an atomic; a race would show
//! here as a run that differs from the CPU (or from another run).

mod common;

use common::{TestRng, plane_fn};
use lfast::config::{Config, Mode};
use lfast::cpu::CpuDetector;
use lfast::gpu::detector::{Frame, GpuDetector, GpuDetectorOptions, GpuInput};
use lfast::testing as t;
use lfast::{KeyPoint, Plane};

/// Runs of each frame (each a separate submit).
const RUNS: usize = 3;

/// Rectangles of random levels on a ramp, with a little noise: edges and
/// corners at random places, many of them, on any size.
fn blocks(w: u32, h: u32, seed: u64) -> Plane<u8> {
    let mut r = TestRng::new(seed);
    let rects: Vec<[u32; 5]> = (0..(w * h / 200).max(4))
        .map(|_| {
            let (x, y) = (r.below(w), r.below(h));
            [x, y, x + 2 + r.below(w / 3 + 1), y + 2 + r.below(h / 3 + 1), r.below(256)]
        })
        .collect();
    plane_fn(w, h, |x, y| {
        let base = ((x * 3 + y * 2) % 200) as u8;
        let v =
            rects.iter().rev().find(|q| x >= q[0] && x < q[2] && y >= q[1] && y < q[3]).map_or(base, |q| q[4] as u8);
        v.saturating_add((r.below(5)) as u8)
    })
}

fn assert_same(what: &str, g: &Frame, c: &(Vec<KeyPoint>, Vec<[u8; 32]>)) {
    assert_eq!(g.keypoints.len(), c.0.len(), "{what}: keypoint count");
    assert_eq!(g.keypoints, c.0, "{what}: keypoints");
    assert_eq!(g.descriptors, c.1, "{what}: descriptors");
}

#[test]
fn every_run_equals_the_cpu_with_many_threads() {
    if std::env::var_os("LP_NUM_THREADS").is_none() {
        // SAFETY: set before the device is created, while this (the file's
        // only) test is the one thread that reads the environment.
        unsafe { std::env::set_var("LP_NUM_THREADS", "16") };
    }
    let Some(ctx) = t::context() else { return };
    eprintln!("adapter {}, LP_NUM_THREADS={:?}", ctx.info.name, std::env::var("LP_NUM_THREADS").ok());
    // widths around 4 (quad), 16 (tile), 32 (flag word), 64 (workgroup) and
    // their multiples; heights around 4 (packed word) and 16 (tile rows)
    let sizes = [(63, 17), (64, 16), (65, 33), (97, 47), (129, 15), (131, 66), (191, 49), (257, 35)];
    let mut checked = 0usize;
    for mode in [Mode::Paper, Mode::Branch] {
        let cfg = Config { mode, ..Config::default() };
        let opts = GpuDetectorOptions { ring: RUNS, ..Default::default() };
        let gpu = GpuDetector::with_options(ctx.clone(), cfg.clone(), opts).unwrap();
        let cpu = CpuDetector::new(cfg).unwrap();
        let mut reused = None;
        for (k, &(w, h)) in sizes.iter().enumerate() {
            let img = blocks(w, h, 1000 + k as u64);
            let c = cpu.detect_and_compute(img.view(), None).unwrap();
            checked += c.0.len();
            for run in 0..RUNS {
                let what = format!("{mode:?} {w}x{h} run {run}");
                // a fresh workspace, and one reused across every size
                let g = gpu.detect_and_compute(&mut None, img.view(), None).unwrap();
                assert_same(&format!("{what}, fresh workspace"), &g, &c);
                let g = gpu.detect_and_compute(&mut reused, img.view(), None).unwrap();
                assert_same(&format!("{what}, reused workspace"), &g, &c);
            }
            // RUNS frames in flight at once, read back after the last submit
            let mut ws = gpu.workspace(w, h).unwrap();
            let mut tickets = Vec::new();
            for _ in 0..RUNS {
                ws.write_gray(&ctx.queue, img.view()).unwrap();
                let mut enc = ctx.device.create_command_encoder(&Default::default());
                gpu.encode(&mut enc, GpuInput::Written, &mut ws).unwrap();
                tickets.push(gpu.encode_readback(&mut enc, &mut ws).unwrap());
                ctx.queue.submit([enc.finish()]);
            }
            for tk in &tickets {
                gpu.start_readback(&mut ws, *tk).unwrap();
            }
            for (run, tk) in tickets.into_iter().enumerate() {
                let g = gpu.finish_readback(&mut ws, tk).unwrap();
                assert_same(&format!("{mode:?} {w}x{h} in flight {run}"), &g, &c);
            }
        }
    }
    assert!(checked > 100, "the frames must hold keypoints to compare, not {checked}");
}
