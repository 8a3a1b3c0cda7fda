//! Public API behaviour of the CPU detector on real and synthetic images:
//! detect / compute / detect_and_compute agreement, SPEC 9 output order and
//! keypoint fields, the n_features cap, masks, bad and tiny inputs, SPEC 0
//! input conversion, file loading errors and determinism across thread counts.

mod common;

use lfast::baseline::canny::{CannyParams, canny};
use lfast::baseline::fast::fast9;
use lfast::baseline::orb::{OrbDetector, OrbParams};
use lfast::cpu::CpuDetector;
use lfast::spec::keypoint_level_pixel;
use lfast::{Config, Descriptor, Error, GrayView, KeyPoint, Mode, Plane};

fn load(name: &str) -> Plane<u8> {
    lfast::image::load_gray(common::data(name)).unwrap_or_else(|e| panic!("{e}"))
}

fn camera() -> Plane<u8> {
    load("camera_cc0_v0.18plus.png")
}

fn det(cfg: Config) -> CpuDetector {
    CpuDetector::new(cfg).unwrap()
}

/// A deterministic pseudo-random image with some structure (blocks + noise).
fn synthetic(w: u32, h: u32, seed: u32) -> Plane<u8> {
    let mut s = seed.wrapping_mul(2654435761).wrapping_add(12345);
    let mut p = Plane::<u8>::new(w, h);
    for y in 0..h {
        for x in 0..w {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            let block = if ((x / 6) + (y / 5)) % 2 == 0 { 180 } else { 40 };
            p.data[(y * w + x) as usize] = (block + (s % 31) as i32 - 15) as u8;
        }
    }
    p
}

// ---------------------------------------------------------------- agreement

#[test]
fn detect_equals_detect_and_compute_and_compute_matches() {
    let img = camera();
    for cfg in [
        Config::default(),
        Config { mode: Mode::Paper, ..Config::default() },
        Config { orientation_bins: 0, ..Config::default() },
        Config { n_features: 300, distribution: true, ..Config::default() },
    ] {
        let d = det(cfg.clone());
        let kps_only = d.detect(img.view(), None).unwrap();
        let (kps, desc) = d.detect_and_compute(img.view(), None).unwrap();
        assert!(!kps.is_empty(), "{cfg:?}");
        assert_eq!(kps_only, kps, "{cfg:?}: detect() and detect_and_compute() disagree");
        assert_eq!(kps.len(), desc.len());
        let desc2 = d.compute(img.view(), &kps).unwrap();
        if let Some(i) = desc2.iter().zip(&desc).position(|(a, b)| a != b) {
            panic!("{cfg:?}: compute() differs at keypoint {i}: {:?}", kps[i]);
        }
        assert_eq!(desc2.len(), desc.len());
        // compute ignores the angle field: orientation is recomputed
        let no_angle: Vec<KeyPoint> = kps.iter().map(|k| KeyPoint { angle: -1.0, response: 0.0, ..*k }).collect();
        assert_eq!(d.compute(img.view(), &no_angle).unwrap(), desc, "{cfg:?}");
        // a subset in another order gives the matching descriptors
        let picked: Vec<usize> = (0..kps.len()).rev().step_by(7).collect();
        let sub: Vec<KeyPoint> = picked.iter().map(|&i| kps[i]).collect();
        let sub_desc = d.compute(img.view(), &sub).unwrap();
        for (j, &i) in picked.iter().enumerate() {
            assert_eq!(sub_desc[j], desc[i], "{cfg:?}: keypoint {i}");
        }
    }
    assert!(det(Config::default()).compute(img.view(), &[]).unwrap().is_empty());
}

#[test]
fn descriptors_are_not_degenerate() {
    let img = camera();
    let (kps, desc) = det(Config::default()).detect_and_compute(img.view(), None).unwrap();
    assert!(kps.len() > 100);
    // bits are neither all 0 nor all 1, and descriptors differ from each other
    let ones: u32 = desc.iter().flat_map(|d| d.iter()).map(|b| b.count_ones()).sum();
    let frac = ones as f64 / (desc.len() * 256) as f64;
    assert!((0.3..0.7).contains(&frac), "fraction of set bits {frac}");
    let mut uniq: Vec<Descriptor> = desc.clone();
    uniq.sort();
    uniq.dedup();
    assert!(uniq.len() * 10 >= desc.len() * 9, "{} distinct of {}", uniq.len(), desc.len());
    let d01 = lfast::hamming(&desc[0], &desc[1]);
    assert!(d01 > 0 && d01 < 256);
}

