//! The GPU path under stress: property tests on sizes that cross workgroup
//! and window boundaries (GPU == CPU, keypoints, descriptors and edge maps),
//! determinism of the atomics, typed errors for faults (device loss, small
//! limits, no adapter, unsupported configs, bad inputs to the embedding API)
//! and workspace reuse across shrinking and growing sizes.
//!
//! Run with `WGPU_ADAPTER_NAME=llvmpipe REQUIRE_GPU=1 cargo test --test gpu_robustness`.

mod common;

use lfast::config::{Config, Mode};
use lfast::cpu::CpuDetector;
use lfast::gpu::detector::{Frame, GpuDetector, GpuDetectorOptions, GpuInput, GpuWorkspace};
use lfast::gpu::testing as t;
use lfast::gpu::{GpuContext, GpuOptions};
use lfast::image::load_gray;
use lfast::wgpu;
use lfast::{Backend, Detector, Error, KeyPoint, Plane};
use proptest::prelude::*;
use proptest::strategy::{BoxedStrategy, Union};
use proptest::test_runner::{TestCaseError, TestRunner};
use std::cell::RefCell;
use std::time::Instant;

// ---------------------------------------------------------------------------
// helpers

type CpuResult = (Vec<KeyPoint>, Vec<[u8; 32]>);

/// `Ok` when the GPU frame equals the CPU's (every keypoint field, descriptors).
fn same(what: &str, gpu: &Frame, cpu: &CpuResult) -> Result<(), String> {
    if gpu.keypoints.len() != cpu.0.len() || gpu.descriptors.len() != cpu.1.len() {
        return Err(format!(
            "{what}: GPU {} keypoints / {} descriptors, CPU {} / {}",
            gpu.keypoints.len(),
            gpu.descriptors.len(),
            cpu.0.len(),
            cpu.1.len()
        ));
    }
    if gpu.raw.len() != gpu.keypoints.len() {
        return Err(format!("{what}: {} raw keypoints for {} keypoints", gpu.raw.len(), gpu.keypoints.len()));
    }
    for (i, (g, c)) in gpu.keypoints.iter().zip(&cpu.0).enumerate() {
        if g != c {
            return Err(format!("{what}: keypoint {i}: GPU {g:?} CPU {c:?}"));
        }
    }
    for (i, (g, c)) in gpu.descriptors.iter().zip(&cpu.1).enumerate() {
        if g != c {
            return Err(format!("{what}: descriptor {i} of {:?}: GPU {g:?} CPU {c:?}", gpu.keypoints[i]));
        }
    }
    Ok(())
}

fn assert_same(what: &str, gpu: &Frame, cpu: &CpuResult) {
    if let Err(e) = same(what, gpu, cpu) {
        panic!("{e}");
    }
}

/// `Ok` when two GPU frames are identical to the bit, raw keypoints included.
fn identical(what: &str, a: &Frame, b: &Frame) -> Result<(), String> {
    if a.raw.len() != b.raw.len() {
        return Err(format!("{what}: {} vs {} keypoints", a.raw.len(), b.raw.len()));
    }
    for (i, (x, y)) in a.raw.iter().zip(&b.raw).enumerate() {
        if bytemuck::bytes_of(x) != bytemuck::bytes_of(y) {
            return Err(format!("{what}: raw keypoint {i}: {x:?} vs {y:?}"));
        }
    }
    if a.keypoints != b.keypoints {
        return Err(format!("{what}: keypoints differ"));
    }
    if a.descriptors != b.descriptors {
        let i = a.descriptors.iter().zip(&b.descriptors).position(|(x, y)| x != y);
        return Err(format!("{what}: descriptors differ (first at {i:?})"));
    }
    Ok(())
}

/// A plane from a closure of (x, y).
fn plane(w: u32, h: u32, f: impl Fn(u32, u32) -> u8) -> Plane<u8> {
    let mut p = Plane::<u8>::new(w, h);
    for y in 0..h {
        for x in 0..w {
            p.data[(y * w + x) as usize] = f(x, y);
        }
    }
    p
}

