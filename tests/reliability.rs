//! Issue 8, the library side: bad input, degenerate sizes and contents, file
//! formats, decoding limits, bad configs, determinism, and the replay of every
//! fuzzer crash input kept in `tests/data/regress/`. docs/reliability.md has
//! one row per case with the test that checks it; the command-line cases
//! (signals, --jobs, messages) are in tests/reliability_cli.rs and the GPU
//! faults in tests/gpu_robustness.rs.
//!
//! GPU comparisons run when an adapter opens (`WGPU_ADAPTER_NAME=llvmpipe`),
//! and fail instead of skipping with `REQUIRE_GPU=1`, as in CI.

mod common;

use common::plane_fn as plane;
use lfast::spec::keypoint_level_pixel;
#[path = "../fuzz/src/lib.rs"]
mod fuzz_cases;

use lfast::cpu::CpuDetector;
use lfast::gpu::detector::{GpuDetector, GpuWorkspace};
use lfast::image::load_gray;
use lfast::testing as t;
use lfast::{Backend, Config, Detector, Error, GrayView, KeyPoint, Mode, Plane};
use std::path::{Path, PathBuf};

// ---------------------------------------------------------------- helpers

/// Uniform noise, every value 0..=255 (the tests' one generator, tests/common).
fn noise(w: u32, h: u32, seed: u32) -> Plane<u8> {
    common::noise(w, h, seed.into())
}

fn checker(w: u32, h: u32, cell: u32) -> Plane<u8> {
    plane(w, h, |x, y| if (x / cell + y / cell).is_multiple_of(2) { 0 } else { 255 })
}

fn cpu(cfg: &Config) -> CpuDetector {
    CpuDetector::new(cfg.clone()).unwrap()
}

/// The smallest border and NMS window, few levels: corners possible from 15x15 on.
fn tight() -> Config {
    Config { border: 7, nms_radius: 1, n_levels: 3, ..Config::default() }
}

type Features = (Vec<KeyPoint>, Vec<[u8; 32]>);

/// A GPU detector per config and its reused workspace, when an adapter opens.
struct Gpu {
    det: GpuDetector,
    ws: Option<GpuWorkspace>,
}

impl Gpu {
    fn new(cfg: &Config) -> Option<Self> {
        let ctx = t::context()?;
        Some(Self { det: GpuDetector::new(ctx, cfg.clone()).unwrap(), ws: None })
    }

    /// Asserts the GPU's keypoints, descriptors and edge map equal `cpu`'s.
    fn assert_equals_cpu(&mut self, cpu: &CpuDetector, img: &Plane<u8>, mask: Option<GrayView<'_>>, what: &str) {
        let g =
            self.det.detect_and_compute(&mut self.ws, img.view(), mask).unwrap_or_else(|e| panic!("{what}: GPU: {e}"));
        let c = cpu.detect_and_compute(img.view(), mask).unwrap();
        assert_eq!(g.keypoints, c.0, "{what}: keypoints GPU vs CPU");
        assert_eq!(g.descriptors, c.1, "{what}: descriptors GPU vs CPU");
        let ge = self.det.edge_image(&mut self.ws, img.view()).unwrap_or_else(|e| panic!("{what}: GPU edges: {e}"));
        assert_eq!(ge, cpu.edge_image(img.view()).unwrap(), "{what}: edge map GPU vs CPU");
    }
}

/// Whether some level of a `w x h` image has a pixel `border` from every side.
fn has_interior_level(cfg: &Config, w: u32, h: u32) -> bool {
    cfg.level_sizes(w, h).iter().any(|&(lw, lh)| lw > 2 * cfg.border && lh > 2 * cfg.border)
}

fn is_invalid_image(r: lfast::Result<impl std::fmt::Debug>) -> bool {
    matches!(r, Err(Error::InvalidImage { .. }))
}

// ------------------------------------------------------------------ sizes

#[test]
fn empty_images_are_invalid_image_errors_on_every_entry_point() {
    let cfg = Config::default();
    let c = cpu(&cfg);
    let auto = Detector::new(cfg.clone(), Backend::Auto).unwrap();
    let on_cpu = Detector::new(cfg.clone(), Backend::Cpu).unwrap();
    let mut gpu = Gpu::new(&cfg);
    for (w, h) in [(0, 0), (0, 7), (7, 0)] {
        let e = GrayView::new(w, h, w as usize, &[]).unwrap_err();
        assert!(matches!(e, Error::InvalidImage { .. }), "{w}x{h}: {e:?}");
        assert!(e.to_string().contains("empty") && e.to_string().contains(&format!("{w}x{h}")), "{e}");
        let p = Plane::<u8>::new(w, h);
        let v = p.view();
        assert!(is_invalid_image(c.detect_and_compute(v, None)), "{w}x{h}");
        assert!(is_invalid_image(c.detect(v, None)), "{w}x{h}");
        assert!(is_invalid_image(c.edge_image(v)), "{w}x{h}");
        assert!(is_invalid_image(c.edge_image_into(v, &mut Plane::default())), "{w}x{h}");
        assert!(is_invalid_image(c.edges(v)), "{w}x{h}");
        assert!(is_invalid_image(c.compute(v, &[])), "{w}x{h}");
        for d in [&auto, &on_cpu] {
            assert!(is_invalid_image(d.detect_and_compute(v, None)), "{w}x{h} {}", d.backend_name());
            assert!(is_invalid_image(d.edge_image(v)), "{w}x{h}");
        }
        if let Some(g) = gpu.as_mut() {
            assert!(is_invalid_image(g.det.workspace(w, h).map(|_| ())), "{w}x{h} workspace");
            assert!(is_invalid_image(g.det.detect_and_compute(&mut g.ws, v, None).map(|_| ())), "{w}x{h}");
            assert!(is_invalid_image(g.det.edge_image(&mut g.ws, v)), "{w}x{h}");
        }
    }
}

