//! The `lfast` binary: `detect` and `edges`, options, config files and errors.

mod common;

use std::process::Output;

use common::{lfast, read_features, stderr, stdout};

fn assert_ok(o: &Output) {
    assert!(o.status.success(), "exit {:?}\nstdout: {}\nstderr: {}", o.status, stdout(o), stderr(o));
}

/// Fails with a non-zero exit and a single-line message on stderr containing `needle`
/// (besides `--backend auto`'s `lfast: note:` line on a machine with no hardware GPU
/// and no adapter named).
fn assert_fails_naming(o: &Output, needle: &str) {
    assert!(!o.status.success(), "expected failure\nstdout: {}\nstderr: {}", stdout(o), stderr(o));
    assert_ne!(o.status.code(), Some(0));
    let err = stderr(o);
    let errors = err.lines().filter(|l| !l.starts_with("lfast: note: ")).count();
    assert_eq!(errors, 1, "stderr should be one error line: {err:?}");
    assert!(err.contains(needle), "stderr does not name `{needle}`: {err:?}");
}

#[test]
fn detect_writes_features_json() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out/nested");
    let img = common::data("coins.png");
    let o = lfast(&[&"detect", &img, &"--out", &out]);
    assert_ok(&o);
    let json = out.join("coins.json");
    let f = read_features(&json);
    assert_eq!((f.width, f.height), (384, 303));
    assert!(!f.keypoints.is_empty());
    assert_eq!(f.keypoints.len(), f.descriptors.len());
    assert!(f.descriptors.iter().all(|d| d.len() == 64 && d.chars().all(|c| c.is_ascii_hexdigit())));
    assert!(f.image.ends_with("coins.png"), "{}", f.image);
    // one line for the file, then the summary
    let text = stdout(&o);
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 2, "{text:?}");
    let line = lines[0];
    assert!(line.contains(&f.keypoints.len().to_string()) && line.contains("coins.json"), "{line:?}");
    assert!(lines[1].starts_with("summary: done 1, skipped 0, failed 0"), "{text:?}");
    assert!(lines[1].contains(&format!("{} keypoints", f.keypoints.len())), "{text:?}");
    // no temporary file is left next to the output
    let names: Vec<String> =
        std::fs::read_dir(&out).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    assert_eq!(names, vec!["coins.json".to_string()]);

    // same result as the library
    let g = lfast::image::load_gray(&img).unwrap();
    let det = lfast::cpu::CpuDetector::new(lfast::Config::default()).unwrap();
    let (kps, desc) = det.detect_and_compute(g.view(), None).unwrap();
    assert_eq!(f.keypoints, kps);
    assert_eq!(f.descriptors, desc.iter().map(lfast::io::hex).collect::<Vec<_>>());
}

#[test]
fn detect_mode_and_options_are_honoured() {
    let dir = tempfile::tempdir().unwrap();
    let img = common::data("coins.png");
    let count = |sub: &str, extra: &[&dyn AsRef<std::ffi::OsStr>]| {
        let out = dir.path().join(sub);
        let mut args: Vec<&dyn AsRef<std::ffi::OsStr>> = vec![&"detect", &img, &"--out", &out];
        args.extend_from_slice(extra);
        let o = lfast(&args);
        assert_ok(&o);
        read_features(&out.join("coins.json"))
    };
    // the default mode is paper (docs/evaluation.md): --mode branch must change the output
    let default = count("default", &[]);
    let branch = count("branch", &[&"--mode", &"branch"]);
    let g = lfast::image::load_gray(&img).unwrap();
    let lib_branch = lfast::cpu::CpuDetector::new(lfast::Config { mode: lfast::Mode::Branch, ..Default::default() })
        .unwrap()
        .detect(g.view(), None)
        .unwrap();
    assert_eq!(branch.keypoints, lib_branch);
    assert_ne!(default.keypoints.len(), branch.keypoints.len(), "--mode branch made no difference");

    let capped = count("capped", &[&"--n-features", &"25"]);
    assert_eq!(capped.keypoints.len(), 25);
    let one_level = count("one", &[&"--n-levels", &"1"]);
    assert!(!one_level.keypoints.is_empty() && one_level.keypoints.iter().all(|k| k.octave == 0));

    // a config file, and a command-line option over it
    let cfg = dir.path().join("cfg.toml");
    std::fs::write(&cfg, "n_features = 10\nmode = \"branch\"\n").unwrap();
    let from_file = count("file", &[&"--config", &cfg]);
    assert!(from_file.keypoints.len() <= 10 && !from_file.keypoints.is_empty(), "{}", from_file.keypoints.len());
    assert!(from_file.keypoints.iter().all(|k| lib_branch.contains(k)), "the config's mode = branch was not used");
    let overridden = count("over", &[&"--config", &cfg, &"--n-features", &"3"]);
    assert_eq!(overridden.keypoints.len(), 3);
}

