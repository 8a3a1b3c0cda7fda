//! What the fuzz targets run on one input, shared with the regression tests.
//!
//! Each function takes the fuzzer's raw bytes, turns them into an input for
//! lfast (a file, an image and a config, a frame for both backends) and
//! panics when an invariant is broken. The fuzz targets in `fuzz_targets/`
//! are one-line wrappers; `tests/reliability.rs` includes this file with
//! `#[path]` and replays every input kept in `tests/data/regress/` through the
//! same function, so CI checks each crash found here without a fuzzer.
//! Only `lfast` and `std` are used, so the file builds in both crates.
#![allow(dead_code)]

use lfast::cpu::CpuDetector;
use lfast::{Config, DescriptorKind, Error, GrayView, KeyPoint, Mode, Plane};
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};

/// Reads the fuzzer's bytes front to back; zeros once they run out, so every
/// input (the empty one included) describes a case.
pub struct Bytes<'a> {
    data: &'a [u8],
    pos: usize,
}

impl<'a> Bytes<'a> {
    /// A reader over `data`.
    pub fn new(data: &'a [u8]) -> Self {
        Self { data, pos: 0 }
    }
    /// The next byte, 0 past the end.
    pub fn u8(&mut self) -> u8 {
        let b = self.data.get(self.pos).copied().unwrap_or(0);
        self.pos += 1;
        b
    }
    /// A little-endian u32 of the next four bytes.
    pub fn u32(&mut self) -> u32 {
        u32::from_le_bytes([self.u8(), self.u8(), self.u8(), self.u8()])
    }
    /// One of `items`, chosen by the next byte.
    pub fn pick<T: Copy>(&mut self, items: &[T]) -> T {
        items[self.u8() as usize % items.len()]
    }
    /// The bytes not read yet.
    pub fn rest(&self) -> &'a [u8] {
        self.data.get(self.pos..).unwrap_or(&[])
    }
}

/// A xorshift32 stream (never zero).
fn xorshift(seed: u32) -> impl FnMut() -> u32 {
    let mut s = seed | 1;
    move || {
        s ^= s << 13;
        s ^= s >> 17;
        s ^= s << 5;
        s
    }
}

/// A `w x h` image whose content the bytes choose: raw bytes, flat, a
/// checkerboard, stripes, noise, blocks, three gray levels or a ramp. The
/// structured kinds reach corners and degenerate histograms that raw bytes
/// rarely do.
pub fn image(r: &mut Bytes, w: u32, h: u32) -> Plane<u8> {
    let kind = r.u8() % 8;
    let (a, b) = (r.u8(), r.u8());
    let p1 = 1 + r.u8() as u32 % 16;
    let seed = r.u32();
    let n = w as usize * h as usize;
    let mut next = xorshift(seed);
    let data: Vec<u8> = match kind {
        0 | 6 => {
            let raw = r.rest();
            (0..n)
                .map(|i| {
                    let v = if raw.is_empty() { 0 } else { raw[i % raw.len()] };
                    if kind == 6 { [0, 128, 255][v as usize % 3] } else { v }
                })
                .collect()
        }
        1 => vec![a; n],
        2 => (0..n)
            .map(|i| if ((i as u32 % w.max(1)) / p1 + (i as u32 / w.max(1)) / p1).is_multiple_of(2) { a } else { b })
            .collect(),
        3 => (0..n)
            .map(|i| {
                let (x, y) = (i as u32 % w.max(1), i as u32 / w.max(1));
                let t = if seed & 1 == 0 { x } else { y };
                if (t / p1).is_multiple_of(2) { a } else { b }
            })
            .collect(),
        4 => (0..n).map(|_| next() as u8).collect(),
        5 => {
            let mut px = vec![a; n];
            for _ in 0..1 + seed % 6 {
                let (x0, y0) = (next() % w.max(1), next() % h.max(1));
                let (bw, bh) = (1 + next() % w.max(1), 1 + next() % h.max(1));
                let v = next() as u8;
                for y in y0..(y0 + bh).min(h) {
                    for x in x0..(x0 + bw).min(w) {
                        px[(y * w + x) as usize] = v;
                    }
                }
            }
            px
        }
        _ => (0..n).map(|i| ((i as u32 % w.max(1)) * p1 + (i as u32 / w.max(1)) * (b as u32 % 5)) as u8).collect(),
    };
    Plane { width: w, height: h, data }
}

