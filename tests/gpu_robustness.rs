//! The GPU path under stress: property tests on sizes that cross workgroup
//! and window boundaries (GPU == CPU, keypoints, descriptors and edge maps),
//! determinism of the atomics, typed errors for faults (device loss, small
//! limits, no adapter, unsupported configs, bad inputs to the embedding API)
//! and workspace reuse across shrinking and growing sizes.
//!
//! Run with `WGPU_ADAPTER_NAME=llvmpipe REQUIRE_GPU=1 cargo test --test gpu_robustness`.

mod common;

use common::plane_fn as plane;
use lfast::config::{Config, Mode};
use lfast::cpu::CpuDetector;
use lfast::gpu::detector::{Frame, GpuDetector, GpuDetectorOptions, GpuInput, GpuWorkspace};
use lfast::gpu::{GpuContext, GpuOptions};
use lfast::image::load_gray;
use lfast::testing as t;
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

/// A stream of random words (the tests' one generator, tests/common).
fn xorshift(seed: u32) -> impl FnMut() -> u32 {
    let mut r = common::TestRng::new(seed.into());
    move || r.next_u32()
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
            let n = 12 + (w * h / 2000).min(400);
            let rects: Vec<(u32, u32, u32, u32, u8)> = (0..n)
                .map(|_| {
                    let (x, y) = (r() % w, r() % h);
                    let (rw, rh) = (4 + r() % (w / 5 + 4), 4 + r() % (h / 5 + 4));
                    (x, y, rw, rh, if r().is_multiple_of(2) { 0 } else { 255 })
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
            proptest::collection::vec(prop_oneof![Just(0u8), Just(128u8), Just(255u8)], n)
                .prop_map(Content::Pixels)
                .boxed(),
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
            (
                name,
                GpuDetector::new(ctx.clone(), cfg.clone()).unwrap(),
                CpuDetector::new(cfg.clone()).unwrap(),
                RefCell::new(None),
            )
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
            let g = gpu
                .detect_and_compute(&mut ws, img.view(), None)
                .map_err(|e| TestCaseError::fail(format!("{what}: {e}")))?;
            let c =
                cpu.detect_and_compute(img.view(), None).map_err(|e| TestCaseError::fail(format!("{what}: {e}")))?;
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
    gpu_equals_cpu_on(
        &[(1, 1), (2, 2), (7, 7)],
        12,
        false,
        &[default_in(Mode::Branch), default_in(Mode::Paper), tight(Mode::Branch)],
    );
}

#[test]
fn prop_16x16_and_17x33_gpu_equals_cpu() {
    // 16x16 = one workgroup exactly; 17x33 = one pixel into the next ones.
    // The tight configs leave room for corners (16 > 2 * 7).
    let cfgs = [
        default_in(Mode::Branch),
        tight(Mode::Branch),
        tight(Mode::Paper),
        Config { border: 7, ..default_in(Mode::Paper) },
    ];
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
    gpu_equals_cpu_on(
        &[(4097, 3)],
        3,
        false,
        &[default_in(Mode::Branch), default_in(Mode::Paper), tight(Mode::Branch)],
    );
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
        let a: Vec<Frame> =
            frames.iter().map(|(_, f)| gpu.detect_and_compute(&mut None, f.view(), None).unwrap()).collect();

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
    let gpu = GpuDetector::with_options(
        ctx.clone(),
        cfg,
        GpuDetectorOptions { ring: 4, profile: false, ..Default::default() },
    )
    .unwrap();
    let astronaut = load_gray(common::data("astronaut_256.png")).unwrap();
    let (w, h) = (astronaut.width, astronaut.height);
    let frames: Vec<Plane<u8>> = vec![astronaut.clone(), render(&Content::Blocks(2), w, h), astronaut.clone()];
    let blocking: Vec<Frame> =
        frames.iter().map(|f| gpu.detect_and_compute(&mut None, f.view(), None).unwrap()).collect();
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
                &wgpu::util::BufferInitDescriptor {
                    label: None,
                    contents: &bytes,
                    usage: wgpu::BufferUsages::COPY_SRC,
                },
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
                ctx.queue.submit([
                    std::mem::replace(&mut enc, ctx.device.create_command_encoder(&Default::default())).finish()
                ]);
            }
        }
        ctx.queue.submit([enc.finish()]);
        for &tk in &tickets {
            gpu.start_readback(&mut ws, tk).unwrap();
        }
        // redeem out of order
        for (i, &tk) in tickets.iter().enumerate().rev() {
            let g = gpu.finish_readback(&mut ws, tk).unwrap();
            identical(&format!("frame {i}, one submit {one_submit}"), &blocking[i], &g)
                .unwrap_or_else(|e| panic!("{e}"));
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
        check(
            "detect_and_compute with a new workspace",
            no_panic(|| gpu.detect_and_compute(&mut None, img.view(), None).map(|_| ())),
        );
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
        check(
            "Detector::from_context",
            no_panic(|| Detector::from_context(ctx.clone(), gpu.config().clone()).map(|_| ())),
        );
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

/// The adapter's limits with storage bindings and buffers of at most `bytes`.
fn small_buffers(bytes: u64) -> wgpu::Limits {
    wgpu::Limits { max_storage_buffer_binding_size: bytes, max_buffer_size: bytes, ..env_adapter().limits() }
}

/// lfast's own device is warmed up while the detector builds (empty
/// dispatches on a small workspace); an embedder's queue gets no submission
/// it did not ask for. Both give the same frames.
#[test]
fn only_lfasts_own_device_is_warmed_up_and_both_give_the_same_frames() {
    let Some(own) = t::context() else { return };
    assert!(own.owns_queue());
    let theirs = context_with_limits(env_adapter().limits()).unwrap();
    assert!(!theirs.owns_queue());
    let img = load_gray(common::data("coins.png")).unwrap();
    let run = |ctx: GpuContext| {
        let det = GpuDetector::new(ctx, Config::default()).unwrap();
        det.detect_and_compute(&mut None, img.view(), None).unwrap()
    };
    let (a, b) = (run(own), run(theirs));
    assert!(a.keypoints.len() > 100);
    assert_eq!((a.keypoints, a.descriptors), (b.keypoints, b.descriptors));
}

#[test]
fn frames_over_small_limits_are_gpu_limits_errors() {
    let Some(_) = t::context() else { return };
    let ctx = context_with_limits(small_buffers(4 << 20)).unwrap();
    let cfg = Config::default();
    let gpu = GpuDetector::new(ctx.clone(), cfg.clone()).unwrap();
    let cpu = CpuDetector::new(cfg.clone()).unwrap();
    // 800x600: the 8-level atlas is ~1.48M pixels = 5.9 MB per buffer > 4 MiB
    // (400x300 fits: 1.48 MB per pixel buffer, 2.4 MB of window histograms)
    let big = t::test_image(800, 600, 6);
    let e = gpu.workspace(800, 600).unwrap_err();
    assert!(matches!(e, Error::GpuLimits { .. }), "workspace: {e:?}");
    eprintln!("800x600 on 4 MiB buffers: {e}");
    let mut ws = None;
    let e = no_panic(|| gpu.detect_and_compute(&mut ws, big.view(), None)).unwrap().unwrap_err();
    assert!(matches!(e, Error::GpuLimits { .. }), "detect_and_compute: {e:?}");
    let e = no_panic(|| gpu.edge_image(&mut ws, big.view())).unwrap().unwrap_err();
    assert!(matches!(e, Error::GpuLimits { .. }), "edge_image: {e:?}");
    // a frame that fits still works, before and after a refused one
    let small = t::test_image(400, 300, 6);
    let g = gpu.detect_and_compute(&mut ws, small.view(), None).unwrap();
    assert_same("400x300 on 4 MiB buffers", &g, &cpu.detect_and_compute(small.view(), None).unwrap());
    let e = gpu.detect_and_compute(&mut ws, big.view(), None).unwrap_err();
    assert!(matches!(e, Error::GpuLimits { .. }), "{e:?}");
    let g = gpu.detect_and_compute(&mut ws, small.view(), None).unwrap();
    assert_same("400x300 after a refused frame", &g, &cpu.detect_and_compute(small.view(), None).unwrap());
    // the front door on this device reports it too (from_context = Backend::Gpu)
    let det = Detector::from_context(ctx.clone(), cfg).unwrap();
    let e = det.detect_and_compute(big.view(), None).unwrap_err();
    assert!(matches!(e, Error::GpuLimits { .. }), "Detector: {e:?}");
}

#[test]
fn frames_whose_readback_exceeds_max_buffer_size_are_gpu_limits_errors() {
    // One level, no corner NMS: 150x150 has 136^2 = 18496 keypoint slots,
    // 48 bytes each in `keypoints` (888 kB, fits 1 MiB) but 80 bytes each in
    // a staging buffer of the readback ring (1.48 MB, does not).
    let Some(_) = t::context() else { return };
    let ctx = context_with_limits(small_buffers(1 << 20)).unwrap();
    let cfg = Config { n_levels: 1, nms_radius: 0, border: 7, ..Config::default() };
    let gpu = GpuDetector::new(ctx.clone(), cfg.clone()).unwrap();
    let img = t::test_image(150, 150, 8);
    let r = no_panic(|| gpu.detect_and_compute(&mut None, img.view(), None));
    match r {
        Err(p) => panic!("panicked: {p}"),
        Ok(Ok(g)) => {
            assert_same("150x150", &g, &CpuDetector::new(cfg).unwrap().detect_and_compute(img.view(), None).unwrap())
        }
        Ok(Err(e)) => assert!(matches!(e, Error::GpuLimits { .. }), "expected GpuLimits, got {e:?}"),
    }
    // and through the workspace alone: a workspace is either usable or refused
    match no_panic(|| gpu.workspace(150, 150)) {
        Err(p) => panic!("panicked: {p}"),
        Ok(Err(e)) => assert!(matches!(e, Error::GpuLimits { .. }), "{e:?}"),
        Ok(Ok(mut ws)) => {
            ws.write_gray(&ctx.queue, img.view()).unwrap();
            let scope = ctx.device.push_error_scope(wgpu::ErrorFilter::Validation);
            let mut enc = ctx.device.create_command_encoder(&Default::default());
            gpu.encode(&mut enc, GpuInput::Written, &mut ws).unwrap();
            let tk = gpu.encode_readback(&mut enc, &mut ws).unwrap();
            ctx.queue.submit([enc.finish()]);
            let err = pollster::block_on(scope.pop());
            assert!(err.is_none(), "a workspace the library handed out fails validation: {}", err.unwrap());
            gpu.start_readback(&mut ws, tk).unwrap();
            gpu.finish_readback(&mut ws, tk).unwrap();
        }
    }
}

#[test]
fn frames_over_the_workgroup_limit_are_gpu_limits_errors() {
    let Some(_) = t::context() else { return };
    let limits = wgpu::Limits { max_compute_workgroups_per_dimension: 64, ..env_adapter().limits() };
    let ctx = context_with_limits(limits).unwrap();
    let cfg = Config::default();
    let gpu = GpuDetector::new(ctx.clone(), cfg.clone()).unwrap();
    // 1025 pixels wide = 65 workgroups of 16
    let wide = t::test_image(1025, 40, 9);
    let e = no_panic(|| gpu.detect_and_compute(&mut None, wide.view(), None)).unwrap().unwrap_err();
    assert!(matches!(e, Error::GpuLimits { .. }), "{e:?}");
    // 1024 wide fits
    let ok = t::test_image(1024, 40, 9);
    let g = gpu.detect_and_compute(&mut None, ok.view(), None).unwrap();
    assert_same(
        "1024x40, 64 workgroups",
        &g,
        &CpuDetector::new(cfg).unwrap().detect_and_compute(ok.view(), None).unwrap(),
    );
}

#[test]
fn keypoint_dispatches_over_the_workgroup_limit_are_gpu_limits_errors() {
    // The per-corner and per-keypoint passes are dispatched indirectly with
    // ceil(n / 64) groups. With 64 groups per dimension, more than 4096
    // corners cannot be dispatched: the frame must be refused (GpuLimits) or
    // processed correctly, never silently truncated.
    let Some(_) = t::context() else { return };
    let limits = wgpu::Limits { max_compute_workgroups_per_dimension: 64, ..env_adapter().limits() };
    let ctx = context_with_limits(limits).unwrap();
    let cfg = Config { nms_radius: 0, border: 7, ..Config::default() };
    let gpu = GpuDetector::new(ctx.clone(), cfg.clone()).unwrap();
    let img = load_gray(common::data("camera_cc0_v0.18plus.png")).unwrap(); // 512x512: 32 groups a side
    let cpu = CpuDetector::new(cfg).unwrap().detect_and_compute(img.view(), None).unwrap();
    assert!(cpu.0.len() > 64 * 64, "{} keypoints", cpu.0.len());
    match no_panic(|| gpu.detect_and_compute(&mut None, img.view(), None)) {
        Err(p) => panic!("panicked: {p}"),
        Ok(Ok(g)) => assert_same("camera, 64 workgroups per dimension", &g, &cpu),
        Ok(Err(e)) => assert!(matches!(e, Error::GpuLimits { .. }), "expected GpuLimits, got {e:?}"),
    }
}

#[test]
fn downlevel_limits_are_a_typed_error() {
    // Too few storage buffers per stage for the pipelines: refused when the
    // detector is built.
    let Some(_) = t::context() else { return };
    let ctx = context_with_limits(wgpu::Limits::downlevel_defaults()).unwrap();
    let e = no_panic(|| GpuDetector::new(ctx.clone(), Config::default())).unwrap().unwrap_err();
    assert!(matches!(e, Error::Gpu { .. } | Error::GpuLimits { .. } | Error::Unsupported { .. }), "{e:?}");
    eprintln!("downlevel_defaults: {e}");
    let e = Detector::from_context(ctx, Config::default()).unwrap_err();
    assert!(matches!(e, Error::Gpu { .. } | Error::GpuLimits { .. } | Error::Unsupported { .. }), "{e:?}");
}

#[test]
fn auto_runs_a_frame_over_the_device_limits_on_the_cpu() {
    // Without corner NMS and with the smallest border there is a keypoint
    // slot per pixel (48 bytes): the smallest square frame whose slots exceed
    // the device's storage binding limit is refused by the GPU path; Auto
    // runs it on the CPU and keeps the GPU for the next frames.
    let Some(ctx) = t::context() else { return };
    let cfg = Config { nms_radius: 0, border: 7, ..Config::default() };
    let limit = ctx.device.limits().max_storage_buffer_binding_size.min(ctx.device.limits().max_buffer_size);
    let over = |s: u32| {
        let l = lfast::gpu::FrameLayout::new(&cfg, s, s);
        l.capacity as u64 * 48 > limit || l.total_px as u64 * 4 > limit
    };
    let Some(side) = (64..=2048u32).step_by(32).find(|&s| over(s)) else {
        eprintln!("NOT RUN: storage bindings of {limit} bytes hold every frame up to 2048x2048 on this device");
        return;
    };
    eprintln!("the smallest square frame over {limit} bytes: {side}x{side}");
    let big = t::test_image(side, side, 10);
    let small = t::test_image(120, 90, 10);
    let cpu = CpuDetector::new(cfg.clone()).unwrap();
    let gpu_only = Detector::new(cfg.clone(), Backend::Gpu).unwrap();
    let e = gpu_only.detect_and_compute(big.view(), None).unwrap_err();
    assert!(matches!(e, Error::GpuLimits { .. }), "Backend::Gpu: {e:?}");
    let auto = Detector::new(cfg.clone(), Backend::Auto).unwrap();
    assert_eq!(auto.backend_name(), "gpu");
    assert_eq!(
        auto.detect_and_compute(small.view(), None).unwrap(),
        cpu.detect_and_compute(small.view(), None).unwrap()
    );
    assert_eq!(auto.detect_and_compute(big.view(), None).unwrap(), cpu.detect_and_compute(big.view(), None).unwrap());
    assert_eq!(auto.backend_name(), "gpu", "a frame over the limits must not switch later frames to the CPU");
    assert_eq!(
        auto.detect_and_compute(small.view(), None).unwrap(),
        cpu.detect_and_compute(small.view(), None).unwrap()
    );
}

#[test]
fn no_adapter_is_a_typed_error_and_auto_falls_back_to_the_cpu() {
    let Some(_) = t::context() else { return };
    let opts = GpuOptions { adapter_name: Some("no-such-adapter".into()), ..Default::default() };
    let e = GpuContext::new(&opts).unwrap_err();
    assert!(matches!(e, Error::NoAdapter { .. }), "{e:?}");
    assert!(e.to_string().contains("no-such-adapter"), "the error names the adapter asked for: {e}");
    eprintln!("{e}");
    let cfg = Config::default();
    let e = Detector::with_gpu_options(cfg.clone(), Backend::Gpu, &opts).unwrap_err();
    assert!(matches!(e, Error::NoAdapter { .. }), "Backend::Gpu: {e:?}");
    let auto = Detector::with_gpu_options(cfg.clone(), Backend::Auto, &opts).unwrap();
    assert_eq!(auto.backend_name(), "cpu");
    assert_eq!(auto.adapter_name(), None);
    let cpu = CpuDetector::new(cfg).unwrap();
    let img = load_gray(common::data("astronaut_256.png")).unwrap();
    assert_eq!(auto.detect_and_compute(img.view(), None).unwrap(), cpu.detect_and_compute(img.view(), None).unwrap());
    assert_eq!(auto.edge_image(img.view()).unwrap().data, cpu.edge_image(img.view()).unwrap().data);
}

#[test]
fn unsupported_configs_are_typed_errors_and_auto_runs_them_on_the_cpu() {
    let Some(ctx) = t::context() else { return };
    let cfg = Config { distribution: true, n_features: 150, ..Config::default() };
    let e = GpuDetector::new(ctx.clone(), cfg.clone()).unwrap_err();
    assert!(matches!(e, Error::Unsupported { .. }), "{e:?}");
    let e = Detector::from_context(ctx.clone(), cfg.clone()).unwrap_err();
    assert!(matches!(e, Error::Unsupported { .. }), "from_context: {e:?}");
    let e = Detector::new(cfg.clone(), Backend::Gpu).unwrap_err();
    assert!(matches!(e, Error::Unsupported { .. }), "Backend::Gpu: {e:?}");
    let auto = Detector::new(cfg.clone(), Backend::Auto).unwrap();
    assert_eq!(auto.backend_name(), "cpu");
    let img = load_gray(common::data("astronaut_256.png")).unwrap();
    let got = auto.detect_and_compute(img.view(), None).unwrap();
    assert_eq!(got, CpuDetector::new(cfg).unwrap().detect_and_compute(img.view(), None).unwrap());
    assert!(!got.0.is_empty() && got.0.len() <= 150);
    // an invalid config is InvalidConfig on every backend, Auto included
    let bad = Config { n_levels: 0, ..Config::default() };
    assert!(matches!(GpuDetector::new(ctx.clone(), bad.clone()).unwrap_err(), Error::InvalidConfig { .. }));
    assert!(matches!(Detector::new(bad.clone(), Backend::Auto).unwrap_err(), Error::InvalidConfig { .. }));
    // a readback ring of 0 slots
    let e = GpuDetector::with_options(
        ctx,
        Config::default(),
        GpuDetectorOptions { ring: 0, profile: false, ..Default::default() },
    )
    .unwrap_err();
    assert!(matches!(e, Error::InvalidConfig { .. }), "{e:?}");
}

// ---------------------------------------------------------------------------
// bad inputs to the embedding API

#[test]
fn wrong_sizes_are_typed_errors() {
    let Some(ctx) = t::context() else { return };
    let cfg = Config::default();
    let gpu = GpuDetector::new(ctx.clone(), cfg.clone()).unwrap();
    let cpu = CpuDetector::new(cfg.clone()).unwrap();
    let mut ws = gpu.workspace(64, 48).unwrap();
    for (w, h) in [(65, 48), (64, 47), (48, 64), (1, 1)] {
        let e = ws.write_gray(&ctx.queue, Plane::<u8>::new(w, h).view()).unwrap_err();
        assert!(matches!(e, Error::InvalidImage { .. }), "gray {w}x{h}: {e:?}");
        let e = gpu.set_mask(&mut ws, Some(Plane::<u8>::new(w, h).view())).unwrap_err();
        assert!(matches!(e, Error::MaskSize { .. }), "mask {w}x{h}: {e:?}");
    }
    // the blocking API: a mask of another size than the image
    let img = t::test_image(64, 48, 12);
    let mut ows = None;
    let e = gpu.detect_and_compute(&mut ows, img.view(), Some(Plane::<u8>::new(63, 48).view())).unwrap_err();
    assert!(matches!(e, Error::MaskSize { .. }), "{e:?}");
    // an empty image and one over MAX_SIDE
    for (w, h) in [(0, 10), (10, 0), (lfast::image::MAX_SIDE + 1, 1)] {
        let e = gpu.workspace(w, h).unwrap_err();
        assert!(matches!(e, Error::InvalidImage { .. }), "workspace {w}x{h}: {e:?}");
    }
    let e = gpu.detect_and_compute(&mut ows, Plane::<u8>::new(0, 5).view(), None).unwrap_err();
    assert!(matches!(e, Error::InvalidImage { .. }), "{e:?}");
    // the workspace still works after the refusals, and the front door reports the same
    assert_same(
        "after refusals",
        &gpu.detect_and_compute(&mut ows, img.view(), None).unwrap(),
        &cpu.detect_and_compute(img.view(), None).unwrap(),
    );
    let det = Detector::from_context(ctx.clone(), cfg.clone()).unwrap();
    let e = det.detect_and_compute(img.view(), Some(Plane::<u8>::new(63, 48).view())).unwrap_err();
    assert!(matches!(e, Error::MaskSize { .. }), "{e:?}");
    let auto = Detector::new(cfg, Backend::Auto).unwrap();
    let e = auto.detect_and_compute(img.view(), Some(Plane::<u8>::new(63, 48).view())).unwrap_err();
    assert!(matches!(e, Error::MaskSize { .. }), "Auto: {e:?}");
    assert_eq!(auto.backend_name(), "gpu", "bad input must not switch Auto to the CPU");
}

#[test]
fn readback_tickets_are_checked() {
    let Some(ctx) = t::context() else { return };
    let cfg = Config::default();
    let gpu = GpuDetector::with_options(
        ctx.clone(),
        cfg.clone(),
        GpuDetectorOptions { ring: 2, profile: false, ..Default::default() },
    )
    .unwrap();
    let cpu = CpuDetector::new(cfg).unwrap();
    let img = t::test_image(80, 60, 13);
    let expected = cpu.detect_and_compute(img.view(), None).unwrap();
    let mut ws = gpu.workspace(80, 60).unwrap();
    ws.write_gray(&ctx.queue, img.view()).unwrap();

    // more readbacks than the ring holds
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    gpu.encode(&mut enc, GpuInput::Written, &mut ws).unwrap();
    let t1 = gpu.encode_readback(&mut enc, &mut ws).unwrap();
    let t2 = gpu.encode_readback(&mut enc, &mut ws).unwrap();
    assert_ne!(t1, t2);
    let e = gpu.encode_readback(&mut enc, &mut ws).unwrap_err();
    assert!(matches!(e, Error::Gpu { .. }), "a third readback on a ring of 2: {e:?}");
    // redeeming before starting
    assert!(gpu.try_finish_readback(&mut ws, t1).is_err());
    assert!(gpu.finish_readback(&mut ws, t1).is_err(), "finish_readback before start_readback must not wait forever");
    ctx.queue.submit([enc.finish()]);
    gpu.start_readback(&mut ws, t1).unwrap();
    // starting twice
    assert!(matches!(gpu.start_readback(&mut ws, t1).unwrap_err(), Error::Gpu { .. }));
    gpu.start_readback(&mut ws, t2).unwrap();
    assert_same("t1", &gpu.finish_readback(&mut ws, t1).unwrap(), &expected);
    // redeeming twice
    let e = gpu.finish_readback(&mut ws, t1).unwrap_err();
    assert!(matches!(e, Error::Gpu { .. }), "t1 redeemed twice: {e:?}");
    assert!(gpu.try_finish_readback(&mut ws, t1).is_err());
    assert!(gpu.start_readback(&mut ws, t1).is_err(), "t1 restarted after it was redeemed");
    assert_same("t2", &gpu.finish_readback(&mut ws, t2).unwrap(), &expected);
    assert!(gpu.finish_readback(&mut ws, t2).is_err());
    // a ticket of another workspace with a shorter ring
    let mut other = GpuDetector::with_options(
        ctx.clone(),
        Config::default(),
        GpuDetectorOptions { ring: 1, profile: false, ..Default::default() },
    )
    .unwrap()
    .workspace(80, 60)
    .unwrap();
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    gpu.encode(&mut enc, GpuInput::Written, &mut ws).unwrap();
    let t3 = gpu.encode_readback(&mut enc, &mut ws).unwrap();
    let t4 = gpu.encode_readback(&mut enc, &mut ws).unwrap();
    let unknown = if t3 == t1 { t4 } else { t3 }; // slot 1: not in a ring of one
    assert!(gpu.start_readback(&mut other, unknown).is_err());
    assert!(gpu.try_finish_readback(&mut other, unknown).is_err());
    ctx.queue.submit([enc.finish()]);
    // the ring is usable again once both are redeemed
    for tk in [t3, t4] {
        gpu.start_readback(&mut ws, tk).unwrap();
    }
    for tk in [t4, t3] {
        assert_same("second round", &gpu.finish_readback(&mut ws, tk).unwrap(), &expected);
    }
}

#[test]
fn a_stale_ticket_does_not_redeem_another_frame() {
    // With a ring of one, every frame's ticket is the same slot: a ticket kept
    // from frame A must not hand out frame B.
    let Some(ctx) = t::context() else { return };
    let gpu = GpuDetector::with_options(
        ctx.clone(),
        Config::default(),
        GpuDetectorOptions { ring: 1, profile: false, ..Default::default() },
    )
    .unwrap();
    let mut ws = gpu.workspace(80, 60).unwrap();
    let run = |ws: &mut GpuWorkspace, img: &Plane<u8>| {
        ws.write_gray(&ctx.queue, img.view()).unwrap();
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        gpu.encode(&mut enc, GpuInput::Written, ws).unwrap();
        let tk = gpu.encode_readback(&mut enc, ws).unwrap();
        ctx.queue.submit([enc.finish()]);
        gpu.start_readback(ws, tk).unwrap();
        tk
    };
    let ta = run(&mut ws, &t::test_image(80, 60, 14));
    let a = gpu.finish_readback(&mut ws, ta).unwrap();
    let tb = run(&mut ws, &t::test_image(80, 60, 15));
    assert_ne!(ta, tb, "tickets of two frames differ, even in a ring of one slot");
    // frame A's ticket, kept and redeemed again after frame B was recorded
    let stale = gpu.finish_readback(&mut ws, ta);
    if let Ok(f) = &stale {
        let b_own = gpu.finish_readback(&mut ws, tb);
        panic!(
            "frame A's ticket, used a second time, redeemed frame B ({} keypoints; frame A had {}); \
             frame B's own ticket then gives {:?}",
            f.keypoints.len(),
            a.keypoints.len(),
            b_own.map(|f| f.keypoints.len())
        );
    }
    // frame B's own ticket gives frame B: the CPU's keypoints of that image
    let b_img = t::test_image(80, 60, 15);
    let cpu = lfast::cpu::CpuDetector::new(gpu.config().clone()).unwrap();
    assert_eq!(gpu.finish_readback(&mut ws, tb).unwrap().keypoints, cpu.detect(b_img.view(), None).unwrap());
}

#[test]
fn bad_gpu_inputs_are_typed_errors() {
    let Some(ctx) = t::context() else { return };
    let cfg = Config::default();
    let gpu = GpuDetector::new(ctx.clone(), cfg.clone()).unwrap();
    let (w, h) = (64u32, 48u32);
    let mut ws = gpu.workspace(w, h).unwrap();
    // a gray buffer too small
    let short = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size: (w * h) as u64 - 4,
        usage: wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    let e = gpu.encode(&mut enc, GpuInput::GrayBuffer(&short), &mut ws).unwrap_err();
    assert!(matches!(e, Error::InvalidImage { .. }), "short gray buffer: {e:?}");
    // textures: wrong size, unsupported format, format not the texture's, no TEXTURE_BINDING
    let tex = |tw: u32, th: u32, format: wgpu::TextureFormat, usage: wgpu::TextureUsages| {
        ctx.device
            .create_texture(&wgpu::TextureDescriptor {
                label: None,
                size: wgpu::Extent3d { width: tw, height: th, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
            .create_view(&Default::default())
    };
    use wgpu::TextureFormat as F;
    let bind = wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST;
    type Case = (&'static str, wgpu::TextureView, F, fn(&Error) -> bool);
    let cases: Vec<Case> = vec![
        ("wrong size", tex(w + 1, h, F::Rgba8Unorm, bind), F::Rgba8Unorm, |e| matches!(e, Error::InvalidImage { .. })),
        ("wrong size, smaller", tex(w, h - 1, F::R8Unorm, bind), F::R8Unorm, |e| {
            matches!(e, Error::InvalidImage { .. })
        }),
        ("Rgba16Float", tex(w, h, F::Rgba16Float, bind), F::Rgba16Float, |e| matches!(e, Error::Unsupported { .. })),
        ("Rgba8UnormSrgb", tex(w, h, F::Rgba8UnormSrgb, bind), F::Rgba8UnormSrgb, |e| {
            matches!(e, Error::Unsupported { .. })
        }),
        ("no TEXTURE_BINDING", tex(w, h, F::Rgba8Unorm, wgpu::TextureUsages::COPY_DST), F::Rgba8Unorm, |_| true),
        // the format named is not the texture's
        ("R32Float named Rgba8Unorm", tex(w, h, F::R32Float, bind), F::Rgba8Unorm, |_| true),
        ("Rgba16Float named Rgba8Unorm", tex(w, h, F::Rgba16Float, bind), F::Rgba8Unorm, |_| true),
        ("Rgba8Unorm named R8Unorm", tex(w, h, F::Rgba8Unorm, bind), F::R8Unorm, |_| true),
    ];
    let mut failures = Vec::new();
    for (what, view, format, ok) in &cases {
        let scope = ctx.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        let r = no_panic(|| gpu.encode(&mut enc, GpuInput::Texture(view, *format), &mut ws));
        drop(enc);
        let leaked = pollster::block_on(scope.pop());
        match r {
            Err(p) => failures.push(format!("{what}: PANICKED: {p}")),
            Ok(Ok(())) => failures.push(format!(
                "{what}: encode returned Ok{}",
                leaked.map(|e| format!(" (and raised a wgpu validation error: {e})")).unwrap_or_default()
            )),
            Ok(Err(e)) if !ok(&e) => failures.push(format!("{what}: unexpected error {e:?}")),
            Ok(Err(e)) => {
                if let Some(v) = leaked {
                    failures.push(format!("{what}: {e:?}, but also raised a wgpu validation error: {v}"));
                } else {
                    eprintln!("{what}: {e}");
                }
            }
        }
    }
    // after all that the workspace still works
    let img = t::test_image(w, h, 16);
    let g = gpu.detect_and_compute(&mut Some(ws), img.view(), None).unwrap();
    assert_same("after bad inputs", &g, &CpuDetector::new(cfg).unwrap().detect_and_compute(img.view(), None).unwrap());
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn an_atlas_over_four_giga_pixels_is_refused() {
    // 32 levels at scale 1.0001 of a 16384 x ~8220 frame: just over 2^32
    // pixels in the atlas, more than a u32 index reaches. The border leaves
    // few keypoint slots, so only the pixel count is over.
    let Some(ctx) = t::context() else { return };
    let cfg = Config { n_levels: 32, scale_factor: 1.0001, border: 1024, nms_radius: 32, ..Config::default() };
    let total = |w: u32, h: u32| -> u64 { cfg.level_sizes(w, h).iter().map(|&(a, b)| a as u64 * b as u64).sum() };
    let w = 16384;
    let h = (8000..16384).find(|&h| total(w, h) > u32::MAX as u64).unwrap();
    let true_total = total(w, h);
    let layout = lfast::gpu::FrameLayout::new(&cfg, w, h);
    let gpu = GpuDetector::new(ctx, cfg).unwrap();
    let r = no_panic(|| gpu.workspace(w, h).map(|_| ()));
    assert!(
        matches!(r, Ok(Err(Error::GpuLimits { .. }))),
        "a {w}x{h} frame with {true_total} atlas pixels (FrameLayout::total_px says {}): {r:?}",
        layout.total_px
    );
}

// ---------------------------------------------------------------------------
// 4. workspace reuse across shrinking and growing sizes

#[test]
fn workspace_reuse_across_shrinking_and_growing_sizes() {
    // One workspace through frames that shrink, grow and change shape: every
    // result equals the CPU's and a fresh workspace's, bit for bit.
    let Some(ctx) = t::context() else { return };
    let cfg = Config { n_levels: 5, ..Config::default() };
    let gpu = GpuDetector::new(ctx.clone(), cfg.clone()).unwrap();
    let cpu = CpuDetector::new(cfg.clone()).unwrap();
    let mut ws: Option<GpuWorkspace> = None;
    let sizes = [
        (240, 180),
        (160, 120),
        (37, 29),
        (1, 1),
        (240, 180),
        (180, 240),
        (17, 33),
        (241, 181),
        (100, 100),
        (241, 181),
    ];
    let mut reused = Vec::new();
    let mut prev: Option<wgpu::Buffer> = None;
    for (i, &(w, h)) in sizes.iter().enumerate() {
        let content = if i % 2 == 0 { Content::Structured(i as u32) } else { Content::Blocks(i as u32) };
        let img = render(&content, w, h);
        gpu.prepare_workspace(&mut ws, w, h).unwrap();
        let b = &ws.as_ref().unwrap().buffers;
        assert_eq!(b.size(), (w, h));
        reused.push(prev.as_ref().is_some_and(|p| *p == b.gray));
        prev = Some(b.gray.clone());
        let g = gpu.detect_and_compute(&mut ws, img.view(), None).unwrap();
        let c = cpu.detect_and_compute(img.view(), None).unwrap();
        assert_same(&format!("step {i}: {w}x{h}"), &g, &c);
        let e = gpu.edge_image(&mut ws, img.view()).unwrap();
        assert_eq!(e.data, cpu.edge_image(img.view()).unwrap().data, "step {i}: edges of {w}x{h}");
        // a fresh workspace gives the same bits: nothing left over from larger frames
        let f = gpu.detect_and_compute(&mut None, img.view(), None).unwrap();
        identical(&format!("step {i}: {w}x{h} reused vs fresh"), &f, &g).unwrap_or_else(|e| panic!("{e}"));
    }
    eprintln!("buffers reused at each step: {:?}", sizes.iter().zip(&reused).collect::<Vec<_>>());
}

#[test]
fn shrinking_frames_reuse_the_buffers() {
    // prepare_workspace: "reallocated only when the frame grew".
    let Some(ctx) = t::context() else { return };
    let cfg = Config { n_levels: 5, ..Config::default() };
    let gpu = GpuDetector::new(ctx, cfg.clone()).unwrap();
    let cpu = CpuDetector::new(cfg).unwrap();
    let mut failures = Vec::new();
    for (w, h) in [(200, 150), (160, 120), (64, 48), (37, 29), (17, 33), (1, 1), (180, 180), (240, 180)] {
        let mut ws: Option<GpuWorkspace> = None;
        gpu.prepare_workspace(&mut ws, 240, 180).unwrap();
        let gray = ws.as_ref().unwrap().buffers.gray.clone();
        gpu.prepare_workspace(&mut ws, w, h).unwrap();
        let b = &ws.as_ref().unwrap().buffers;
        if b.gray != gray || b.gray.size() != gray.size() {
            let l = lfast::gpu::FrameLayout::new(gpu.config(), w, h);
            failures.push(format!(
                "240x180 -> {w}x{h}: reallocated (new gray buffer of {} bytes, was {}; this frame needs {} windows, {} grid words, {} pixels)",
                b.gray.size(),
                gray.size(),
                l.total_windows,
                l.grid_data.len(),
                l.total_px
            ));
        }
        // whatever happened, the results are right
        let img = t::test_image(w, h, w + h);
        let g = gpu.detect_and_compute(&mut ws, img.view(), None).unwrap();
        assert_same(&format!("{w}x{h}"), &g, &cpu.detect_and_compute(img.view(), None).unwrap());
    }
    let first = lfast::gpu::FrameLayout::new(gpu.config(), 240, 180);
    assert!(
        failures.is_empty(),
        "240x180 was allocated for {} windows, {} grid words, {} pixels; {failures:#?}",
        first.total_windows,
        first.grid_data.len(),
        first.total_px
    );
}

#[test]
fn a_mask_does_not_outlive_its_frame_size() {
    // set_mask at one size, then prepare_workspace to another: the old mask
    // (laid out for the old size) must not apply to the new frames, whether
    // the buffers were reused (shrink) or reallocated (grow).
    let Some(ctx) = t::context() else { return };
    let cfg = Config::default();
    let gpu = GpuDetector::new(ctx.clone(), cfg.clone()).unwrap();
    let cpu = CpuDetector::new(cfg).unwrap();
    let mut failures = Vec::new();
    for (from, to) in [((256u32, 256u32), (200u32, 160u32)), ((200, 160), (256, 256))] {
        let mut ws = None;
        gpu.prepare_workspace(&mut ws, from.0, from.1).unwrap();
        let off = Plane::<u8>::new(from.0, from.1); // all off: no keypoint anywhere
        gpu.set_mask(ws.as_mut().unwrap(), Some(off.view())).unwrap();
        gpu.prepare_workspace(&mut ws, to.0, to.1).unwrap();
        let w = ws.as_mut().unwrap();
        let img = t::test_image(to.0, to.1, 17);
        w.write_gray(&ctx.queue, img.view()).unwrap();
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        gpu.encode(&mut enc, GpuInput::Written, w).unwrap();
        let tk = gpu.encode_readback(&mut enc, w).unwrap();
        ctx.queue.submit([enc.finish()]);
        gpu.start_readback(w, tk).unwrap();
        let g = gpu.finish_readback(w, tk).unwrap();
        let c = cpu.detect_and_compute(img.view(), None).unwrap();
        if let Err(e) = same(&format!("mask set at {from:?}, frame at {to:?}"), &g, &c) {
            failures.push(e);
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn one_detector_shared_by_threads() {
    // The front door's workspace is behind a lock: frames of different sizes
    // from two threads at once all equal the CPU's.
    let Some(_) = t::context() else { return };
    let det = Detector::new(Config::default(), Backend::Gpu).unwrap();
    let cpu = CpuDetector::new(Config::default()).unwrap();
    std::thread::scope(|s| {
        for k in 0..2u32 {
            let (det, cpu) = (&det, &cpu);
            s.spawn(move || {
                for i in 0..4u32 {
                    let (w, h) = if (i + k) % 2 == 0 { (120, 90) } else { (97, 131) };
                    let img = t::test_image(w, h, 40 + 10 * k + i);
                    assert_eq!(
                        det.detect_and_compute(img.view(), None).unwrap(),
                        cpu.detect_and_compute(img.view(), None).unwrap(),
                        "thread {k} frame {i}"
                    );
                }
            });
        }
    });
    assert_eq!(det.backend_name(), "gpu");
}

#[test]
fn auto_fallback_after_a_device_loss_keeps_every_frame() {
    // Backend::Auto semantics on an embedder's device: frames before the loss
    // run on the GPU, the frame that meets the loss and every later one run on
    // the CPU, all with the CPU's result; nothing is lost or reported as an error.
    let Some(_) = t::context() else { return };
    let (ctx, gpu, _, img, cpu) = doomed_device();
    let det = Detector::from_context_with_fallback(ctx.clone(), gpu.config().clone()).unwrap();
    assert_eq!(det.detect_and_compute(img.view(), None).unwrap(), cpu);
    assert_eq!(det.backend_name(), "gpu");
    ctx.device.destroy();
    assert_eq!(det.detect_and_compute(img.view(), None).unwrap(), cpu, "the frame that meets the loss");
    assert_eq!(det.backend_name(), "cpu", "after a loss, later frames go to the CPU");
    assert_eq!(det.detect_and_compute(img.view(), None).unwrap(), cpu);
    let e = CpuDetector::new(gpu.config().clone()).unwrap().edge_image(img.view()).unwrap();
    assert_eq!(det.edge_image(img.view()).unwrap(), e);
}

#[test]
fn streams_run_a_frame_over_the_limits_on_the_cpu_or_name_the_limit() {
    let Some(_) = t::context() else { return };
    // 4 MiB buffers: 400x300 fits, 800x600 does not (frames_over_small_limits_are_gpu_limits_errors)
    let ctx = context_with_limits(small_buffers(4 << 20)).unwrap();
    let cfg = Config::default();
    let cpu = CpuDetector::new(cfg.clone()).unwrap();
    let frames = [t::test_image(400, 300, 7), t::test_image(800, 600, 6), t::test_image(400, 300, 8)];
    let run = |det: &Detector| {
        let mut stream = det.stream_with::<usize>(3);
        let mut done: Vec<_> = frames.iter().cloned().enumerate().flat_map(|(i, f)| stream.push(i, f)).collect();
        done.extend(stream.finish());
        done.sort_by_key(|d| d.tag);
        done
    };
    // with the fallback (Backend::Auto's behaviour): the large frame on the CPU, the
    // others on the GPU, and the GPU still in use after it
    let auto = Detector::from_context_with_fallback(ctx.clone(), cfg.clone()).unwrap();
    for d in run(&auto) {
        let want = cpu.detect_and_compute(frames[d.tag].view(), None).unwrap();
        assert_eq!(d.result.as_ref().expect("every frame detected"), &want, "frame {}", d.tag);
    }
    assert_eq!(auto.backend_name(), "gpu", "a frame over the limits is no device failure");
    // without: the large frame is a GpuLimits error in its place, the others come back
    let gpu = Detector::from_context(ctx, cfg).unwrap();
    for d in run(&gpu) {
        match (d.tag, &d.result) {
            (1, Err(e)) => assert!(matches!(e, Error::GpuLimits { .. }), "{e}"),
            (1, Ok(_)) => panic!("800x600 does not fit 4 MiB buffers"),
            (i, r) => assert_eq!(r.as_ref().unwrap(), &cpu.detect_and_compute(frames[i].view(), None).unwrap()),
        }
    }
}