#[test]
fn edges_writes_a_binary_png() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sub/coins_edges.png");
    let img = common::data("coins.png");
    let o = lfast(&[&"edges", &img, &"-o", &out]);
    assert_ok(&o);
    let e = image::open(&out).unwrap();
    assert!(matches!(e, image::DynamicImage::ImageLuma8(_)));
    let e = e.to_luma8();
    assert_eq!(e.dimensions(), (384, 303));
    assert!(e.as_raw().iter().all(|&v| v == 0 || v == 255));
    let n = e.as_raw().iter().filter(|&&v| v == 255).count();
    assert!(n > 0);
    assert!(stdout(&o).contains(&format!("{n} edge pixels")), "{}", stdout(&o));
    // the library's edge map
    let g = lfast::image::load_gray(&img).unwrap();
    let em = lfast::cpu::CpuDetector::new(lfast::Config::default()).unwrap().edges(g.view()).unwrap();
    assert_eq!(e.as_raw(), &em.edges.data);

    // --out long form, RGB input
    let out2 = dir.path().join("astro.png");
    assert_ok(&lfast(&[&"edges", &common::data("astronaut_256.png"), &"--out", &out2]));
    assert_eq!(image::open(&out2).unwrap().to_luma8().dimensions(), (256, 256));
}

#[test]
fn missing_input_fails_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nowhere_to_be_found.png");
    let o = lfast(&[&"detect", &missing, &"--out", &dir.path()]);
    assert_fails_naming(&o, "nowhere_to_be_found.png");
    assert!(!dir.path().join("nowhere_to_be_found.json").exists());
    let o = lfast(&[&"edges", &missing, &"-o", &dir.path().join("e.png")]);
    assert_fails_naming(&o, "nowhere_to_be_found.png");
    assert!(!dir.path().join("e.png").exists());
}

#[test]
fn non_image_input_fails() {
    let dir = tempfile::tempdir().unwrap();
    let txt = dir.path().join("readme.png");
    std::fs::write(&txt, "plain text, not a PNG\n").unwrap();
    let o = lfast(&[&"detect", &txt, &"--out", &dir.path().join("out")]);
    assert_fails_naming(&o, "readme.png");
    let o = lfast(&[&"edges", &txt, &"-o", &dir.path().join("e.png")]);
    assert_fails_naming(&o, "readme.png");
}

#[test]
fn invalid_config_fails_naming_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let img = common::data("text.png");
    let out = dir.path().join("out");
    let cfg = dir.path().join("bad.toml");
    std::fs::write(&cfg, "scale_factor = 0.9\n").unwrap();
    assert_fails_naming(&lfast(&[&"detect", &img, &"--out", &out, &"--config", &cfg]), "scale_factor");
    std::fs::write(&cfg, "alpha_pct = 100\n").unwrap();
    assert_fails_naming(&lfast(&[&"edges", &img, &"-o", &dir.path().join("e.png"), &"--config", &cfg]), "alpha_pct");
    // an option out of range
    assert_fails_naming(&lfast(&[&"detect", &img, &"--out", &out, &"--n-levels", &"0"]), "n_levels");
    // unknown field and parse errors name the file
    std::fs::write(&cfg, "n_feature = 5\n").unwrap();
    assert!(!lfast(&[&"detect", &img, &"--out", &out, &"--config", &cfg]).status.success());
    assert!(stderr(&lfast(&[&"detect", &img, &"--out", &out, &"--config", &cfg])).contains("bad.toml"));
    // a missing config file
    let o = lfast(&[&"detect", &img, &"--out", &out, &"--config", &dir.path().join("absent.toml")]);
    assert_fails_naming(&o, "absent.toml");
    assert!(!out.join("text.json").exists());
}

#[test]
fn bad_arguments_fail() {
    let img = common::data("text.png");
    assert!(!lfast(&[]).status.success());
    assert!(!lfast(&[&"detect", &img]).status.success(), "--out is required");
    assert!(!lfast(&[&"frobnicate", &img]).status.success());
    let o = lfast(&[&"detect", &img, &"--out", &"/tmp/x", &"--mode", &"sideways"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("sideways"), "{}", stderr(&o));
    let o = lfast(&[&"--help"]);
    assert_ok(&o);
    assert!(stdout(&o).contains("detect") && stdout(&o).contains("edges"));
}