// ----------------------------------------------------------- order & fields

fn check_fields_and_order(kps: &[KeyPoint], cfg: &Config, what: &str) {
    for (i, k) in kps.iter().enumerate() {
        assert!((0..cfg.n_levels as i32).contains(&k.octave), "{what} {i}: {k:?}");
        let s = cfg.scale_factor.powi(k.octave);
        assert!((k.size as f64 - 31.0 * s).abs() < 1e-3 * s, "{what} {i}: size {k:?}");
        assert!((0.0..360.0).contains(&k.angle), "{what} {i}: angle {k:?}");
        assert_eq!(k.class_id, -1, "{what} {i}");
        assert!(k.response.is_finite(), "{what} {i}");
        // a pixel centre, moved by a whole number of 1/16 steps up to 7/16 when snapped
        let steps = if cfg.snap() > 0 { 7 } else { 0 };
        for v in [k.pt.x as f64 / s, k.pt.y as f64 / s] {
            let q = (v - v.floor() - 0.5) * 16.0;
            assert!(
                (q - q.round()).abs() < 16e-3 && q.round().abs() <= steps as f64,
                "{what} {i}: pt/s = {v} is not a pixel centre + k/16, |k| <= {steps}: {k:?}"
            );
        }
        // inside the border at its level
        let (x, y) = keypoint_level_pixel(cfg, k);
        assert!(x >= cfg.border && y >= cfg.border, "{what} {i}: ({x},{y}) inside the border: {k:?}");
    }
    for (i, w) in kps.windows(2).enumerate() {
        let (a, b) = (&w[0], &w[1]);
        let ka = (-a.response, a.octave, keypoint_level_pixel(cfg, a).1, keypoint_level_pixel(cfg, a).0);
        let kb = (-b.response, b.octave, keypoint_level_pixel(cfg, b).1, keypoint_level_pixel(cfg, b).0);
        assert!(ka.partial_cmp(&kb) == Some(std::cmp::Ordering::Less), "{what}: order broken at {i}: {a:?} then {b:?}");
    }
}

#[test]
fn output_order_and_keypoint_fields() {
    for name in ["camera_cc0_v0.18plus.png", "coins.png", "chessboard_GRAY.png"] {
        let img = load(name);
        for cfg in [Config::default(), Config { mode: Mode::Paper, ..Config::default() }] {
            let (kps, _) = det(cfg.clone()).detect_and_compute(img.view(), None).unwrap();
            assert!(!kps.is_empty(), "{name}");
            check_fields_and_order(&kps, &cfg, name);
            // keypoints lie inside the image, more than `border` level pixels from the far side
            for k in &kps {
                let (x, y) = keypoint_level_pixel(&cfg, k);
                let (w, h) = cfg.level_sizes(img.width, img.height)[k.octave as usize];
                assert!(x + cfg.border < w && y + cfg.border < h, "{name}: {k:?} in level {w}x{h}");
            }
            // several pyramid levels contribute on a 512x512 image
            if name.starts_with("camera") {
                let levels: std::collections::BTreeSet<i32> = kps.iter().map(|k| k.octave).collect();
                assert!(levels.len() >= 4, "{name}: levels {levels:?}");
            }
        }
    }
}

#[test]
fn single_level_and_other_scale() {
    let img = load("coins.png");
    let cfg = Config { n_levels: 1, ..Config::default() };
    let (kps, desc) = det(cfg.clone()).detect_and_compute(img.view(), None).unwrap();
    assert!(!kps.is_empty());
    assert!(kps.iter().all(|k| k.octave == 0 && k.size == 31.0));
    assert_eq!(kps.len(), desc.len());
    // level 0 of the full pyramid is the same as the single level
    let (all, _) = det(Config::default()).detect_and_compute(img.view(), None).unwrap();
    let l0: Vec<KeyPoint> = all.into_iter().filter(|k| k.octave == 0).collect();
    assert_eq!(l0, kps);

    let cfg = Config { n_levels: 4, scale_factor: 1.5, ..Config::default() };
    let (kps, _) = det(cfg.clone()).detect_and_compute(img.view(), None).unwrap();
    check_fields_and_order(&kps, &cfg, "coins, scale 1.5");
}

// --------------------------------------------------------------------- cap