#[test]
fn every_size_from_1x1_to_15x15_gives_an_empty_result() {
    // Default border 16: no pixel of any level is 16 from every side of a
    // 15x15 image. With border 7 only a 15-pixel side has one interior pixel.
    let configs = [Config::default(), Config { border: 7, nms_radius: 1, n_levels: 8, ..Config::default() }];
    let mut found = 0;
    for cfg in &configs {
        let c = cpu(cfg);
        let mut gpu = Gpu::new(cfg);
        for w in 1..=15 {
            for h in 1..=15 {
                let sizes = cfg.level_sizes(w, h);
                assert_eq!(sizes.len(), cfg.n_levels as usize);
                assert!(sizes.iter().all(|&(lw, lh)| lw >= 1 && lh >= 1 && lw <= w && lh <= h), "{w}x{h}: {sizes:?}");
                for (name, img) in [("noise", noise(w, h, w * 31 + h)), ("checker", checker(w, h, 3))] {
                    let what = format!("{w}x{h} {name} border {}", cfg.border);
                    let (kps, desc) = c.detect_and_compute(img.view(), None).unwrap();
                    assert_eq!(kps.len(), desc.len(), "{what}");
                    if !has_interior_level(cfg, w, h) {
                        assert!(kps.is_empty(), "{what}: {kps:?}");
                    }
                    fuzz_cases::check_keypoints(&kps, cfg, w, h, &what);
                    found += kps.len();
                    let e = c.edge_image(img.view()).unwrap();
                    assert_eq!((e.width, e.height), (w, h), "{what}");
                    assert!(e.data.iter().all(|&v| v == 0 || v == 255), "{what}");
                    assert_eq!(e, c.edges(img.view()).unwrap().edges, "{what}: fused vs staged");
                    if let Some(g) = gpu.as_mut()
                        && (w == h || w == 1 || h == 1 || (w + h) % 4 == 0)
                    {
                        g.assert_equals_cpu(&c, &img, None, &what);
                    }
                }
            }
        }
    }
    // only the 15-pixel sides with border 7 may have one, at level 0's centre
    assert!(found <= 4, "{found} keypoints on images up to 15x15");
}

#[test]
fn strips_one_or_two_pixels_thick_give_empty_results() {
    let cfg = Config::default();
    let c = cpu(&cfg);
    let mut gpu = Gpu::new(&cfg);
    for n in [1u32, 2, 3, 15, 16, 17, 33, 64, 1000, 16384] {
        for (w, h) in [(1, n), (n, 1), (2, n), (n, 2)] {
            let img = noise(w, h, n);
            let what = format!("{w}x{h}");
            let (kps, desc) = c.detect_and_compute(img.view(), None).unwrap();
            assert!(kps.is_empty() && desc.is_empty(), "{what}");
            let e = c.edge_image(img.view()).unwrap();
            assert_eq!((e.width, e.height), (w, h), "{what}");
            assert_eq!(e, c.edges(img.view()).unwrap().edges, "{what}: fused vs staged");
            if let Some(g) = gpu.as_mut()
                && n <= 1000
            {
                g.assert_equals_cpu(&c, &img, None, &what);
            }
        }
    }
    // a strip over the side limit is refused, not processed
    let long = vec![0u8; lfast::image::MAX_SIDE as usize + 1];
    assert!(is_invalid_image(GrayView::new(lfast::image::MAX_SIDE + 1, 1, long.len(), &long)));
}

#[test]
fn pyramid_levels_that_shrink_below_the_border_are_skipped() {
    // 20 levels of 1.2 on 200x150: level 8 (47x35) is the last with a pixel
    // 16 from every side; levels down to 6x5 exist and must not break anything.
    let cfg = Config { n_levels: 20, ..Config::default() };
    let img = t::test_image(200, 150, 7);
    let sizes = cfg.level_sizes(200, 150);
    assert_eq!(sizes[5], (80, 60));
    assert_eq!(sizes[19], (6, 5));
    let last_interior = sizes.iter().rposition(|&(w, h)| w > 32 && h > 32).unwrap();
    assert_eq!((last_interior, sizes[8], sizes[9]), (8, (47, 35), (39, 29)), "{sizes:?}");
    let c = cpu(&cfg);
    let (kps, _) = c.detect_and_compute(img.view(), None).unwrap();
    assert!(!kps.is_empty());
    fuzz_cases::check_keypoints(&kps, &cfg, 200, 150, "200x150, 20 levels");
    for k in &kps {
        let (lw, lh) = sizes[k.octave as usize];
        let (x, y) = keypoint_level_pixel(&cfg, k);
        assert!(k.octave as usize <= last_interior, "{k:?}");
        assert!(x >= cfg.border && y >= cfg.border && x < lw - cfg.border && y < lh - cfg.border, "{k:?} on {lw}x{lh}");
    }
    // the levels that exist give the same keypoints as the shallower pyramid
    let shallow = Config { n_levels: 9, ..Config::default() };
    assert_eq!(cpu(&shallow).detect_and_compute(img.view(), None).unwrap().0, kps);
    if let Some(mut g) = Gpu::new(&cfg) {
        g.assert_equals_cpu(&c, &img, None, "200x150, 20 levels");
    }
}

// ---------------------------------------------------------------- content