fn xorshift(seed: u32) -> impl FnMut() -> u32 {
    let mut s = seed.wrapping_mul(0x9E37_79B9) | 1;
    move || {
        s ^= s << 13;
        s ^= s >> 17;
        s ^= s << 5;
        s
    }
}

/// What an image of a property case holds.
#[derive(Clone, Debug)]
enum Content {
    /// `t::test_image`: ramps and blocks (edges, corners).
    Structured(u32),
    /// Uniform noise: edges everywhere, hardly any corner.
    Noise(u32),
    /// `t::test_image` plus noise of amplitude `.1` (saturating).
    Mixed(u32, u8),
    /// Black and white rectangles on gray: strong corners, many equal responses.
    Blocks(u32),
    /// One value everywhere (no gradient at all).
    Flat(u8),
    /// Every pixel chosen by proptest (small sizes).
    Pixels(Vec<u8>),
}

fn render(c: &Content, w: u32, h: u32) -> Plane<u8> {
    match c {
        Content::Structured(s) => t::test_image(w, h, *s),
        Content::Noise(s) => {
            let mut r = xorshift(*s);
            let mut p = Plane::<u8>::new(w, h);
            p.data.iter_mut().for_each(|v| *v = r() as u8);
            p
        }
        Content::Mixed(s, a) => {
            let mut p = t::test_image(w, h, *s);
            let mut r = xorshift(s.wrapping_add(77));
            let a = *a as i32;
            p.data.iter_mut().for_each(|v| {
                let n = (r() % (2 * a as u32 + 1)) as i32 - a;
                *v = (*v as i32 + n).clamp(0, 255) as u8;
            });
            p
        }
        Content::Blocks(s) => {
            let mut r = xorshift(*s);
            let rects: Vec<(u32, u32, u32, u32, u8)> = (0..12)
                .map(|_| {
                    let (x, y) = (r() % w, r() % h);
                    let (rw, rh) = (4 + r() % (w / 3 + 4), 4 + r() % (h / 3 + 4));
                    (x, y, rw, rh, if r() % 2 == 0 { 0 } else { 255 })
                })
                .collect();
            plane(w, h, |x, y| {
                rects
                    .iter()
                    .rev()
                    .find(|&&(rx, ry, rw, rh, _)| x >= rx && x < rx + rw && y >= ry && y < ry + rh)
                    .map_or(128, |r| r.4)
            })
        }
        Content::Flat(v) => plane(w, h, |_, _| *v),
        Content::Pixels(px) => {
            let mut p = Plane::<u8>::new(w, h);
            p.data.copy_from_slice(px);
            p
        }
    }
}

/// Image contents for a `w x h` frame: pixel vectors only for small frames;
/// `rich` = only contents with corners (for the expensive sizes).
fn contents(w: u32, h: u32, rich: bool) -> BoxedStrategy<Content> {
    let mut arms: Vec<BoxedStrategy<Content>> = vec![
        any::<u32>().prop_map(Content::Structured).boxed(),
        (any::<u32>(), 1u8..48).prop_map(|(s, a)| Content::Mixed(s, a)).boxed(),
        any::<u32>().prop_map(Content::Blocks).boxed(),
    ];
    if !rich {
        arms.push(any::<u32>().prop_map(Content::Noise).boxed());
        arms.push(any::<u8>().prop_map(Content::Flat).boxed());
    }
    let n = (w * h) as usize;
    if n <= 4096 {
        arms.push(proptest::collection::vec(any::<u8>(), n).prop_map(Content::Pixels).boxed());
        // a second pixel arm with few gray levels: large flat areas and steps
        arms.push(
            proptest::collection::vec(prop_oneof![Just(0u8), Just(128u8), Just(255u8)], n).prop_map(Content::Pixels).boxed(),
        );
    }
    Union::new(arms).boxed()
}

fn runner(cases: u32) -> TestRunner {
    TestRunner::new(proptest::test_runner::Config {
        cases,
        max_shrink_iters: 64,
        failure_persistence: None,
        ..proptest::test_runner::Config::default()
    })
}