fn mean_nn_distance(kps: &[KeyPoint]) -> f64 {
    let n = kps.len();
    let mut sum = 0.0;
    for i in 0..n {
        let best =
            (0..n).filter(|&j| j != i).map(|j| (kps[i].pt - kps[j].pt).length() as f64).fold(f64::INFINITY, f64::min);
        sum += best;
    }
    sum / n as f64
}

#[test]
fn n_features_cap() {
    let img = camera();
    let all = det(Config::default()).detect(img.view(), None).unwrap();
    assert!(all.len() > 100, "{}", all.len());

    let cfg = Config { n_features: 100, ..Config::default() };
    let top = det(cfg.clone()).detect(img.view(), None).unwrap();
    assert_eq!(top.len(), 100, "enough corners exist, so the cap is filled");
    assert!(top.iter().all(|k| all.contains(k)), "capped keypoints are a subset of the uncapped set");
    check_fields_and_order(&top, &cfg, "capped");

    let cfg = Config { n_features: 100, distribution: true, ..Config::default() };
    let spread = det(cfg.clone()).detect(img.view(), None).unwrap();
    assert!(spread.len() <= 100 && spread.len() >= 90, "{}", spread.len());
    assert!(spread.iter().all(|k| all.contains(k)), "distributed keypoints are a subset of the uncapped set");
    check_fields_and_order(&spread, &cfg, "distributed");
    let (nn_top, nn_spread) = (mean_nn_distance(&top), mean_nn_distance(&spread));
    eprintln!("mean nearest-neighbour distance: top-100 {nn_top:.1} px, quadtree {nn_spread:.1} px");
    assert!(nn_spread > nn_top, "distribution should spread keypoints: {nn_spread} <= {nn_top}");

    // a cap above the number found changes nothing
    let big = det(Config { n_features: all.len() as u32 + 10, ..Config::default() }).detect(img.view(), None).unwrap();
    assert_eq!(big, all);
    // n_features = 1
    let one = det(Config { n_features: 1, ..Config::default() }).detect(img.view(), None).unwrap();
    assert_eq!(one.len(), 1);
    assert!(all.contains(&one[0]));
}

#[test]
fn distribution_spreads_on_kitti() {
    let Some(p) = common::shared("kitti/seq01_000000-000050/image_0/000000.png") else { return };
    let img = lfast::image::load_gray(p).unwrap();
    let top = det(Config { n_features: 200, ..Config::default() }).detect(img.view(), None).unwrap();
    let spread =
        det(Config { n_features: 200, distribution: true, ..Config::default() }).detect(img.view(), None).unwrap();
    assert!(top.len() <= 200 && spread.len() <= 200 && spread.len() >= 180, "{} {}", top.len(), spread.len());
    let (a, b) = (mean_nn_distance(&top), mean_nn_distance(&spread));
    eprintln!("KITTI 000000 mean NN distance: top {a:.1}, quadtree {b:.1}");
    assert!(b > a, "{b} <= {a}");
}

// ------------------------------------------------------------------- masks

fn mask_plane(w: u32, h: u32, on: impl Fn(u32, u32) -> bool) -> Plane<u8> {
    let mut m = Plane::<u8>::new(w, h);
    for y in 0..h {
        for x in 0..w {
            m.data[(y * w + x) as usize] = if on(x, y) { 255 } else { 0 };
        }
    }
    m
}