#[test]
fn flat_images_have_no_otsu_threshold_no_edges_and_no_keypoints() {
    let cfg = Config::default();
    let c = cpu(&cfg);
    let mut gpu = Gpu::new(&cfg);
    for v in [0u8, 255, 1, 128, 254] {
        let img = plane(96, 64, |_, _| v);
        let em = c.edges(img.view()).unwrap();
        assert_eq!(em.t1(), None, "gray {v}: one histogram bin, Otsu is degenerate");
        assert!(em.magnitude().data.iter().all(|&m| m == 0), "gray {v}");
        assert!(em.edges.data.iter().all(|&e| e == 0), "gray {v}");
        assert!(c.edge_image(img.view()).unwrap().data.iter().all(|&e| e == 0));
        assert!(c.detect(img.view(), None).unwrap().is_empty(), "gray {v}");
        if let Some(g) = gpu.as_mut() {
            g.assert_equals_cpu(&c, &img, None, &format!("flat {v}"));
        }
    }
}

#[test]
fn pure_noise_runs_and_is_reproducible() {
    let cfg = Config::default();
    let c = cpu(&cfg);
    let img = noise(160, 120, 99);
    let em = c.edges(img.view()).unwrap();
    assert!(em.t1().is_some());
    let n_edges = em.edges.data.iter().filter(|&&e| e != 0).count();
    assert!(n_edges > 0 && n_edges < 160 * 120, "{n_edges}");
    let first = c.detect_and_compute(img.view(), None).unwrap();
    fuzz_cases::check_keypoints(&first.0, &cfg, 160, 120, "noise");
    assert_eq!(c.detect_and_compute(img.view(), None).unwrap(), first);
    assert_eq!(cpu(&cfg).detect_and_compute(img.view(), None).unwrap(), first);
    if let Some(mut g) = Gpu::new(&cfg) {
        g.assert_equals_cpu(&c, &img, None, "noise");
    }
}

#[test]
fn checkerboard_edges_lie_on_the_cell_boundaries_and_corners_on_the_junctions() {
    let cell = 16;
    let img = checker(128, 128, cell);
    // SPEC 8 as written: the paper's support 4, corners on their edge pixels (no snap)
    let one_level = |mode| Config { mode, n_levels: 1, ..Config::paper() };
    let c = cpu(&one_level(Mode::Paper));
    let e = c.edge_image(img.view()).unwrap();
    // the gradient of pixel x lies between x and x+1: a step at 16k sits at x = 16k - 1
    let on_boundary = |v: u32| (v + 1).is_multiple_of(cell);
    let mut n = 0;
    for y in 0..128 {
        for x in 0..128 {
            if e.at(x, y) != 0 {
                n += 1;
                assert!(on_boundary(x) || on_boundary(y), "edge pixel ({x},{y}) off the cell boundaries");
            }
        }
    }
    // every inner boundary is found: 7 vertical and 7 horizontal lines
    assert!(n >= 2 * 7 * 120, "{n} edge pixels");
    // Paper mode: corners at the junctions (16i, 16j), within the radius 3
    // of the L-FAST circle (every edge pixel on it counts in this mode)
    let kps = c.detect(img.view(), None).unwrap();
    assert!(kps.len() >= 25, "{} corners on 49 inner junctions", kps.len());
    for k in &kps {
        let d = |v: f32| (v - (v / cell as f32).round() * cell as f32).abs();
        assert!(d(k.pt.x) <= 3.0 && d(k.pt.y) <= 3.0, "corner away from a junction: {k:?}");
    }
    // Branch mode: an X junction is two straight lines crossing, no corner (SPEC 8)
    assert!(cpu(&one_level(Mode::Branch)).detect(img.view(), None).unwrap().is_empty());
    // a single bright rectangle on black: exactly its 4 corners, in both modes
    let rect = plane(128, 96, |x, y| if (40..90).contains(&x) && (30..70).contains(&y) { 255 } else { 0 });
    for mode in [Mode::Branch, Mode::Paper] {
        let mut pts: Vec<(f32, f32)> =
            cpu(&one_level(mode)).detect(rect.view(), None).unwrap().iter().map(|k| (k.pt.x, k.pt.y)).collect();
        pts.sort_by(|a, b| a.partial_cmp(b).unwrap());
        assert_eq!(pts, vec![(39.5, 29.5), (39.5, 69.5), (89.5, 29.5), (89.5, 69.5)], "{mode:?}");
    }
    for cfg in [one_level(Mode::Paper), Config::default()] {
        if let Some(mut g) = Gpu::new(&cfg) {
            g.assert_equals_cpu(&cpu(&cfg), &img, None, "checkerboard");
            g.assert_equals_cpu(&cpu(&cfg), &rect, None, "rectangle");
        }
    }
}

#[test]
fn maximum_contrast_stripes_are_straight_edges_without_corners() {
    for vertical in [true, false] {
        let period = 8;
        let img = plane(128, 96, |x, y| if ((if vertical { x } else { y }) / (period / 2)) % 2 == 0 { 0 } else { 255 });
        for mode in [Mode::Branch, Mode::Paper] {
            let cfg = Config { mode, n_levels: 1, ..Config::default() };
            let c = cpu(&cfg);
            let e = c.edge_image(img.view()).unwrap();
            for y in 0..96 {
                for x in 0..128 {
                    let (t, len) = if vertical { (x, 128) } else { (y, 96) };
                    let step = (t + 1) % (period / 2) == 0 && t + 1 < len;
                    assert_eq!(e.at(x, y) != 0, step, "({x},{y}) vertical {vertical}");
                }
            }
            let kps = c.detect(img.view(), None).unwrap();
            assert!(kps.is_empty(), "{mode:?}: straight lines are no corners: {:?}", &kps[..kps.len().min(3)]);
        }
        // On the full pyramid, levels 4 and 5 alias the 4-pixel stripes into
        // blobs that do have corners; the GPU must agree there too.
        let cfg = Config::default();
        if let Some(mut g) = Gpu::new(&cfg) {
            g.assert_equals_cpu(&cpu(&cfg), &img, None, &format!("stripes vertical {vertical}"));
        }
    }
}

// ---------------------------------------------------------------- formats