/// The default config in `mode`.
fn default_in(mode: Mode) -> Config {
    Config { mode, ..Config::default() }
}

/// The smallest border and NMS window, few levels: corners fit in frames from
/// 15x15 on, and keypoints sit closer to the sides than the descriptor's
/// pattern reaches.
fn tight(mode: Mode) -> Config {
    Config { mode, border: 7, nms_radius: 1, n_levels: 3, ..Config::default() }
}

/// Property: for random contents of each size, GPU keypoints, descriptors and
/// level-0 edge maps equal the CPU's, under the config proptest picks from
/// `cfgs`. One workspace per config is reused across cases and sizes.
fn gpu_equals_cpu_on(sizes: &[(u32, u32)], cases: u32, rich: bool, cfgs: &[Config]) {
    let Some(ctx) = t::context() else { return };
    let dets: Vec<(String, GpuDetector, CpuDetector, RefCell<Option<GpuWorkspace>>)> = cfgs
        .iter()
        .map(|cfg| {
            let name = format!("{:?} border {} r {} levels {}", cfg.mode, cfg.border, cfg.nms_radius, cfg.n_levels);
            (name, GpuDetector::new(ctx.clone(), cfg.clone()).unwrap(), CpuDetector::new(cfg.clone()).unwrap(), RefCell::new(None))
        })
        .collect();
    for &(w, h) in sizes {
        let start = Instant::now();
        let corners = std::cell::Cell::new(0usize);
        let strategy = (contents(w, h, rich), 0..dets.len());
        let r = runner(cases).run(&strategy, |(content, m)| {
            let (name, gpu, cpu, ws) = &dets[m];
            let img = render(&content, w, h);
            let what = format!("{w}x{h} [{name}] {}", short(&content));
            let mut ws = ws.borrow_mut();
            let g = gpu.detect_and_compute(&mut ws, img.view(), None).map_err(|e| TestCaseError::fail(format!("{what}: {e}")))?;
            let c = cpu.detect_and_compute(img.view(), None).map_err(|e| TestCaseError::fail(format!("{what}: {e}")))?;
            same(&what, &g, &c).map_err(TestCaseError::fail)?;
            corners.set(corners.get() + g.keypoints.len());
            let ge = gpu.edge_image(&mut ws, img.view()).map_err(|e| TestCaseError::fail(format!("{what}: {e}")))?;
            let ce = cpu.edge_image(img.view()).map_err(|e| TestCaseError::fail(format!("{what}: {e}")))?;
            prop_assert_eq!((ge.width, ge.height), (w, h));
            if ge.data != ce.data {
                let i = ge.data.iter().zip(&ce.data).position(|(a, b)| a != b).unwrap_or(0) as u32;
                return Err(TestCaseError::fail(format!(
                    "{what}: edge maps differ first at ({}, {}): GPU {} CPU {}",
                    i % w,
                    i / w,
                    ge.data[i as usize],
                    ce.data[i as usize]
                )));
            }
            Ok(())
        });
        if let Err(e) = r {
            panic!("{w}x{h}: {e}");
        }
        eprintln!("{w}x{h}: {cases} cases, {} keypoints in all, {:.2?}", corners.get(), start.elapsed());
    }
}

/// The content without its pixel vector, for messages.
fn short(c: &Content) -> String {
    match c {
        Content::Pixels(p) => format!("Pixels({} px)", p.len()),
        c => format!("{c:?}"),
    }
}

// ---------------------------------------------------------------------------
// 1. property tests: GPU == CPU on sizes crossing workgroup (16) and window boundaries

#[test]
fn prop_tiny_sizes_gpu_equals_cpu() {
    gpu_equals_cpu_on(&[(1, 1), (2, 2), (7, 7)], 12, false, &[default_in(Mode::Branch), default_in(Mode::Paper), tight(Mode::Branch)]);
}