#[test]
fn masks() {
    let img = camera();
    let (w, h) = (img.width, img.height);
    let d = det(Config::default());
    let (kps, desc) = d.detect_and_compute(img.view(), None).unwrap();

    let off = mask_plane(w, h, |_, _| false);
    let (k0, d0) = d.detect_and_compute(img.view(), Some(off.view())).unwrap();
    assert!(k0.is_empty() && d0.is_empty(), "all-off mask gave {} keypoints", k0.len());

    let on = mask_plane(w, h, |_, _| true);
    assert_eq!(d.detect_and_compute(img.view(), Some(on.view())).unwrap(), (kps.clone(), desc.clone()));
    // any nonzero value is "on"
    let mut ones = on.clone();
    ones.data.fill(1);
    assert_eq!(d.detect(img.view(), Some(ones.view())).unwrap(), kps);

    // left half on: every keypoint's level pixel keeps mask_radius level pixels
    // from the footprint of the off region
    let half = w / 2;
    let left = mask_plane(w, h, |x, _| x < half);
    let kl = d.detect(img.view(), Some(left.view())).unwrap();
    assert!(!kl.is_empty());
    let cfg = d.config();
    let sizes = cfg.level_sizes(w, h);
    let r = d.mask_radius();
    assert!(r >= 15, "mask radius {r} must cover the orientation disc");
    for k in &kl {
        assert!(k.pt.x < half as f32, "{k:?}");
        let (x, _) = keypoint_level_pixel(cfg, k);
        let lw = sizes[k.octave as usize].0 as u64;
        // last input column under level pixel x + r: ceil((x + r + 1) * W / lw) - 1 must be on
        let last_input = ((x as u64 + r as u64 + 1) * w as u64).div_ceil(lw) - 1;
        assert!(last_input < half as u64, "{k:?}: level x {x}, radius {r} reaches input column {last_input}");
    }
    // the left half of the unmasked result far from the boundary survives
    let far: Vec<&KeyPoint> = kps.iter().filter(|k| k.octave == 0 && k.pt.x < (half - 2 * r) as f32).collect();
    let kept = far.iter().filter(|k| kl.iter().any(|m| m.pt == k.pt && m.octave == 0)).count();
    assert!(kept * 10 >= far.len() * 9, "{kept} of {} level-0 keypoints far from the mask edge kept", far.len());

    // a mask with a stride
    let mut strided = vec![7u8; (w as usize + 5) * h as usize];
    for y in 0..h as usize {
        strided[y * (w as usize + 5)..y * (w as usize + 5) + w as usize].copy_from_slice(left.row(y as u32));
    }
    let sv = GrayView::new(w, h, w as usize + 5, &strided).unwrap();
    assert_eq!(d.detect(img.view(), Some(sv)).unwrap(), kl);

    // wrong size
    let small = mask_plane(w - 1, h, |_, _| true);
    let e = d.detect_and_compute(img.view(), Some(small.view())).unwrap_err();
    assert!(
        matches!(e, Error::MaskSize { mask_width, mask_height, width, height }
        if (mask_width, mask_height, width, height) == (w - 1, h, w, h)),
        "{e:?}"
    );
    let tall = mask_plane(w, h + 1, |_, _| true);
    assert!(matches!(d.detect(img.view(), Some(tall.view())), Err(Error::MaskSize { .. })));
}

// --------------------------------------------------------------- bad input

#[test]
fn gray_view_rejects_bad_buffers() {
    let buf = vec![0u8; 100];
    let invalid = |r: lfast::Result<GrayView<'_>>, what: &str| match r {
        Err(Error::InvalidImage { .. }) => {}
        other => panic!("{what}: expected InvalidImage, got {other:?}"),
    };
    invalid(GrayView::new(10, 11, 10, &buf), "buffer too short");
    invalid(GrayView::new(10, 10, 11, &buf), "buffer too short for the stride");
    invalid(GrayView::new(10, 5, 9, &buf), "stride < width");
    invalid(GrayView::new(0, 5, 5, &buf), "zero width");
    invalid(GrayView::new(5, 0, 5, &buf), "zero height");
    invalid(GrayView::new(0, 0, 0, &[]), "zero size");
    let long = vec![0u8; 16385];
    invalid(GrayView::new(16385, 1, 16385, &long), "width over 16384");
    invalid(GrayView::new(1, 16385, 1, &long), "height over 16384");
    // the last row may be just `width` long
    assert!(GrayView::new(10, 10, 12, &[0u8; 12 * 9 + 10]).is_ok());
    assert!(GrayView::new(16384, 1, 16384, &long).is_ok());
    // the messages say what is wrong
    let e = GrayView::new(10, 5, 9, &buf).unwrap_err().to_string();
    assert!(e.contains("stride"), "{e}");
    let e = GrayView::new(10, 11, 10, &buf).unwrap_err().to_string();
    assert!(e.contains("10x11"), "{e}");
    // Plane::from_vec checks its length
    assert!(matches!(Plane::from_vec(3, 3, vec![0u8; 8]), Err(Error::InvalidImage { .. })));
}

/// A stride so large that `stride * (height - 1)` overflows must be an error,
/// not an arithmetic-overflow panic (debug) or a wrapped size check (release).
#[test]
fn gray_view_rejects_overflowing_stride() {
    let buf = vec![0u8; 64];
    let r = std::panic::catch_unwind(|| GrayView::new(10, 3, usize::MAX / 2 + 1, &buf).map(|_| ()));
    assert!(matches!(r, Ok(Err(Error::InvalidImage { .. }))), "{r:?}");
}