/// CRC-32 (PNG chunks).
fn crc32(bytes: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in bytes {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 { 0xEDB8_8320 ^ (c >> 1) } else { c >> 1 };
        }
    }
    !c
}

/// A zlib stream of stored (uncompressed) deflate blocks.
fn zlib_stored(raw: &[u8]) -> Vec<u8> {
    let mut z = vec![0x78, 0x01];
    let blocks: Vec<&[u8]> = if raw.is_empty() { vec![&[]] } else { raw.chunks(65535).collect() };
    for (i, b) in blocks.iter().enumerate() {
        z.push((i + 1 == blocks.len()) as u8);
        z.extend((b.len() as u16).to_le_bytes());
        z.extend((!(b.len() as u16)).to_le_bytes());
        z.extend(*b);
    }
    let (mut a, mut b) = (1u32, 0u32);
    for &v in raw {
        a = (a + v as u32) % 65521;
        b = (b + a) % 65521;
    }
    z.extend(((b << 16) | a).to_be_bytes());
    z
}

/// A PNG from its parts: IHDR fields, extra chunks before IDAT, raw scanlines.
fn png(w: u32, h: u32, depth: u8, colour: u8, chunks: &[(&[u8; 4], Vec<u8>)], scanlines: &[u8]) -> Vec<u8> {
    fn chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
        out.extend((data.len() as u32).to_be_bytes());
        let start = out.len();
        out.extend(kind);
        out.extend(data);
        let crc = crc32(&out[start..]);
        out.extend(crc.to_be_bytes());
    }
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut ihdr = w.to_be_bytes().to_vec();
    ihdr.extend(h.to_be_bytes());
    ihdr.extend([depth, colour, 0, 0, 0]);
    chunk(&mut out, b"IHDR", &ihdr);
    for (k, d) in chunks {
        chunk(&mut out, k, d);
    }
    chunk(&mut out, b"IDAT", &zlib_stored(scanlines));
    chunk(&mut out, b"IEND", &[]);
    out
}

fn luma(r: u8, g: u8, b: u8) -> u8 {
    ((19596 * r as u32 + 38470 * g as u32 + 7470 * b as u32 + 32768) >> 16) as u8
}

/// RGB colours of a test image: every pixel a different mix.
fn rgb_at(x: u32, y: u32) -> [u8; 3] {
    [(x * 37 + y * 11) as u8, (x * 5 + y * 53) as u8, (255 - x * 17 - y * 3) as u8]
}