#[test]
fn prop_16x16_and_17x33_gpu_equals_cpu() {
    // 16x16 = one workgroup exactly; 17x33 = one pixel into the next ones.
    // The tight configs leave room for corners (16 > 2 * 7).
    let cfgs = [default_in(Mode::Branch), tight(Mode::Branch), tight(Mode::Paper), Config { border: 7, ..default_in(Mode::Paper) }];
    gpu_equals_cpu_on(&[(16, 16), (17, 33)], 16, false, &cfgs);
}

#[test]
fn prop_255x257_gpu_equals_cpu() {
    gpu_equals_cpu_on(&[(255, 257)], 5, true, &[default_in(Mode::Branch), default_in(Mode::Paper), tight(Mode::Paper)]);
}

#[test]
fn prop_1241x376_gpu_equals_cpu_branch() {
    // KITTI's frame size.
    gpu_equals_cpu_on(&[(1241, 376)], 2, true, &[default_in(Mode::Branch)]);
}

#[test]
fn prop_1241x376_gpu_equals_cpu_paper() {
    gpu_equals_cpu_on(&[(1241, 376)], 1, true, &[default_in(Mode::Paper)]);
}

#[test]
fn prop_4097x3_gpu_equals_cpu() {
    // 257 workgroups wide, 3 rows: no level has room for a corner, but every
    // edge stage runs over a 4097-wide row and pyramid levels of height 2..3.
    gpu_equals_cpu_on(&[(4097, 3)], 3, false, &[default_in(Mode::Branch), default_in(Mode::Paper), tight(Mode::Branch)]);
}

#[test]
fn detector_front_door_edge_images_equal_the_cpu() {
    let Some(_ctx) = t::context() else { return };
    let det = Detector::new(Config::default(), Backend::Gpu).unwrap();
    assert_eq!(det.backend_name(), "gpu");
    let cpu = CpuDetector::new(Config::default()).unwrap();
    for (i, &(w, h)) in [(1, 1), (2, 2), (7, 7), (16, 16), (17, 33), (255, 257), (4097, 3)].iter().enumerate() {
        let img = t::test_image(w, h, 900 + i as u32);
        assert_eq!(det.edge_image(img.view()).unwrap().data, cpu.edge_image(img.view()).unwrap().data, "{w}x{h}");
        let (k, d) = det.detect_and_compute(img.view(), None).unwrap();
        let c = cpu.detect_and_compute(img.view(), None).unwrap();
        assert_eq!((k, d), c, "{w}x{h}");
    }
}

// ---------------------------------------------------------------------------
// 2. determinism: the order in which atomics land must not show in the output

/// Frames for the determinism tests: one with thousands of keypoints, one
/// with many equal responses (black and white blocks), a structured one.
fn determinism_frames() -> Vec<(String, Plane<u8>)> {
    vec![
        ("camera".into(), load_gray(common::data("camera_cc0_v0.18plus.png")).unwrap()),
        ("blocks 300x220".into(), render(&Content::Blocks(5), 300, 220)),
        ("mixed 320x240".into(), render(&Content::Mixed(11, 30), 320, 240)),
    ]
}

#[test]
fn repeated_frames_are_bit_identical() {
    let Some(ctx) = t::context() else { return };
    let frames = determinism_frames();
    for cfg in [
        Config::default(),
        // thousands of corners, a cap that cuts among them, equal responses
        Config { mode: Mode::Paper, nms_radius: 0, border: 7, n_features: 2000, ..Config::default() },
    ] {
        let gpu = GpuDetector::new(ctx.clone(), cfg.clone()).unwrap();
        let cpu = CpuDetector::new(cfg.clone()).unwrap();
        // a: a fresh workspace per frame
        let t0 = Instant::now();
        let a: Vec<Frame> = frames.iter().map(|(_, f)| gpu.detect_and_compute(&mut None, f.view(), None).unwrap()).collect();

        for ((name, f), g) in frames.iter().zip(&a) {
            assert_same(&format!("{name} {cfg:?}"), g, &cpu.detect_and_compute(f.view(), None).unwrap());
        }
        let camera = a[0].keypoints.len();
        assert!(camera > 1000, "the camera frame should have many keypoints, has {camera}");
        // b: one workspace through all frames, the camera twice in a row, and
        // each frame after a different one of another size
        let mut ws = None;
        let order = [0, 0, 2, 1];
        for (k, &i) in order.iter().enumerate() {
            let g = gpu.detect_and_compute(&mut ws, frames[i].1.view(), None).unwrap();
            let what = format!("{} run {k} {:?} n_features {}", frames[i].0, cfg.mode, cfg.n_features);
            identical(&what, &a[i], &g).unwrap_or_else(|e| panic!("{e}"));
        }
        eprintln!(
            "{:?} r {} n_features {}: camera frame {camera} keypoints, bit-identical ({:.2?})",
            cfg.mode,
            cfg.nms_radius,
            cfg.n_features,
            t0.elapsed()
        );
    }
}