#[test]
fn tiny_images_do_not_panic() {
    let cfg = Config::default();
    let d = det(cfg.clone());
    let orb = OrbDetector::new(OrbParams::default()).unwrap();
    for (w, h) in [(1, 1), (2, 3), (3, 2), (7, 7), (20, 20), (33, 33), (1, 500), (500, 1), (40, 2)] {
        for img in [synthetic(w, h, w * 1000 + h), Plane::<u8>::new(w, h)] {
            let em = d.edges(img.view()).unwrap();
            assert_eq!((em.edges.width, em.edges.height), (w, h));
            assert!(em.edges.data.iter().all(|&v| v == 0 || v == 255), "{w}x{h}");

            let (kps, desc) = d.detect_and_compute(img.view(), None).unwrap();
            assert_eq!(kps.len(), desc.len(), "{w}x{h}");
            if w <= 2 * cfg.border || h <= 2 * cfg.border {
                assert!(kps.is_empty(), "{w}x{h}: no pixel is {} from every side: {kps:?}", cfg.border);
            }
            for k in &kps {
                assert!(k.pt.x >= 0.0 && k.pt.y >= 0.0 && k.pt.x < w as f32 && k.pt.y < h as f32, "{w}x{h}: {k:?}");
            }
            assert_eq!(d.detect(img.view(), None).unwrap(), kps);
            let m = mask_plane(w, h, |_, _| true);
            assert_eq!(d.detect(img.view(), Some(m.view())).unwrap(), kps);

            let c = canny(&img, &CannyParams::default());
            assert_eq!((c.width, c.height), (w, h));
            assert!(c.data.iter().all(|&v| v == 0 || v == 255));

            let f = fast9(&img, 20, true);
            for k in &f {
                assert!(
                    k.pt.x >= 3.0 && k.pt.y >= 3.0 && k.pt.x + 3.0 < w as f32 && k.pt.y + 3.0 < h as f32,
                    "{w}x{h}: {k:?}"
                );
            }
            if w < 7 || h < 7 {
                assert!(f.is_empty(), "{w}x{h}: FAST needs a radius-3 circle");
            }

            let (ok, od) = orb.detect_and_compute(img.view()).unwrap();
            assert_eq!(ok.len(), od.len());
            assert!(ok.is_empty(), "{w}x{h}: ORB's 31-pixel edge threshold leaves nothing");
        }
    }
    // a flat image of a usable size has no edges and no keypoints
    let flat = Plane::from_vec(64, 64, vec![128u8; 64 * 64]).unwrap();
    assert!(d.edges(flat.view()).unwrap().edges.data.iter().all(|&v| v == 0));
    assert!(d.detect(flat.view(), None).unwrap().is_empty());
}

#[test]
fn strided_view_equals_dense() {
    let img = load("coins.png");
    let (w, h) = (img.width as usize, img.height as usize);
    let stride = w + 13;
    let mut buf = vec![0xAAu8; stride * (h - 1) + w];
    for y in 0..h {
        buf[y * stride..y * stride + w].copy_from_slice(img.row(y as u32));
    }
    let v = GrayView::new(img.width, img.height, stride, &buf).unwrap();
    assert_eq!(v.to_plane(), img);
    let d = det(Config::default());
    assert_eq!(d.detect_and_compute(v, None).unwrap(), d.detect_and_compute(img.view(), None).unwrap());
    assert_eq!(d.edges(v).unwrap().edges, d.edges(img.view()).unwrap().edges);
    // From<&GrayImage>
    let gi = image::GrayImage::from_raw(img.width, img.height, img.data.clone()).unwrap();
    assert_eq!(GrayView::from(&gi).to_plane(), img);
}

// --------------------------------------------------------- SPEC 0 convert

fn luma(r: u8, g: u8, b: u8) -> u8 {
    ((19596 * r as u32 + 38470 * g as u32 + 7470 * b as u32 + 32768) >> 16) as u8
}

const RGB: [[u8; 3]; 8] =
    [[0, 0, 0], [255, 255, 255], [255, 0, 0], [0, 255, 0], [0, 0, 255], [12, 200, 77], [1, 2, 3], [250, 128, 7]];