/// A config whose fields the bytes choose, mostly in range, sometimes just
/// outside it (NaN, infinities, zero, negative, one past a limit), so that
/// validation is fuzzed together with the pipeline.
pub fn config(r: &mut Bytes) -> Config {
    Config {
        delta: r.pick(&[0.1, 0.0001, 0.05, 0.5, 1.0, 100.0, 0.0, -1.0, f64::NAN, f64::INFINITY, 0.00004, 100.5]),
        alpha_pct: r.u8() as u32 % 101,
        mode: if r.u8() & 1 == 0 { Mode::Branch } else { Mode::Paper },
        support: r.u8() as u32 % 9,
        straight_tol: r.u8() as u32 % 9,
        border: r.pick(&[7, 8, 9, 12, 16, 20, 31, 6, 0, 1024, 1025]),
        nms_radius: r.u8() as u32 % 34,
        n_levels: r.u8() as u32 % 34,
        scale_factor: r.pick(&[1.2, 1.01, 1.5, 2.0, 4.0, 1.1, 3.7, 1.0, 4.01, f64::NAN, -2.0, f64::INFINITY]),
        n_features: r.pick(&[0, 1, 2, 5, 50, 500]),
        distribution: r.u8() & 1 == 1,
        orientation_bins: r.pick(&[30, 0, 1, 2, 7, 360, 361]),
        descriptor: if r.u8() & 3 == 0 { DescriptorKind::Opencv } else { DescriptorKind::Lfast },
        snap_radius: r.pick(&[0, 0, 1, 2, 17]),
        reject_edges: r.u8() & 1 == 1,
        // the fill mostly off; on, sometimes with thresholds out of range
        fill_fast_ini: r.pick(&[0, 0, 0, 20, 20, 7, 1, 255, 256]),
        fill_fast_min: r.pick(&[0, 0, 7, 7, 1, 20, 21]),
    }
}

/// The level pixel of an L-FAST keypoint: pt = ((x + 0.5) s, (y + 0.5) s).
fn level_xy(k: &KeyPoint, scale_factor: f64) -> (u32, u32) {
    let s = scale_factor.powi(k.octave);
    ((k.pt.x as f64 / s).floor() as u32, (k.pt.y as f64 / s).floor() as u32)
}

/// SPEC 9-11 output invariants: fields in range, inside the border and the
/// image, strictly ordered by (-response, octave, y, x).
pub fn check_keypoints(kps: &[KeyPoint], cfg: &Config, w: u32, h: u32, what: &str) {
    for (i, k) in kps.iter().enumerate() {
        assert!((0..cfg.n_levels as i32).contains(&k.octave), "{what} {i}: octave {k:?}");
        let s = cfg.scale_factor.powi(k.octave);
        assert!((k.size as f64 - 31.0 * s).abs() < 1e-3 * s, "{what} {i}: size {k:?}");
        assert!((0.0..360.0).contains(&k.angle), "{what} {i}: angle {k:?}");
        assert!(k.response.is_finite(), "{what} {i}: response {k:?}");
        assert_eq!(k.class_id, -1, "{what} {i}");
        assert!(
            k.pt.x >= 0.0 && k.pt.y >= 0.0 && k.pt.x < w as f32 && k.pt.y < h as f32,
            "{what} {i}: outside {w}x{h}: {k:?}"
        );
        let (x, y) = level_xy(k, cfg.scale_factor);
        assert!(x >= cfg.border && y >= cfg.border, "{what} {i}: ({x},{y}) inside the border: {k:?}");
    }
    for (i, p) in kps.windows(2).enumerate() {
        let key = |k: &KeyPoint| {
            let (x, y) = level_xy(k, cfg.scale_factor);
            (-k.response, k.octave, y, x)
        };
        assert!(
            key(&p[0]).partial_cmp(&key(&p[1])) == Some(std::cmp::Ordering::Less),
            "{what}: order broken at {i}: {:?} then {:?}",
            p[0],
            p[1]
        );
    }
    if cfg.n_features > 0 {
        assert!(
            kps.len() <= cfg.n_features as usize,
            "{what}: {} keypoints over the cap {}",
            kps.len(),
            cfg.n_features
        );
    }
}