#[test]
fn every_colour_type_decodes_to_the_spec0_gray() {
    use image::{ImageBuffer, Luma, LumaA, Rgb, Rgba};
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (23u32, 17u32);
    let want_rgb: Vec<u8> = (0..w * h)
        .map(|i| {
            let [r, g, b] = rgb_at(i % w, i / w);
            luma(r, g, b)
        })
        .collect();
    let check = |name: &str, want: &[u8]| {
        let g = load_gray(dir.path().join(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!((g.width, g.height), (w, h), "{name}");
        assert_eq!(g.data, want, "{name}");
        // and the detector takes it
        assert!(cpu(&tight()).detect_and_compute(g.view(), None).is_ok());
    };

    // 16-bit gray: v >> 8, the low byte must not matter
    let g16 = ImageBuffer::from_fn(w, h, |x, y| Luma([((x * 11 + y * 7) as u16) << 8 | (x * 3) as u16 & 0xff]));
    g16.save(dir.path().join("gray16.png")).unwrap();
    check("gray16.png", &(0..w * h).map(|i| ((i % w) * 11 + (i / w) * 7) as u8).collect::<Vec<_>>());
    // RGB, RGBA (alpha ignored), gray + alpha (gray kept)
    ImageBuffer::from_fn(w, h, |x, y| Rgb(rgb_at(x, y))).save(dir.path().join("rgb.png")).unwrap();
    check("rgb.png", &want_rgb);
    ImageBuffer::from_fn(w, h, |x, y| {
        let [r, g, b] = rgb_at(x, y);
        Rgba([r, g, b, (x * 13) as u8])
    })
    .save(dir.path().join("rgba.png"))
    .unwrap();
    check("rgba.png", &want_rgb);
    ImageBuffer::from_fn(w, h, |x, y| LumaA([(x * 9 + y) as u8, 255 - (y * 5) as u8]))
        .save(dir.path().join("la.png"))
        .unwrap();
    check("la.png", &(0..w * h).map(|i| ((i % w) * 9 + i / w) as u8).collect::<Vec<_>>());
    // 16-bit RGBA: v >> 8 per channel, then the luma
    ImageBuffer::from_fn(w, h, |x, y| {
        let [r, g, b] = rgb_at(x, y);
        Rgba([(r as u16) << 8 | 0xff, (g as u16) << 8 | 0x80, (b as u16) << 8, 0x1234])
    })
    .save(dir.path().join("rgba16.png"))
    .unwrap();
    check("rgba16.png", &want_rgb);

    // palette PNG (8-bit indices into a 7-colour PLTE), with and without tRNS
    let pal: Vec<[u8; 3]> =
        vec![[0, 0, 0], [255, 255, 255], [255, 0, 0], [0, 255, 0], [0, 0, 255], [12, 200, 77], [250, 128, 7]];
    let index = |x: u32, y: u32| ((x + 2 * y) % pal.len() as u32) as u8;
    let mut lines = Vec::new();
    for y in 0..h {
        lines.push(0); // filter: none
        lines.extend((0..w).map(|x| index(x, y)));
    }
    let plte: Vec<u8> = pal.iter().flatten().copied().collect();
    let want_pal: Vec<u8> = (0..w * h)
        .map(|i| {
            let [r, g, b] = pal[index(i % w, i / w) as usize];
            luma(r, g, b)
        })
        .collect();
    std::fs::write(dir.path().join("palette.png"), png(w, h, 8, 3, &[(b"PLTE", plte.clone())], &lines)).unwrap();
    check("palette.png", &want_pal);
    std::fs::write(
        dir.path().join("palette_trns.png"),
        png(w, h, 8, 3, &[(b"PLTE", plte), (b"tRNS", vec![0, 128, 255])], &lines),
    )
    .unwrap();
    check("palette_trns.png", &want_pal);

    // JPEG is lossy: the gray is SPEC 0 of what the decoder returns
    for (name, img) in [
        ("rgb.jpg", image::DynamicImage::ImageRgb8(ImageBuffer::from_fn(w, h, |x, y| Rgb(rgb_at(x, y))))),
        (
            "gray.jpeg",
            image::DynamicImage::ImageLuma8(ImageBuffer::from_fn(w, h, |x, y| Luma([(x * 9 + y * 4) as u8]))),
        ),
    ] {
        let p = dir.path().join(name);
        img.save(&p).unwrap();
        let decoded = image::open(&p).unwrap();
        let want: Vec<u8> = match &decoded {
            image::DynamicImage::ImageLuma8(b) => b.as_raw().clone(),
            other => other.to_rgb8().pixels().map(|p| luma(p.0[0], p.0[1], p.0[2])).collect(),
        };
        check(name, &want);
    }
}

/// Asserts `load_gray(p)` is an `Io` or `Image` error naming the file, not a panic.
fn assert_load_fails(p: &Path, what: &str) -> Error {
    let r = std::panic::catch_unwind(|| load_gray(p));
    let e = match r {
        Ok(Err(e)) => e,
        Ok(Ok(img)) => panic!("{what}: decoded to {}x{}", img.width, img.height),
        Err(_) => panic!("{what}: load_gray panicked"),
    };
    match &e {
        Error::Io { path, .. } | Error::Image { path, .. } => assert_eq!(path, p, "{what}"),
        other => panic!("{what}: {other:?}"),
    }
    let name = p.file_name().unwrap().to_string_lossy().into_owned();
    assert!(e.to_string().contains(&name), "{what}: the message names the file: {e}");
    e
}

#[test]
fn broken_and_non_image_files_are_typed_errors_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // truncated PNG: after the signature, inside IHDR, inside IDAT, before IEND
    let good_png = std::fs::read(common::data("coins.png")).unwrap();
    for n in [0, 4, 8, 20, 33, 60, good_png.len() / 2, good_png.len() - 13] {
        let p = d.join(format!("cut_{n}.png"));
        std::fs::write(&p, &good_png[..n]).unwrap();
        assert_load_fails(&p, &format!("PNG cut at {n}"));
    }
    // truncated JPEG: header only, and half of the entropy-coded data
    let jpg = d.join("whole.jpg");
    image::GrayImage::from_raw(64, 48, noise(64, 48, 3).data).unwrap().save(&jpg).unwrap();
    let good_jpg = std::fs::read(&jpg).unwrap();
    for n in [2, 20, 200] {
        let p = d.join(format!("cut_{n}.jpg"));
        std::fs::write(&p, &good_jpg[..n]).unwrap();
        assert_load_fails(&p, &format!("JPEG cut at {n}"));
    }
    // empty file, text named .png, a directory named like an image, a missing path
    std::fs::write(d.join("empty.png"), b"").unwrap();
    assert_load_fails(&d.join("empty.png"), "empty file");
    std::fs::write(d.join("notes.png"), "plain text\n".repeat(20)).unwrap();
    assert_load_fails(&d.join("notes.png"), "text named .png");
    std::fs::create_dir(d.join("frame.png")).unwrap();
    assert_load_fails(&d.join("frame.png"), "directory named .png");
    let e = assert_load_fails(&d.join("missing.png"), "missing path");
    assert!(matches!(&e, Error::Io { source, .. } if source.kind() == std::io::ErrorKind::NotFound), "{e:?}");
}

/// Whether this process can read a file whose mode is 000 (root, or
/// CAP_DAC_OVERRIDE): CI runs as root, where chmod does not deny reads.
#[cfg(unix)]
fn chmod_000_denies(p: &Path) -> bool {
    std::fs::File::open(p).is_err()
}

#[cfg(unix)]
#[test]
fn unreadable_files_are_io_errors() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("locked.png");
    std::fs::copy(common::data("coins.png"), &p).unwrap();
    std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o000)).unwrap();
    if chmod_000_denies(&p) {
        let e = assert_load_fails(&p, "mode 000");
        assert!(
            matches!(&e, Error::Io { source, .. } if source.kind() == std::io::ErrorKind::PermissionDenied),
            "{e:?}"
        );
    } else {
        eprintln!("note: running privileged (root): mode 000 does not deny reads here; checked with /proc/self/mem");
        assert_eq!(load_gray(&p).unwrap(), load_gray(common::data("coins.png")).unwrap());
    }
    // A file that opens but cannot be read, even by root: /proc/self/mem at
    // offset 0 (unmapped) fails every read with EIO.
    #[cfg(target_os = "linux")]
    {
        let mem = dir.path().join("mem.png");
        std::os::unix::fs::symlink("/proc/self/mem", &mem).unwrap();
        let e = assert_load_fails(&mem, "unreadable (EIO)");
        assert!(matches!(e, Error::Io { .. }), "{e:?}");
    }
}

// ----------------------------------------------------------------- limits

/// A PNG that declares `w x h` (8-bit gray) and holds a few bytes of data.
pub fn png_header_only(w: u32, h: u32, depth: u8, colour: u8) -> Vec<u8> {
    png(w, h, depth, colour, &[], &[0, 1, 2, 3])
}