#[test]
fn frames_in_flight_are_bit_identical_to_blocking_ones() {
    // Several frames recorded and submitted before any is read back, in one
    // submit and in separate ones: same results as one at a time.
    let Some(ctx) = t::context() else { return };
    let cfg = Config::default();
    let gpu = GpuDetector::with_options(ctx.clone(), cfg, GpuDetectorOptions { ring: 4, profile: false }).unwrap();
    let astronaut = load_gray(common::data("astronaut_256.png")).unwrap();
    let (w, h) = (astronaut.width, astronaut.height);
    let frames: Vec<Plane<u8>> = vec![astronaut.clone(), render(&Content::Blocks(2), w, h), astronaut.clone()];
    let blocking: Vec<Frame> = frames.iter().map(|f| gpu.detect_and_compute(&mut None, f.view(), None).unwrap()).collect();
    let mut ws = gpu.workspace(w, h).unwrap();
    // Each frame goes through its own gray buffer (GpuInput::GrayBuffer), so
    // all can be recorded into one encoder.
    let inputs: Vec<wgpu::Buffer> = frames
        .iter()
        .map(|f| {
            let mut bytes = f.data.clone();
            bytes.resize(bytes.len().next_multiple_of(4), 0);
            wgpu::util::DeviceExt::create_buffer_init(
                &ctx.device,
                &wgpu::util::BufferInitDescriptor { label: None, contents: &bytes, usage: wgpu::BufferUsages::COPY_SRC },
            )
        })
        .collect();
    for one_submit in [true, false] {
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        let mut tickets = Vec::new();
        for input in &inputs {
            gpu.encode(&mut enc, GpuInput::GrayBuffer(input), &mut ws).unwrap();
            tickets.push(gpu.encode_readback(&mut enc, &mut ws).unwrap());
            if !one_submit {
                ctx.queue.submit([std::mem::replace(&mut enc, ctx.device.create_command_encoder(&Default::default())).finish()]);
            }
        }
        ctx.queue.submit([enc.finish()]);
        for &tk in &tickets {
            gpu.start_readback(&mut ws, tk).unwrap();
        }
        // redeem out of order
        for (i, &tk) in tickets.iter().enumerate().rev() {
            let g = gpu.finish_readback(&mut ws, tk).unwrap();
            identical(&format!("frame {i}, one submit {one_submit}"), &blocking[i], &g).unwrap_or_else(|e| panic!("{e}"));
        }
    }
    assert!(blocking[0].keypoints.len() > 100);
}

// ---------------------------------------------------------------------------
// 3. faults: typed errors, never a panic

/// The adapter the environment selects (`WGPU_BACKEND`, `WGPU_ADAPTER_NAME`), as `GpuContext::new` picks it.
fn env_adapter() -> wgpu::Adapter {
    let backends = wgpu::Backends::from_env().unwrap_or(wgpu::Backends::PRIMARY);
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
    desc.backends = backends;
    let inst = wgpu::Instance::new(desc);
    let all = pollster::block_on(inst.enumerate_adapters(backends));
    let want = std::env::var("WGPU_ADAPTER_NAME").unwrap_or_default().to_lowercase();
    all.into_iter().find(|a| a.get_info().name.to_lowercase().contains(&want)).expect("the test adapter")
}