/// Target `decode_detect`: the first byte picks a file name extension, the
/// rest is the file. `load_gray` must return an image within the limits or a
/// typed error, never panic; a decoded image (up to 512x512, to keep the
/// fuzzer fast) then goes through the CPU detector.
pub fn decode_detect(data: &[u8]) {
    static N: AtomicU64 = AtomicU64::new(0);
    let mut r = Bytes::new(data);
    let ext = r.pick(&["png", "jpg", "tif", "bmp", "pgm", "ppm", "jpeg", "img"]);
    let path: PathBuf = std::env::temp_dir().join(format!(
        "lfast-fuzz-{}-{}.{ext}",
        std::process::id(),
        N.fetch_add(1, Ordering::Relaxed)
    ));
    std::fs::write(&path, r.rest()).expect("the temporary directory is writable");
    let loaded = lfast::image::load_gray(&path);
    let _ = std::fs::remove_file(&path);
    let img = match loaded {
        Ok(img) => img,
        Err(Error::Image { path: p, .. } | Error::Io { path: p, .. }) => {
            assert_eq!(p, path, "the error names the file");
            return;
        }
        Err(Error::InvalidImage { width, height, .. }) => {
            assert!(
                width == 0 || height == 0 || width.max(height) > lfast::image::MAX_SIDE,
                "{width}x{height} refused"
            );
            return;
        }
        Err(e) => panic!("unexpected error kind: {e:?}"),
    };
    assert!(img.width >= 1 && img.height >= 1 && img.width.max(img.height) <= lfast::image::MAX_SIDE);
    assert_eq!(img.data.len(), img.width as usize * img.height as usize);
    if img.width as u64 * img.height as u64 > 512 * 512 {
        return;
    }
    let cfg = Config::default();
    let det = CpuDetector::new(cfg.clone()).unwrap();
    let (kps, desc) = det.detect_and_compute(img.view(), None).unwrap();
    assert_eq!(kps.len(), desc.len());
    check_keypoints(&kps, &cfg, img.width, img.height, "decoded");
    let e = det.edge_image(img.view()).unwrap();
    assert!(e.data.iter().all(|&v| v == 0 || v == 255));
}