#[test]
fn huge_declared_sizes_are_refused_by_the_decoding_limits() {
    let dir = tempfile::tempdir().unwrap();
    for (name, w, h, depth, colour, limit) in [
        // 4.3 G pixels: over the side limit
        ("huge.png", 65535, 65535, 8, 0, "dimension"),
        ("wide.png", 16385, 1, 8, 0, "dimension"),
        // 16384 x 16384 16-bit RGBA = 2 GiB: sides allowed, allocation over 1 GiB
        ("deep.png", 16384, 16384, 16, 6, "memory"),
    ] {
        let p = dir.path().join(name);
        std::fs::write(&p, png_header_only(w, h, depth, colour)).unwrap();
        assert!(std::fs::metadata(&p).unwrap().len() < 100);
        let e = assert_load_fails(&p, name);
        let Error::Image { source: image::ImageError::Limits(l), .. } = &e else {
            panic!("{name}: not a limit error: {e:?}")
        };
        let kind = format!("{:?}", l.kind()).to_lowercase();
        assert!(kind.contains(limit), "{name}: {kind}");
    }
    // the peak memory of refusing them is measured in tests/reliability_cli.rs
}

// ----------------------------------------------------------------- config

#[test]
fn nan_infinite_negative_and_zero_values_are_invalid_config_naming_the_field() {
    let d = Config::default;
    let cases: Vec<(&str, Config)> = vec![
        ("delta", Config { delta: f64::NAN, ..d() }),
        ("delta", Config { delta: f64::INFINITY, ..d() }),
        ("delta", Config { delta: f64::NEG_INFINITY, ..d() }),
        ("delta", Config { delta: -0.1, ..d() }),
        ("delta", Config { delta: 0.0, ..d() }),
        ("delta", Config { delta: -0.0, ..d() }),
        ("delta", Config { delta: 0.00004, ..d() }), // rounds to a zero numerator
        ("scale_factor", Config { scale_factor: f64::NAN, ..d() }),
        ("scale_factor", Config { scale_factor: f64::INFINITY, ..d() }),
        ("scale_factor", Config { scale_factor: f64::NEG_INFINITY, ..d() }),
        ("scale_factor", Config { scale_factor: -1.2, ..d() }),
        ("scale_factor", Config { scale_factor: 0.0, ..d() }),
        ("scale_factor", Config { scale_factor: 1.0, ..d() }),
        ("n_levels", Config { n_levels: 0, ..d() }),
        ("n_levels", Config { n_levels: 33, ..d() }),
        ("support", Config { support: 0, ..d() }),
        ("border", Config { border: 0, ..d() }),
        ("alpha_pct", Config { alpha_pct: 100, ..d() }),
        ("orientation_bins", Config { orientation_bins: 361, ..d() }),
    ];
    let ctx = t::context();
    for (field, cfg) in &cases {
        let check = |r: lfast::Result<()>, who: &str| match r {
            Err(Error::InvalidConfig { field: f, reason }) => {
                assert_eq!(f, *field, "{who}: {cfg:?}: {reason}");
            }
            other => panic!("{who}: {field} in {cfg:?}: {other:?}"),
        };
        check(cfg.validate(), "validate");
        check(CpuDetector::new(cfg.clone()).map(|_| ()), "CpuDetector");
        for b in [Backend::Cpu, Backend::Auto, Backend::Gpu] {
            if b == Backend::Gpu && ctx.is_none() {
                continue;
            }
            check(Detector::new(cfg.clone(), b).map(|_| ()), &format!("Detector {b:?}"));
        }
        if let Some(ctx) = &ctx {
            check(GpuDetector::new(ctx.clone(), cfg.clone()).map(|_| ()), "GpuDetector");
        }
        let msg = cfg.validate().unwrap_err().to_string();
        assert!(msg.contains(field), "{msg}");
    }
    // TOML spells them too
    for (text, field) in [
        ("delta = nan", "delta"),
        ("delta = -inf", "delta"),
        ("scale_factor = inf", "scale_factor"),
        ("scale_factor = -1.5", "scale_factor"),
        ("n_levels = 0", "n_levels"),
    ] {
        match Config::from_toml_str(text) {
            Err(Error::InvalidConfig { field: f, .. }) => assert_eq!(f, field, "{text}"),
            other => panic!("{text}: {other:?}"),
        }
    }
    // negative integers do not parse into unsigned fields
    assert!(matches!(Config::from_toml_str("n_levels = -1"), Err(Error::ConfigParse { .. })));
}

#[test]
fn n_levels_deeper_than_the_image_is_fine() {
    // 32 levels of 4.0 on 120x90: from level 4 on every level is 1x1
    let cfg = Config { n_levels: 32, scale_factor: 4.0, border: 7, nms_radius: 1, ..Config::default() };
    let sizes = cfg.level_sizes(120, 90);
    assert_eq!(&sizes[..4], &[(120, 90), (30, 23), (8, 6), (2, 1)]);
    assert!(sizes[4..].iter().all(|&s| s == (1, 1)), "{sizes:?}");
    let img = t::test_image(120, 90, 3);
    let c = cpu(&cfg);
    let (kps, desc) = c.detect_and_compute(img.view(), None).unwrap();
    assert!(!kps.is_empty());
    assert!(kps.iter().all(|k| k.octave <= 1), "only levels 0 and 1 have interior pixels");
    assert_eq!(c.compute(img.view(), &kps).unwrap(), desc);
    // the same keypoints as the two levels that matter
    assert_eq!(cpu(&Config { n_levels: 2, ..cfg.clone() }).detect_and_compute(img.view(), None).unwrap(), (kps, desc));
    if let Some(mut g) = Gpu::new(&cfg) {
        g.assert_equals_cpu(&c, &img, None, "32 levels of 4.0");
    }
}