/// A context on a device of our own with `limits` (instead of the adapter's).
fn context_with_limits(limits: wgpu::Limits) -> std::result::Result<GpuContext, wgpu::RequestDeviceError> {
    let adapter = env_adapter();
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("small limits"),
        required_limits: limits,
        ..Default::default()
    }))?;
    Ok(GpuContext::from_device(device, queue, adapter.get_info()))
}

fn is_device_lost(e: &Error) -> bool {
    matches!(e, Error::DeviceLost { .. })
}

/// A device of our own (the shared test device must stay alive), a detector
/// that has run one frame on it, that frame's CPU result.
fn doomed_device() -> (GpuContext, GpuDetector, Option<GpuWorkspace>, Plane<u8>, CpuResult) {
    let ctx = GpuContext::new(&GpuOptions::default()).unwrap();
    let cfg = Config::default();
    let gpu = GpuDetector::new(ctx.clone(), cfg.clone()).unwrap();
    let img = t::test_image(96, 80, 4);
    let cpu = CpuDetector::new(cfg).unwrap().detect_and_compute(img.view(), None).unwrap();
    let mut ws = None;
    assert_same("before the loss", &gpu.detect_and_compute(&mut ws, img.view(), None).unwrap(), &cpu);
    (ctx, gpu, ws, img, cpu)
}

#[test]
fn device_loss_is_a_typed_error() {
    let Some(_) = t::context() else { return };
    let (ctx, gpu, mut ws, img, cpu) = doomed_device();
    let cfg = gpu.config().clone();
    let det = Detector::from_context(ctx.clone(), cfg.clone()).unwrap();
    assert_eq!(det.detect_and_compute(img.view(), None).unwrap(), cpu);
    assert_eq!(det.backend_name(), "gpu");
    let mut ws2 = gpu.workspace(96, 80).unwrap();

    ctx.device.destroy();
    // wgpu reports the loss from the next poll (maintain); the first frame
    // after a destroy is `the_first_frame_after_a_loss_reports_device_lost`.
    let _ = ctx.device.poll(wgpu::PollType::Poll);

    let e = gpu.detect_and_compute(&mut ws, img.view(), None).unwrap_err();
    assert!(is_device_lost(&e), "detect_and_compute: {e:?}");
    let e = gpu.detect_and_compute(&mut None, img.view(), None).unwrap_err();
    assert!(is_device_lost(&e), "detect_and_compute, fresh workspace: {e:?}");
    let e = gpu.edge_image(&mut ws, img.view()).unwrap_err();
    assert!(is_device_lost(&e), "edge_image: {e:?}");
    let e = gpu.workspace(96, 80).unwrap_err();
    assert!(is_device_lost(&e), "workspace: {e:?}");
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    let e = gpu.encode(&mut enc, GpuInput::Written, &mut ws2).unwrap_err();
    assert!(is_device_lost(&e), "encode: {e:?}");
    drop(enc);
    let e = GpuDetector::new(ctx.clone(), cfg.clone()).unwrap_err();
    assert!(is_device_lost(&e), "GpuDetector::new: {e:?}");
    let e = Detector::from_context(ctx.clone(), cfg.clone()).unwrap_err();
    assert!(is_device_lost(&e), "Detector::from_context: {e:?}");
    // from_context is Backend::Gpu: the loss is reported, not hidden
    let e = det.detect_and_compute(img.view(), None).unwrap_err();
    assert!(is_device_lost(&e), "Detector (from_context): {e:?}");
    let e = det.edge_image(img.view()).unwrap_err();
    assert!(is_device_lost(&e), "Detector::edge_image (from_context): {e:?}");
    assert!(e.to_string().contains("lost"), "{e}");
}