/// Target `cpu_pipeline`: an image of 0..=71 by 0..=71 pixels, a config, a
/// mask kind. An invalid config must be refused by every constructor with
/// `InvalidConfig`; an empty image with `InvalidImage`. Otherwise every entry
/// point runs and they agree with each other: detect == detect_and_compute,
/// compute(keypoints) == descriptors, the fused edge image == the staged
/// edge map, a second run == the first (workspace reuse), an all-on mask ==
/// no mask, an all-off mask leaves nothing, a mask of another size is
/// `MaskSize`; the baselines (FAST-9, Canny, ORB) do not panic.
pub fn cpu_pipeline(data: &[u8]) {
    let mut r = Bytes::new(data);
    let (w, h) = (r.u8() as u32 % 72, r.u8() as u32 % 72);
    let cfg = config(&mut r);
    let mask_kind = r.u8() % 6;
    let img = image(&mut r, w, h);
    let what = format!("{w}x{h} {cfg:?}");
    if let Err(e) = cfg.validate() {
        assert!(matches!(e, Error::InvalidConfig { .. }), "{what}: {e:?}");
        assert!(matches!(CpuDetector::new(cfg.clone()), Err(Error::InvalidConfig { .. })), "{what}");
        assert!(matches!(lfast::Detector::new(cfg, lfast::Backend::Cpu), Err(Error::InvalidConfig { .. })), "{what}");
        return;
    }
    let det = CpuDetector::new(cfg.clone()).unwrap();
    let view = img.view();
    if w == 0 || h == 0 {
        assert!(matches!(det.detect_and_compute(view, None), Err(Error::InvalidImage { .. })), "{what}");
        assert!(matches!(det.edge_image(view), Err(Error::InvalidImage { .. })), "{what}");
        assert!(GrayView::new(w, h, w as usize, &img.data).is_err());
        return;
    }
    let (kps, desc) = det.detect_and_compute(view, None).unwrap();
    assert_eq!(kps.len(), desc.len(), "{what}");
    check_keypoints(&kps, &cfg, w, h, &what);
    assert_eq!(det.detect(view, None).unwrap(), kps, "{what}: detect");
    assert_eq!(det.detect_and_compute(view, None).unwrap(), (kps.clone(), desc.clone()), "{what}: second run");
    assert_eq!(det.compute(view, &kps).unwrap(), desc, "{what}: compute");
    let staged = det.edges(view).unwrap();
    let fused = det.edge_image(view).unwrap();
    assert_eq!(fused, staged.edges, "{what}: fused edge image != staged edge map");
    assert!(fused.data.iter().all(|&v| v == 0 || v == 255), "{what}");
    if staged.t1().is_none() {
        // SPEC 4: a histogram with one non-empty bin (a flat image) has no edges
        assert!(fused.data.iter().all(|&v| v == 0), "{what}: edges without an Otsu threshold");
    }
    match mask_kind {
        1 => {
            let on = Plane { width: w, height: h, data: vec![255u8; img.data.len()] };
            assert_eq!(det.detect_and_compute(view, Some(on.view())).unwrap(), (kps, desc), "{what}: all-on mask");
        }
        2 => {
            let off = Plane::<u8>::new(w, h);
            assert!(det.detect(view, Some(off.view())).unwrap().is_empty(), "{what}: all-off mask");
        }
        3 => {
            let m = Plane::<u8>::new(w + 1, h);
            assert!(matches!(det.detect(view, Some(m.view())), Err(Error::MaskSize { .. })), "{what}");
        }
        4 => {
            let (x0, y0) = (w / 4, h / 4);
            let m = Plane {
                width: w,
                height: h,
                data: (0..w * h).map(|i| ((i % w) >= x0 && (i / w) >= y0) as u8).collect(),
            };
            let (mk, md) = det.detect_and_compute(view, Some(m.view())).unwrap();
            assert_eq!(mk.len(), md.len());
            check_keypoints(&mk, &cfg, w, h, &what);
        }
        _ => {}
    }
    let f = lfast::baseline::fast::fast9(&img, 1 + (w as i32 * 7 + h as i32) % 60, true);
    for k in &f {
        assert!(k.pt.x >= 3.0 && k.pt.y >= 3.0 && k.pt.x + 3.0 < w as f32 && k.pt.y + 3.0 < h as f32, "{what}: {k:?}");
    }
    let c = lfast::baseline::canny::canny(&img, &Default::default());
    assert_eq!((c.width, c.height), (w, h));
    let orb = lfast::baseline::orb::OrbDetector::new(lfast::baseline::orb::OrbParams {
        n_features: 50,
        n_levels: cfg.n_levels.min(4),
        scale_factor: cfg.scale_factor,
        ..Default::default()
    });
    if let Ok(orb) = orb {
        let (ok, od) = orb.detect_and_compute(view).unwrap();
        assert_eq!(ok.len(), od.len(), "{what}: ORB");
    }
}

