//! What a newcomer sees first (README): the first command on a headless machine
//! prints only lfast's own lines, and a colour file gives the keypoints of its
//! gray conversion (SPEC 0 luma = OpenCV 4.x/5.x `cvtColor(COLOR_BGR2GRAY)`),
//! in PNG and JPEG.
//!
//! The quiet run: lfast's Vulkan instance leaves out the window-system surface
//! extensions (src/gpu/context.rs, `compute_only_vulkan`), so Mesa's device
//! selection layer does not connect to a Wayland display and libwayland's
//! `error: XDG_RUNTIME_DIR is invalid or not set in the environment.` is not
//! printed while the backend is chosen; the environment is not changed.
//! python/tests/test_first_run.py checks the Python package the same way, and
//! .ci/run the C and C++ tests.

mod common;

use common::{read_features, show, stderr, stdout};
use std::path::Path;
use std::process::{Command, Output};

/// The binary as on a user's fresh headless machine: no `XDG_RUNTIME_DIR`, no
/// adapter or backend named (so `--backend auto` enumerates every adapter,
/// lavapipe's included where it is installed).
fn fresh(args: &[&dyn AsRef<std::ffi::OsStr>]) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_lfast"));
    c.env_remove("XDG_RUNTIME_DIR").env_remove("WGPU_ADAPTER_NAME").env_remove("WGPU_BACKEND");
    c.args(args).output().expect("the lfast binary runs")
}

#[test]
fn readme_first_command_prints_only_lfasts_lines() {
    let tmp = tempfile::tempdir().unwrap();
    let img = common::data("camera_cc0_v0.18plus.png");
    let out = tmp.path().join("out");
    let o = fresh(&[&"detect", &img, &"--out", &out]);
    assert!(o.status.success(), "{}", show(&o));
    for line in stderr(&o).lines() {
        assert!(line.starts_with("lfast: "), "a stderr line that is not lfast's: {line:?}\n{}", show(&o));
    }
    let text = stdout(&o);
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 2, "{}", show(&o));
    assert!(lines[0].starts_with(&format!("{}: ", img.display())), "{}", show(&o));
    assert!(lines[1].starts_with("summary: done 1, skipped 0, failed 0 of 1 files"), "{}", show(&o));
    assert!(out.join("camera_cc0_v0.18plus.json").is_file());

    // `lfast info` enumerates every adapter: where lavapipe is installed (CI sets
    // REQUIRE_GPU=1 and installs it), the test above really crossed Mesa's check.
    let o = fresh(&[&"info"]);
    assert!(o.status.success(), "{}", show(&o));
    assert_eq!(stderr(&o), "", "{}", show(&o));
    if std::env::var("REQUIRE_GPU").is_ok_and(|v| v == "1") {
        assert!(stdout(&o).contains("llvmpipe"), "REQUIRE_GPU=1 but lavapipe is not enumerated\n{}", show(&o));
    }
}

#[test]
fn an_explicit_xdg_runtime_dir_is_left_alone() {
    // a valid directory of the user's stays as it is (the child sees it unchanged)
    let tmp = tempfile::tempdir().unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_lfast"))
        .env("XDG_RUNTIME_DIR", tmp.path())
        .env_remove("WGPU_ADAPTER_NAME")
        .args(["info"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", show(&o));
    assert_eq!(stderr(&o), "", "{}", show(&o));
    assert_eq!(std::fs::read_dir(tmp.path()).unwrap().count(), 0, "nothing written into the user's directory");
}

/// Keypoints and descriptors of `lfast detect --backend cpu` on one file.
fn detect(path: &Path, out: &Path) -> (Vec<lfast::KeyPoint>, Vec<String>) {
    let o = common::lfast(&[&"detect", &path, &"--out", &out, &"--backend", &"cpu"]);
    assert!(o.status.success(), "{}", show(&o));
    let stem = path.file_stem().unwrap().to_str().unwrap();
    let f = read_features(&out.join(format!("{stem}.json")));
    (f.keypoints, f.descriptors)
}

/// SPEC 0 as cv2.cvtColor(COLOR_BGR2GRAY) computes it, written out here.
fn cv2_gray(rgb: &image::RgbImage) -> image::GrayImage {
    image::GrayImage::from_fn(rgb.width(), rgb.height(), |x, y| {
        let [r, g, b] = rgb.get_pixel(x, y).0.map(u32::from);
        image::Luma([((19596 * r + 38470 * g + 7470 * b + 32768) >> 16) as u8])
    })
}

#[test]
fn colour_and_gray_files_give_the_same_keypoints_png_and_jpeg() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let out = dir.join("out");
    // a colour photo (CC0), twice as large so that the pyramid has detail to keep
    let rgb = image::open(common::data("astronaut_256.png")).unwrap().to_rgb8();
    let rgb = image::imageops::resize(&rgb, 512, 512, image::imageops::FilterType::CatmullRom);

    // PNG: colour against its gray conversion
    rgb.save(dir.join("colour.png")).unwrap();
    cv2_gray(&rgb).save(dir.join("gray.png")).unwrap();
    let colour = detect(&dir.join("colour.png"), &out);
    assert!(colour.0.len() > 100, "{} keypoints", colour.0.len());
    assert_eq!(colour, detect(&dir.join("gray.png"), &out), "colour.png and gray.png");

    // colour JPEG: the decoded colours' gray conversion as a lossless PNG
    let mut jpeg = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut jpeg, 90).encode_image(&rgb).unwrap();
    std::fs::write(dir.join("colour_jpeg.jpg"), &jpeg).unwrap();
    let decoded = image::open(dir.join("colour_jpeg.jpg")).unwrap().to_rgb8();
    cv2_gray(&decoded).save(dir.join("colour_jpeg_gray.png")).unwrap();
    assert_eq!(
        detect(&dir.join("colour_jpeg.jpg"), &out),
        detect(&dir.join("colour_jpeg_gray.png"), &out),
        "colour JPEG and its gray conversion"
    );

    // gray JPEG: read as the gray it decodes to
    let gray = cv2_gray(&rgb);
    let mut jpeg = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut jpeg, 90).encode_image(&gray).unwrap();
    std::fs::write(dir.join("gray_jpeg.jpg"), &jpeg).unwrap();
    let decoded = image::open(dir.join("gray_jpeg.jpg")).unwrap();
    assert!(matches!(decoded, image::DynamicImage::ImageLuma8(_)), "a one-channel JPEG");
    decoded.to_luma8().save(dir.join("gray_jpeg_decoded.png")).unwrap();
    assert_eq!(
        detect(&dir.join("gray_jpeg.jpg"), &out),
        detect(&dir.join("gray_jpeg_decoded.png"), &out),
        "gray JPEG and its pixels as PNG"
    );
}