#[test]
fn colour_and_16_bit_conversion() {
    use image::{DynamicImage as D, ImageBuffer, Luma, LumaA, Rgb, Rgba};
    let n = RGB.len() as u32;
    // hand-checked values of the formula
    assert_eq!(luma(255, 0, 0), 76);
    assert_eq!(luma(0, 255, 0), 150);
    assert_eq!(luma(0, 0, 255), 29);
    assert_eq!(luma(255, 255, 255), 255);
    let expect: Vec<u8> = RGB.iter().map(|p| luma(p[0], p[1], p[2])).collect();

    let rgb8 = ImageBuffer::from_fn(n, 1, |x, _| Rgb(RGB[x as usize]));
    assert_eq!(lfast::image::to_gray(&D::ImageRgb8(rgb8)).unwrap().data, expect, "Rgb8");

    let rgba8 = ImageBuffer::from_fn(n, 1, |x, _| {
        let [r, g, b] = RGB[x as usize];
        Rgba([r, g, b, (x * 37) as u8]) // alpha is ignored
    });
    assert_eq!(lfast::image::to_gray(&D::ImageRgba8(rgba8)).unwrap().data, expect, "Rgba8");

    // 16-bit: v >> 8 per channel, then the luma; low bytes must not matter
    let lows = [0u16, 0xff, 0x80, 0x7f, 1, 0xfe, 0x55, 0xaa];
    let rgb16 = ImageBuffer::from_fn(n, 1, |x, _| {
        let [r, g, b] = RGB[x as usize];
        let l = lows[x as usize];
        Rgb([(r as u16) << 8 | l, (g as u16) << 8 | (0xff - l), (b as u16) << 8 | l])
    });
    assert_eq!(lfast::image::to_gray(&D::ImageRgb16(rgb16)).unwrap().data, expect, "Rgb16");
    let rgba16 = ImageBuffer::from_fn(n, 1, |x, _| {
        let [r, g, b] = RGB[x as usize];
        Rgba([(r as u16) << 8 | 0xff, (g as u16) << 8, (b as u16) << 8 | 0x80, 0])
    });
    assert_eq!(lfast::image::to_gray(&D::ImageRgba16(rgba16)).unwrap().data, expect, "Rgba16");

    let vals16 = [0u16, 0xff, 0x100, 0x1234, 0x8000, 0xfeff, 0xff00, 0xffff];
    let l16 = ImageBuffer::from_fn(8, 1, |x, _| Luma([vals16[x as usize]]));
    let want16: Vec<u8> = vals16.iter().map(|v| (v >> 8) as u8).collect();
    assert_eq!(want16, vec![0, 0, 1, 0x12, 0x80, 0xfe, 0xff, 0xff]);
    assert_eq!(lfast::image::to_gray(&D::ImageLuma16(l16)).unwrap().data, want16, "Luma16");
    let la16 = ImageBuffer::from_fn(8, 1, |x, _| LumaA([vals16[x as usize], 0x1234]));
    assert_eq!(lfast::image::to_gray(&D::ImageLumaA16(la16)).unwrap().data, want16, "LumaA16");

    let vals8 = [0u8, 1, 7, 128, 200, 254, 255, 99];
    let la8 = ImageBuffer::from_fn(8, 1, |x, _| LumaA([vals8[x as usize], 255 - vals8[x as usize]]));
    assert_eq!(lfast::image::to_gray(&D::ImageLumaA8(la8)).unwrap().data, vals8.to_vec(), "LumaA8");
    let l8 = ImageBuffer::from_fn(8, 1, |x, _| Luma([vals8[x as usize]]));
    assert_eq!(lfast::image::to_gray(&D::ImageLuma8(l8)).unwrap().data, vals8.to_vec(), "Luma8");

    // a 2-D image keeps its layout (row-major)
    let rgb = ImageBuffer::from_fn(3, 2, |x, y| Rgb(RGB[(y * 3 + x) as usize]));
    let g = lfast::image::to_gray(&D::ImageRgb8(rgb)).unwrap();
    assert_eq!((g.width, g.height), (3, 2));
    assert_eq!(g.at(2, 1), expect[5]);
    assert_eq!(g.at(0, 1), expect[3]);
}