#[test]
fn the_first_frame_after_a_loss_reports_device_lost() {
    // No poll between the destroy and the frame: the library must still say
    // DeviceLost (not a generic map_async failure).
    let Some(_) = t::context() else { return };
    let (ctx, gpu, mut ws, img, _) = doomed_device();
    ctx.device.destroy();
    let e = gpu.detect_and_compute(&mut ws, img.view(), None).unwrap_err();
    assert!(is_device_lost(&e), "the first frame after the loss: {e:?}");
}

/// Runs `f`, turning a panic into its message.
fn no_panic<T>(f: impl FnOnce() -> T) -> Result<T, String> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)).map_err(|p| {
        p.downcast_ref::<String>().cloned().or(p.downcast_ref::<&str>().map(|s| s.to_string())).unwrap_or_default()
    })
}

#[test]
fn right_after_a_loss_nothing_panics() {
    // No poll between the destroy and the calls: wgpu has not reported the
    // loss yet, so `check_lost` passes and the library creates resources on
    // the destroyed device.
    let Some(_) = t::context() else { return };
    let mut failures = Vec::new();
    let mut check = |what: &str, r: Result<Result<(), Error>, String>| match r {
        Ok(Err(e)) if is_device_lost(&e) => {}
        Ok(Err(e)) => eprintln!("{what}: typed error, not DeviceLost: {e:?}"),
        Ok(Ok(())) => failures.push(format!("{what}: succeeded on a destroyed device")),
        Err(p) => failures.push(format!("{what}: PANICKED: {p}")),
    };
    {
        let (ctx, gpu, _, img, _) = doomed_device();
        ctx.device.destroy();
        check("detect_and_compute with a new workspace", no_panic(|| gpu.detect_and_compute(&mut None, img.view(), None).map(|_| ())));
    }
    {
        let (ctx, gpu, _, _, _) = doomed_device();
        ctx.device.destroy();
        check("GpuDetector::workspace", no_panic(|| gpu.workspace(50, 40).map(|_| ())));
    }
    {
        let (ctx, gpu, _, _, _) = doomed_device();
        ctx.device.destroy();
        check("GpuDetector::new", no_panic(|| GpuDetector::new(ctx.clone(), gpu.config().clone()).map(|_| ())));
    }
    {
        let (ctx, gpu, _, _, _) = doomed_device();
        ctx.device.destroy();
        check("Detector::from_context", no_panic(|| Detector::from_context(ctx.clone(), gpu.config().clone()).map(|_| ())));
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn a_frame_in_flight_when_the_device_is_lost() {
    let Some(_) = t::context() else { return };
    let (ctx, gpu, _, img, _) = doomed_device();
    let mut ws = gpu.workspace(96, 80).unwrap();
    ws.write_gray(&ctx.queue, img.view()).unwrap();
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    gpu.encode(&mut enc, GpuInput::Written, &mut ws).unwrap();
    let tk = gpu.encode_readback(&mut enc, &mut ws).unwrap();
    ctx.queue.submit([enc.finish()]);
    gpu.start_readback(&mut ws, tk).unwrap();
    ctx.device.destroy();
    // the frame either completed before the loss or reports it; it must not hang or panic
    match gpu.finish_readback(&mut ws, tk) {
        Ok(f) => eprintln!("frame in flight finished before the loss: {} keypoints", f.keypoints.len()),
        Err(e) => {
            eprintln!("frame in flight: {e:?}");
            assert!(matches!(e, Error::DeviceLost { .. } | Error::Gpu { .. }), "{e:?}");
        }
    }
}

#[test]
fn probe_limits() {
    let a = env_adapter();
    eprintln!("{:#?}", a.limits());
    for (name, l) in [("downlevel", wgpu::Limits::downlevel_defaults()), ("1MiB", wgpu::Limits { max_storage_buffer_binding_size: 1 << 20, max_buffer_size: 1 << 20, ..a.limits() })] {
        let ctx = context_with_limits(l).unwrap();
        let r = no_panic(|| GpuDetector::new(ctx.clone(), Config::default()).map(|_| ()));
        eprintln!("{name}: {r:?}");
    }
}
