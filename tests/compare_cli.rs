//! `lfast compare`: the README's picture, checked against the library.

mod common;

use common::{lfast, show, stdout};
use lfast::frontend::{Features, FrontEnd};
use lfast::{Backend, Config, Detector};

/// Decodes an RGB PNG.
fn read_rgb(path: &std::path::Path) -> image::RgbImage {
    image::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())).to_rgb8()
}

/// The `w x h` panel whose image starts at `(x0, y0)` of `pic`.
fn panel(pic: &image::RgbImage, (x0, y0): (u32, u32), (w, h): (u32, u32)) -> image::RgbImage {
    image::imageops::crop_imm(pic, x0, y0, w, h).to_image()
}

fn is_gray(p: &image::Rgb<u8>) -> bool {
    p.0[0] == p.0[1] && p.0[1] == p.0[2]
}

#[test]
fn compare_draws_the_edge_map_and_three_detectors_side_by_side() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("pic/compare.png");
    let img = common::data("astronaut_256.png");
    let o = lfast(&[&"compare", &img, &"--out", &out, &"--backend", &"cpu", &"--n-features", &"300"]);
    assert!(o.status.success(), "{}", show(&o));
    let line = stdout(&o);
    assert!(line.contains("budget 300") && line.contains("lfast 300"), "{line:?}");

    let gray = lfast::image::load_gray(&img).unwrap();
    let (w, h) = (gray.width, gray.height);
    let pic = read_rgb(&out);
    // two panels by two, 6-pixel gaps, a label strip of 8/5 of the font (w / 26, at least 11)
    // above each, and one below for the legend
    let strip = (w / 26).clamp(11, 26) * 8 / 5;
    assert_eq!(pic.dimensions(), (2 * w + 18, 3 * strip + 2 * h + 18));
    let origin = |i: u32| (6 + (i % 2) * (w + 6), 6 + (i / 2) * (h + strip + 6) + strip);
    let panels: Vec<image::RgbImage> = (0..4).map(|i| panel(&pic, origin(i), (w, h))).collect();

    // the edge panel is the library's edge map, white on black
    let cfg = Config { n_features: 300, ..Config::default() };
    let det = Detector::new(cfg.clone(), Backend::Cpu).unwrap();
    let edges = det.edge_image(gray.view()).unwrap();
    for (x, y, p) in panels[0].enumerate_pixels() {
        let v = if edges.at(x, y) != 0 { 255 } else { 0 };
        assert_eq!(p.0, [v, v, v], "edge panel at ({x}, {y})");
    }
    assert!(edges.data.iter().any(|&v| v != 0));

    // each keypoint panel is the image, gray, with a coloured ring (radius 3 at this width)
    // around each of its detector's keypoints
    let fronts = [
        Features::lfast(det),
        Features::cpu(FrontEnd::Fast, cfg.clone(), 20, 300).unwrap(),
        Features::cpu(FrontEnd::Orb, cfg, 20, 300).unwrap(),
    ];
    for (front, pane) in fronts.iter().zip(&panels[1..]) {
        let (kps, _) = front.detect_and_compute(&gray).unwrap();
        assert!(!kps.is_empty() && kps.len() <= 300, "{}: {} keypoints", front.kind(), kps.len());
        let mut marked = 0;
        for (x, y, p) in pane.enumerate_pixels() {
            if is_gray(p) {
                assert_eq!(p.0[0], gray.at(x, y), "{}: unmarked pixel ({x}, {y}) is not the image", front.kind());
            } else {
                marked += 1;
            }
        }
        assert!(marked > 0, "{}: nothing drawn", front.kind());
        for k in &kps {
            let (x, y) = (k.pt.x.round() as u32 + 3, k.pt.y.round() as u32);
            if x < w {
                assert!(!is_gray(pane.get_pixel(x, y)), "{}: keypoint ring at ({x}, {y}) not drawn", front.kind());
            }
        }
    }
    // the four panels differ from one another
    for i in 0..4 {
        for j in i + 1..4 {
            assert_ne!(panels[i], panels[j], "panels {i} and {j} are the same");
        }
    }
    // the label strips and the legend hold text: light or coloured pixels on the dark background
    let text_in = |y: u32| image::imageops::crop_imm(&pic, 6, y, w, strip).to_image().pixels().any(|p| p.0[0] > 128);
    assert!(text_in(6), "the first label is empty");
    assert!(text_in(2 * (h + strip) + 12), "the legend is empty");
}

#[test]
fn compare_names_a_missing_input() {
    let dir = tempfile::tempdir().unwrap();
    let o = lfast(&[&"compare", &"no/such/image.png", &"--out", &dir.path().join("x.png")]);
    assert_eq!(o.status.code(), Some(2), "{}", show(&o));
    assert!(common::stderr(&o).contains("no/such/image.png"), "{}", show(&o));
    assert!(!dir.path().join("x.png").exists());
}

#[test]
fn compare_on_the_gpu_draws_the_cpu_picture() {
    // lavapipe in CI, where REQUIRE_GPU=1 makes a missing adapter a failure
    if lfast::testing::context().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let img = common::data("coins.png");
    let (gpu, cpu) = (dir.path().join("gpu.png"), dir.path().join("cpu.png"));
    let o = lfast(&[&"compare", &img, &"--out", &gpu, &"--backend", &"gpu"]);
    assert!(o.status.success(), "{}", show(&o));
    let o = lfast(&[&"compare", &img, &"--out", &cpu, &"--backend", &"cpu"]);
    assert!(o.status.success(), "{}", show(&o));
    assert_eq!(std::fs::read(&gpu).unwrap(), std::fs::read(&cpu).unwrap(), "GPU and CPU pictures differ");
}