/// SPEC 0 on every one of the 2^24 colours: a 4096x4096 RGB image holding each colour once
/// (red in the low byte of the index, blue in the high), through `to_gray`, against the
/// formula. The GPU luma pass is held to `luma_bt601` in tests/gpu_levels.rs, and cv2's
/// `cvtColor` to it in python/tests/test_detect.py.
#[test]
fn luma_is_exact_on_all_2_pow_24_colours() {
    use image::{DynamicImage as D, ImageBuffer, Rgb};
    let colour = |x: u32, y: u32| {
        let i = y * 4096 + x;
        [i as u8, (i >> 8) as u8, (i >> 16) as u8]
    };
    let rgb = ImageBuffer::from_fn(4096, 4096, |x, y| Rgb(colour(x, y)));
    let g = lfast::image::to_gray(&D::ImageRgb8(rgb)).unwrap();
    let mut wrong = 0usize;
    for (i, &v) in g.data.iter().enumerate() {
        let [r, gr, b] = colour(i as u32 % 4096, i as u32 / 4096);
        if v != luma(r, gr, b) || v != lfast::image::luma_bt601(r, gr, b) {
            wrong += 1;
        }
    }
    assert_eq!(wrong, 0, "colours converted off the SPEC 0 formula");
    // the older 14-bit weights differ from these on some colours: the test can tell them apart
    let old = |r: u32, g: u32, b: u32| ((4899 * r + 9617 * g + 1868 * b + 8192) >> 14) as u8;
    assert_eq!((old(0, 0, 250), luma(0, 0, 250)), (29, 28));
}

#[test]
fn load_gray_converts_an_rgb_png() {
    let path = common::data("astronaut_256.png");
    let rgb = image::open(&path).unwrap();
    assert!(matches!(rgb, image::DynamicImage::ImageRgb8(_)), "the test image is RGB");
    let rgb = rgb.to_rgb8();
    let g = lfast::image::load_gray(&path).unwrap();
    assert_eq!((g.width, g.height), rgb.dimensions());
    for (i, p) in rgb.pixels().enumerate() {
        assert_eq!(g.data[i], luma(p.0[0], p.0[1], p.0[2]), "pixel {i}");
    }
}

#[test]
fn load_gray_errors() {
    let dir = tempfile::tempdir().unwrap();

    let missing = dir.path().join("does_not_exist.png");
    let e = lfast::image::load_gray(&missing).unwrap_err();
    assert!(matches!(&e, Error::Io { path, .. } if path == &missing), "{e:?}");
    assert!(e.to_string().contains("does_not_exist.png"), "{e}");

    let text = dir.path().join("notes.png");
    std::fs::write(&text, "this is not an image, just some text\n".repeat(10)).unwrap();
    let e = lfast::image::load_gray(&text).unwrap_err();
    assert!(matches!(&e, Error::Image { path, .. } if path == &text), "{e:?}");
    assert!(e.to_string().contains("notes.png"), "{e}");

    let empty = dir.path().join("empty.png");
    std::fs::write(&empty, b"").unwrap();
    assert!(lfast::image::load_gray(&empty).is_err());

    let real = std::fs::read(common::data("coins.png")).unwrap();
    for n in [8, 33, 100, 1000, real.len() / 2, real.len() - 12] {
        let cut = dir.path().join(format!("truncated_{n}.png"));
        std::fs::write(&cut, &real[..n]).unwrap();
        let r = std::panic::catch_unwind(|| lfast::image::load_gray(&cut));
        match r {
            Ok(Err(e)) => assert!(e.to_string().contains(&format!("truncated_{n}.png")), "{e}"),
            Ok(Ok(p)) => panic!("{n} bytes of a PNG decoded to {}x{}", p.width, p.height),
            Err(_) => panic!("load_gray panicked on a PNG truncated to {n} bytes"),
        }
    }

    // a directory is not an image either
    assert!(lfast::image::load_gray(dir.path()).is_err());
}

#[test]
fn save_gray_round_trips() {
    let dir = tempfile::tempdir().unwrap();
    let img = synthetic(37, 23, 5);
    let p = dir.path().join("x.png");
    lfast::image::save_gray(&img, &p).unwrap();
    assert_eq!(lfast::image::load_gray(&p).unwrap(), img);
    let e = lfast::image::save_gray(&img, dir.path().join("no/such/dir/x.png")).unwrap_err();
    assert!(e.to_string().contains("x.png"), "{e}");
}

// ------------------------------------------------------------- determinism