#[test]
fn masks_of_the_wrong_size_are_mask_size_errors_on_every_backend() {
    let cfg = Config::default();
    let img = t::test_image(64, 48, 1);
    let c = cpu(&cfg);
    let auto = Detector::new(cfg.clone(), Backend::Auto).unwrap();
    let mut gpu = Gpu::new(&cfg);
    for (mw, mh) in [(63, 48), (65, 48), (64, 47), (64, 49), (48, 64), (1, 1)] {
        let m = Plane { width: mw, height: mh, data: vec![255u8; (mw * mh) as usize] };
        let is_mask_size = |r: lfast::Result<()>| matches!(r, Err(Error::MaskSize { mask_width, mask_height, width: 64, height: 48 }) if (mask_width, mask_height) == (mw, mh));
        assert!(is_mask_size(c.detect(img.view(), Some(m.view())).map(|_| ())), "{mw}x{mh}");
        assert!(is_mask_size(c.detect_and_compute(img.view(), Some(m.view())).map(|_| ())), "{mw}x{mh}");
        // Auto must not hide a caller's error by falling back to the CPU
        assert!(is_mask_size(auto.detect_and_compute(img.view(), Some(m.view())).map(|_| ())), "{mw}x{mh} auto");
        if let Some(g) = gpu.as_mut() {
            assert!(
                is_mask_size(g.det.detect_and_compute(&mut g.ws, img.view(), Some(m.view())).map(|_| ())),
                "{mw}x{mh} GPU"
            );
        }
        let e = c.detect(img.view(), Some(m.view())).unwrap_err().to_string();
        assert!(e.contains(&format!("{mw}x{mh}")) && e.contains("64x48"), "{e}");
    }
    // an inconsistent mask buffer is an image error, not a panic
    let short = Plane { width: 64, height: 48, data: vec![1u8; 100] };
    assert!(is_invalid_image(c.detect(img.view(), Some(short.view()))));
    // the right size works on every backend and agrees
    let m = plane(64, 48, |x, _| (x > 20) as u8);
    let want = c.detect_and_compute(img.view(), Some(m.view())).unwrap();
    assert_eq!(auto.detect_and_compute(img.view(), Some(m.view())).unwrap(), want);
    if let Some(g) = gpu.as_mut() {
        g.assert_equals_cpu(&c, &img, Some(m.view()), "mask");
    }
}

// ------------------------------------------------------------ determinism

#[test]
fn same_input_same_output_across_runs_thread_counts_and_backends() {
    let img = load_gray(common::data("camera_cc0_v0.18plus.png")).unwrap();
    let small = t::test_image(200, 150, 42);
    for cfg in [Config::default(), Config { mode: Mode::Paper, n_features: 300, ..Config::default() }] {
        let run = |threads: usize, img: &Plane<u8>| -> (Features, Plane<u8>) {
            rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap().install(|| {
                let d = cpu(&cfg);
                (d.detect_and_compute(img.view(), None).unwrap(), d.edge_image(img.view()).unwrap())
            })
        };
        for im in [&img, &small] {
            let one = run(1, im);
            assert!(!one.0.0.is_empty());
            for threads in [2, 3, 8] {
                assert!(run(threads, im) == one, "{threads} threads differ from 1");
            }
            assert!(run(1, im) == one, "two 1-thread runs differ");
            let d = Detector::new(cfg.clone(), Backend::Cpu).unwrap();
            assert_eq!(d.detect_and_compute(im.view(), None).unwrap(), one.0);
            if let Some(ctx) = t::context() {
                let g = Detector::from_context(ctx, cfg.clone()).unwrap();
                assert_eq!(g.backend_name(), "gpu");
                for _ in 0..2 {
                    assert_eq!(g.detect_and_compute(im.view(), None).unwrap(), one.0, "GPU vs CPU");
                    assert_eq!(g.edge_image(im.view()).unwrap(), one.1, "GPU vs CPU edges");
                }
            }
        }
    }
}

// ------------------------------------------------------- fuzz regressions

/// Every file under tests/data/regress/<target>/, sorted.
fn regress_inputs(target: &str) -> Vec<PathBuf> {
    let dir = common::data("regress").join(target);
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file() && p.file_name().is_some_and(|n| !n.to_string_lossy().starts_with('.')))
        .collect();
    v.sort();
    v
}

/// Replays one target's inputs; each must pass the target's checks.
fn replay(target: &str, mut f: impl FnMut(&[u8])) {
    let inputs = regress_inputs(target);
    assert!(!inputs.is_empty(), "tests/data/regress/{target} has no inputs");
    for p in &inputs {
        let bytes = std::fs::read(p).unwrap();
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| f(&bytes)));
        assert!(r.is_ok(), "{target}: {} fails again", p.display());
    }
    eprintln!("{target}: {} inputs replayed", inputs.len());
}

#[test]
fn fuzz_regressions_decode_detect() {
    replay("decode_detect", fuzz_cases::decode_detect);
}

#[test]
fn fuzz_regressions_cpu_pipeline() {
    replay("cpu_pipeline", fuzz_cases::cpu_pipeline);
}

#[test]
fn fuzz_regressions_cpu_vs_gpu() {
    let Some(ctx) = t::context() else { return };
    let mut st = fuzz_cases::GpuState::new(ctx);
    replay("cpu_vs_gpu", |b| fuzz_cases::cpu_vs_gpu(b, &mut st));
}

// -------------------------------------------------------------- GPU faults
// No adapter, a refused device, device loss mid-batch, limits: see
// tests/gpu_robustness.rs (docs/reliability.md lists which test covers what).

/// The process's virtual memory size in bytes (Linux).
#[cfg(target_os = "linux")]
fn vm_size() -> u64 {
    let s = std::fs::read_to_string("/proc/self/status").unwrap();
    let line = s.lines().find(|l| l.starts_with("VmSize:")).unwrap();
    line.split_whitespace().nth(1).unwrap().parse::<u64>().unwrap() * 1024
}