/// Configs of the CPU-vs-GPU target: compiling the GPU pipelines takes a
/// while on lavapipe, so the fuzzer picks among these (one detector each,
/// built once) instead of drawing every field.
pub fn gpu_configs() -> Vec<Config> {
    let d = Config::default;
    let tight = |mode| Config { mode, border: 7, nms_radius: 1, n_levels: 3, ..d() };
    vec![
        tight(Mode::Branch),
        tight(Mode::Paper),
        Config { border: 7, nms_radius: 0, n_levels: 2, scale_factor: 1.5, ..d() },
        Config { border: 7, n_levels: 4, scale_factor: 1.2, n_features: 5, ..d() },
        Config { border: 8, nms_radius: 2, n_levels: 1, support: 1, straight_tol: 0, orientation_bins: 360, ..d() },
        Config { border: 7, n_levels: 3, scale_factor: 2.0, delta: 1.0, alpha_pct: 0, mode: Mode::Paper, ..d() },
        Config {
            border: 7,
            n_levels: 2,
            support: 8,
            straight_tol: 7,
            alpha_pct: 99,
            delta: 0.0001,
            orientation_bins: 1,
            ..d()
        },
        Config { border: 7, n_levels: 8, ..d() },
    ]
}

/// One GPU detector per entry of [`gpu_configs`], built on first use, with
/// its reusable workspace (the fuzzer's sizes change every input, so reuse
/// across sizes is exercised too).
pub struct GpuState {
    ctx: lfast::gpu::GpuContext,
    dets: Vec<Option<(lfast::gpu::detector::GpuDetector, CpuDetector, Option<lfast::gpu::detector::GpuWorkspace>)>>,
}

impl GpuState {
    /// Detectors on `ctx`.
    pub fn new(ctx: lfast::gpu::GpuContext) -> Self {
        Self { ctx, dets: (0..gpu_configs().len()).map(|_| None).collect() }
    }
}

/// Target `cpu_vs_gpu`: a frame of 1..=40 by 1..=40 pixels, a config from
/// [`gpu_configs`], a mask kind; GPU keypoints, descriptors and the level-0
/// edge map must equal the CPU's bit for bit.
pub fn cpu_vs_gpu(data: &[u8], st: &mut GpuState) {
    let mut r = Bytes::new(data);
    let (w, h) = (1 + r.u8() as u32 % 40, 1 + r.u8() as u32 % 40);
    let i = r.u8() as usize % st.dets.len();
    let mask_kind = r.u8() % 3;
    let img = image(&mut r, w, h);
    let (gpu, cpu, ws) = st.dets[i].get_or_insert_with(|| {
        let cfg = gpu_configs()[i].clone();
        (
            lfast::gpu::detector::GpuDetector::new(st.ctx.clone(), cfg.clone()).expect("GPU detector"),
            CpuDetector::new(cfg).expect("valid config"),
            None,
        )
    });
    let what = format!("{w}x{h} config {i} mask {mask_kind}");
    let mask = match mask_kind {
        1 => Some(Plane {
            width: w,
            height: h,
            data: (0..w * h).map(|j| ((j % w) >= w / 3 && (j / w) < h - h / 4) as u8 * 255).collect(),
        }),
        2 => Some(Plane { width: w, height: h, data: img.data.iter().map(|&v| (v > 40) as u8).collect() }),
        _ => None,
    };
    let mv = mask.as_ref().map(|m| m.view());
    let g = gpu.detect_and_compute(ws, img.view(), mv).unwrap_or_else(|e| panic!("{what}: GPU: {e}"));
    let c = cpu.detect_and_compute(img.view(), mv).unwrap();
    assert_eq!(g.keypoints, c.0, "{what}: keypoints");
    assert_eq!(g.descriptors, c.1, "{what}: descriptors");
    let ge = gpu.edge_image(ws, img.view()).unwrap_or_else(|e| panic!("{what}: GPU edges: {e}"));
    assert_eq!(ge, cpu.edge_image(img.view()).unwrap(), "{what}: edge map");
}