#[test]
fn deterministic_across_runs_and_thread_counts() {
    let img = camera();
    let run = |cfg: &Config, threads: usize| {
        rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap().install(|| {
            let d = det(cfg.clone());
            let out = d.detect_and_compute(img.view(), None).unwrap();
            let edges = d.edges(img.view()).unwrap().edges;
            let c = canny(&img, &CannyParams::default());
            let orb = OrbDetector::new(OrbParams::default()).unwrap().detect_and_compute(img.view()).unwrap();
            (out, edges, c, orb)
        })
    };
    for cfg in [
        Config::default(),
        Config { mode: Mode::Paper, n_features: 500, distribution: true, ..Config::default() },
        Config { orientation_bins: 0, n_features: 300, ..Config::default() },
    ] {
        let one = run(&cfg, 1);
        assert!(!one.0.0.is_empty());
        let three = run(&cfg, 3);
        assert!(one == three, "{cfg:?}: 1 thread and 3 threads differ");
        let again = run(&cfg, 3);
        assert!(three == again, "{cfg:?}: two 3-thread runs differ");
    }
}

#[test]
fn extreme_valid_configs_do_not_panic() {
    let img = load("coins.png");
    let d = Config::default;
    for cfg in [
        Config { nms_radius: 32, ..d() },
        Config { nms_radius: 0, ..d() },
        Config { border: 1024, ..d() },
        Config { border: 7, ..d() },
        Config { support: 1, straight_tol: 0, ..d() },
        Config { support: 8, straight_tol: 7, ..d() },
        Config { orientation_bins: 1, ..d() },
        Config { orientation_bins: 360, ..d() },
        Config { n_levels: 32, scale_factor: 4.0, ..d() },
        Config { n_levels: 32, scale_factor: 1.01, ..d() },
        Config { alpha_pct: 0, delta: 0.0001, ..d() },
        Config { alpha_pct: 99, delta: 100.0, ..d() },
        Config { n_features: 1, distribution: true, ..d() },
        Config { n_features: 7, distribution: true, n_levels: 3, ..d() },
    ] {
        cfg.validate().unwrap();
        let det = det(cfg.clone());
        let (kps, desc) = det.detect_and_compute(img.view(), None).unwrap();
        assert_eq!(kps.len(), desc.len(), "{cfg:?}");
        check_fields_and_order(&kps, &cfg, &format!("{cfg:?}"));
        if cfg.border == 1024 {
            assert!(kps.is_empty());
        }
        if cfg.n_features > 0 {
            assert!(kps.len() <= cfg.n_features as usize, "{cfg:?}: {}", kps.len());
        }
        assert_eq!(det.compute(img.view(), &kps).unwrap(), desc, "{cfg:?}");
    }
}

#[test]
fn edge_image_equals_the_staged_edge_map() {
    let det = lfast::cpu::CpuDetector::new(lfast::Config::default()).unwrap();
    for name in ["camera_cc0_v0.18plus.png", "coins.png", "text.png", "astronaut_256.png"] {
        let img = lfast::image::load_gray(common::data(name)).unwrap();
        assert_eq!(det.edge_image(img.view()).unwrap(), det.edges(img.view()).unwrap().edges, "{name}");
    }
}

#[test]
fn edge_image_into_reuses_its_plane_and_keeps_it_on_errors() {
    let det = lfast::cpu::CpuDetector::new(lfast::Config::default()).unwrap();
    let mut out = lfast::Plane::default();
    // one plane through images of different sizes, each result equal to edge_image's
    for name in ["camera_cc0_v0.18plus.png", "coins.png", "camera_cc0_v0.18plus.png"] {
        let img = lfast::image::load_gray(common::data(name)).unwrap();
        det.edge_image_into(img.view(), &mut out).unwrap();
        assert_eq!(out, det.edge_image(img.view()).unwrap(), "{name}");
    }
    // a strided view (row padding) reads in place, with the same result as its dense copy
    let img = lfast::image::load_gray(common::data("coins.png")).unwrap();
    let (w, h) = (img.width, img.height);
    let stride = w as usize + 13;
    let mut padded = vec![7u8; stride * h as usize];
    for y in 0..h as usize {
        padded[y * stride..y * stride + w as usize].copy_from_slice(img.row(y as u32));
    }
    let view = lfast::GrayView::new(w, h, stride, &padded).unwrap();
    det.edge_image_into(view, &mut out).unwrap();
    assert_eq!(out, det.edge_image(img.view()).unwrap());
    // bad input: an error naming the problem, and `out` as it was
    let before = out.clone();
    let bad = lfast::Plane { width: 10, height: 10, data: vec![0u8; 5] };
    let e = det.edge_image_into(bad.view(), &mut out).unwrap_err();
    assert!(matches!(e, lfast::Error::InvalidImage { .. }), "{e:?}");
    assert_eq!(out, before);
}