/// Out of memory on a workspace allocation, for real: the test runs itself
/// again in a child process (the limit is process-wide) that caps its address
/// space three quarters of a 5000x5000 workspace (`workspace_report`) above
/// what it uses, so that lavapipe's device memory runs out for that workspace
/// (a fixed 1 GiB held it once the workspace shrank to 590 MB). The allocation must be `GpuOutOfMemory`, the
/// device must stay usable, and `Detector` with the CPU fallback must run the
/// frame on the CPU with the CPU's result and keep the GPU for later frames.
#[cfg(target_os = "linux")]
#[test]
fn out_of_memory_on_a_workspace_is_a_typed_error_and_auto_runs_the_frame_on_the_cpu() {
    const CHILD: &str = "LFAST_RELIABILITY_OOM_CHILD";
    let Some(ctx) = t::context() else { return };
    if std::env::var_os(CHILD).is_none() {
        let o = std::process::Command::new(std::env::current_exe().unwrap())
            .args(["out_of_memory_on_a_workspace", "--exact", "--nocapture", "--test-threads=1"])
            .arg("out_of_memory_on_a_workspace_is_a_typed_error_and_auto_runs_the_frame_on_the_cpu")
            .env(CHILD, "1")
            .output()
            .unwrap();
        let text = format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
        assert!(o.status.success() && text.contains("oom child: done"), "child: {:?}\n{text}", o.status);
        return;
    }
    // Config::paper(): its buffers do not move with the defaults (the keypoint
    // slots follow nms_radius; under NMS radius 4 a 5000x5000 workspace fits the cap)
    let cfg = Config { n_levels: 1, ..Config::paper() };
    let gpu = GpuDetector::new(ctx.clone(), cfg.clone()).unwrap();
    let auto = Detector::from_context_with_fallback(ctx, cfg.clone()).unwrap();
    let c = cpu(&cfg);
    let small = t::test_image(120, 90, 1);
    let big = t::test_image(5000, 5000, 2);
    let want_small = c.detect_and_compute(small.view(), None).unwrap();
    let want_big = c.detect_and_compute(big.view(), None).unwrap();
    let mut ws = None;
    assert_eq!(gpu.detect_and_compute(&mut ws, small.view(), None).unwrap().keypoints, want_small.0);
    assert_eq!(auto.detect_and_compute(small.view(), None).unwrap(), want_small);
    let headroom = lfast::gpu::workspace_report(&cfg, 5000, 5000).unwrap().total() * 3 / 4;
    let cap = vm_size() + headroom;
    let lim = libc::rlimit { rlim_cur: cap, rlim_max: libc::RLIM_INFINITY };
    // SAFETY: setrlimit with a valid struct; only this child process is limited.
    assert_eq!(unsafe { libc::setrlimit(libc::RLIMIT_AS, &lim) }, 0);
    eprintln!("oom child: address space capped at {} MiB", cap >> 20);
    // 25 M pixels x 4 bytes in each of some 30 buffers: about 3 GB of device memory
    match gpu.workspace(5000, 5000) {
        Err(Error::GpuOutOfMemory { reason }) => eprintln!("oom child: {reason}"),
        Err(e) => panic!("expected GpuOutOfMemory, got {e:?}"),
        // a discrete GPU's memory is not in the process's address space
        Ok(_) if gpu.context().info.device_type != lfast::wgpu::DeviceType::Cpu => {
            eprintln!(
                "oom child: NOT RUN: {} memory is not limited by RLIMIT_AS; oom child: done",
                gpu.context().info.name
            );
            return;
        }
        Ok(_) => panic!("a 5000x5000 workspace fit in {} MiB of address space on a CPU adapter", headroom >> 20),
    }
    // the device is still usable
    let again = gpu.detect_and_compute(&mut ws, small.view(), None).unwrap();
    assert_eq!((again.keypoints, again.descriptors), want_small);
    // the frame that does not fit (smaller ones did as the buffers shrank:
    // 4000x4000 until blur_tmp went, 4600x4600 until the readback copies were
    // sized from the counts); Auto runs it on the CPU
    assert!(matches!(gpu.workspace(5000, 5000), Err(Error::GpuOutOfMemory { .. })));
    assert_eq!(auto.detect_and_compute(big.view(), None).unwrap(), want_big);
    assert_eq!(auto.backend_name(), "gpu", "out of memory for one frame is not a device loss");
    assert_eq!(auto.detect_and_compute(small.view(), None).unwrap(), want_small);
    eprintln!("oom child: done");
}

/// A device request the adapter cannot satisfy is an `Err` from wgpu, not a
/// panic; `GpuContext::new` turns such an `Err` into `Error::Gpu` ("device
/// request refused by ...") and `Backend::Auto` then runs on the CPU, as for
/// a missing adapter (tests/gpu_robustness.rs,
/// `no_adapter_is_a_typed_error_and_auto_falls_back_to_the_cpu`).
#[test]
fn a_refused_device_request_is_an_error_not_a_panic() {
    use lfast::wgpu;
    let Some(ctx) = t::context() else { return };
    let inst = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    let adapters = pollster::block_on(inst.enumerate_adapters(wgpu::Backends::all()));
    let adapter = adapters.into_iter().find(|a| a.get_info().name == ctx.info.name).expect("the test adapter");
    let mut limits = adapter.limits();
    limits.max_buffer_size = u64::MAX;
    limits.max_compute_workgroups_per_dimension = u32::MAX;
    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        pollster::block_on(
            adapter.request_device(&wgpu::DeviceDescriptor { required_limits: limits, ..Default::default() }),
        )
    }));
    match r {
        Ok(Err(e)) => eprintln!("refused: {e}"),
        Ok(Ok(_)) => panic!("{} granted limits beyond its own", ctx.info.name),
        Err(_) => panic!("request_device panicked"),
    }
}
