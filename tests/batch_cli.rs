//! `lfast detect` / `edges` / `info` as a batch tool: many inputs, per-file
//! errors, summary counts, --skip-existing, formats, shards, backends.

mod common;

use std::ffi::OsStr;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use common::{files, lfast, read_features, show, stderr, stdout, summary};

/// in/: coins.png, text.png, sub/camera.png (good), trunc.png (a truncated
/// PNG), x.png (a text file).
fn inputs(root: &Path) -> PathBuf {
    let dir = root.join("in");
    std::fs::create_dir_all(dir.join("sub")).unwrap();
    std::fs::copy(common::data("coins.png"), dir.join("coins.png")).unwrap();
    std::fs::copy(common::data("text.png"), dir.join("text.png")).unwrap();
    std::fs::copy(common::data("camera_cc0_v0.18plus.png"), dir.join("sub/camera.png")).unwrap();
    let png = std::fs::read(common::data("coins.png")).unwrap();
    std::fs::write(dir.join("trunc.png"), &png[..png.len() / 3]).unwrap();
    std::fs::write(dir.join("x.png"), "this is text, not a PNG\n").unwrap();
    dir
}

#[test]
fn batch_reports_each_failure_and_goes_on_then_skip_existing_finishes() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = inputs(tmp.path());
    let out = tmp.path().join("out");
    let o = lfast(&[&"detect", &dir, &"--out", &out]);
    assert_eq!(o.status.code(), Some(1), "{}", show(&o));
    assert_eq!(summary(&o), (3, 0, 2), "{}", show(&o));
    // one error line per bad file, naming it
    let err = stderr(&o);
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 2, "{err}");
    assert!(lines.iter().any(|l| l.contains("trunc.png")), "{err}");
    assert!(lines.iter().any(|l| l.contains("x.png")), "{err}");
    // outputs exist, parse, and keep the directory structure
    assert_eq!(files(&out), vec!["coins.json", "sub/camera.json", "text.json"]);
    let f = read_features(&out.join("coins.json"));
    let g = lfast::image::load_gray(common::data("coins.png")).unwrap();
    let (kps, desc) =
        lfast::cpu::CpuDetector::new(lfast::Config::default()).unwrap().detect_and_compute(g.view(), None).unwrap();
    assert_eq!(f.keypoints, kps);
    assert_eq!(f.descriptors, desc.iter().map(lfast::io::hex).collect::<Vec<_>>());
    assert_eq!((read_features(&out.join("sub/camera.json")).width, 512), (512, 512));
    let total: usize = ["coins.json", "sub/camera.json", "text.json"]
        .iter()
        .map(|n| read_features(&out.join(n)).keypoints.len())
        .sum();
    assert!(stdout(&o).contains(&format!("; {total} keypoints;")), "{}", show(&o));

    // second run: nothing to do
    let before = std::fs::metadata(out.join("coins.json")).unwrap().modified().unwrap();
    let o = lfast(&[&"detect", &dir, &"--out", &out, &"--skip-existing"]);
    assert_eq!(summary(&o), (0, 3, 2), "{}", show(&o));
    assert_eq!(o.status.code(), Some(1));
    assert_eq!(std::fs::metadata(out.join("coins.json")).unwrap().modified().unwrap(), before);

    // an interrupted run: one output missing, a stale temporary file left
    std::fs::remove_file(out.join("text.json")).unwrap();
    std::fs::write(out.join(".text.json.999999999.tmp"), "partial").unwrap();
    std::fs::remove_file(dir.join("trunc.png")).unwrap();
    std::fs::remove_file(dir.join("x.png")).unwrap();
    let o = lfast(&[&"detect", &dir, &"--out", &out, &"--skip-existing"]);
    assert!(o.status.success(), "{}", show(&o));
    assert_eq!(summary(&o), (1, 2, 0), "{}", show(&o));
    assert_eq!(files(&out), vec!["coins.json", "sub/camera.json", "text.json"], "a temporary file is left");
}

#[test]
fn every_format_is_written_and_parses() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let img = common::data("coins.png");
    let o = lfast(&[
        &"detect",
        &img,
        &"--out",
        &out,
        &"--format",
        &"json,csv",
        &"--format",
        &"npy",
        &"--format",
        &"yaml",
        &"--draw",
    ]);
    assert!(o.status.success(), "{}", show(&o));
    assert_eq!(
        files(&out),
        vec!["coins.csv", "coins.descriptors.npy", "coins.draw.png", "coins.json", "coins.keypoints.npy", "coins.yaml"]
    );
    let f = read_features(&out.join("coins.json"));
    let n = f.keypoints.len();
    assert!(n > 0);

    // npy: magic, version 1.0, header length to a 64-byte boundary, dtype, shape, data size
    let npy = |name: &str, descr: &str, cols: usize, item: usize| -> Vec<u8> {
        let b = std::fs::read(out.join(name)).unwrap();
        assert_eq!(&b[..8], b"\x93NUMPY\x01\x00", "{name}");
        let hlen = u16::from_le_bytes([b[8], b[9]]) as usize;
        assert_eq!((10 + hlen) % 64, 0, "{name}");
        let header = std::str::from_utf8(&b[10..10 + hlen]).unwrap();
        assert!(header.ends_with('\n'));
        assert!(header.contains(&format!("'descr': '{descr}'")), "{header}");
        assert!(header.contains("'fortran_order': False"), "{header}");
        assert!(header.contains(&format!("'shape': ({n}, {cols})")), "{header}");
        assert_eq!(b.len(), 10 + hlen + n * cols * item, "{name}");
        b[10 + hlen..].to_vec()
    };
    let k = npy("coins.keypoints.npy", "<f4", 7, 4);
    let v: Vec<f32> = k.chunks(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect();
    let kp = &f.keypoints[0];
    assert_eq!(&v[..7], &[kp.pt.x, kp.pt.y, kp.size, kp.angle, kp.response, kp.octave as f32, kp.class_id as f32]);
    let d = npy("coins.descriptors.npy", "|u1", 32, 1);
    assert_eq!(lfast::io::hex(&d[..32].try_into().unwrap()), f.descriptors[0]);

    // csv: header + one row per keypoint, same values
    let csv = std::fs::read_to_string(out.join("coins.csv")).unwrap();
    let rows: Vec<&str> = csv.lines().collect();
    assert_eq!(rows[0], "x,y,size,angle,response,octave,class_id,descriptor");
    assert_eq!(rows.len(), n + 1);
    let r: Vec<&str> = rows[1].split(',').collect();
    assert_eq!(r[0].parse::<f32>().unwrap(), kp.pt.x);
    assert_eq!(r[4].parse::<f32>().unwrap(), kp.response);
    assert_eq!(r[7], f.descriptors[0]);

    // yaml: OpenCV FileStorage layout (read back with cv2 by scripts/check_formats.py)
    let y = std::fs::read_to_string(out.join("coins.yaml")).unwrap();
    assert!(y.starts_with("%YAML:1.0\n---\nkeypoints:\n"), "{}", &y[..40]);
    assert_eq!(y.lines().filter(|l| l.starts_with("   - [ ")).count(), n);
    assert!(y.contains(&format!("descriptors: !!opencv-matrix\n   rows: {n}\n   cols: 32\n   dt: u\n   data: [")));

    // the overlay: an RGB image of the input's size
    let draw = image::open(out.join("coins.draw.png")).unwrap();
    assert_eq!((draw.width(), draw.height()), (384, 303));
    assert!(matches!(draw, image::DynamicImage::ImageRgb8(_)));
}

#[test]
fn shards_cover_every_file_exactly_once() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("in");
    std::fs::create_dir_all(&dir).unwrap();
    for i in 0..7 {
        let src = ["coins.png", "text.png", "camera_cc0_v0.18plus.png"][i % 3];
        std::fs::copy(common::data(src), dir.join(format!("f{i}.png"))).unwrap();
    }
    let out = tmp.path().join("out");
    let mut done = 0;
    let mut seen = Vec::new();
    for k in 0..3 {
        let sub = out.join(format!("s{k}"));
        let o = lfast(&[&"detect", &dir, &"--out", &sub, &"--shard", &format!("{k}/3"), &"--jobs", &"1"]);
        assert!(o.status.success(), "{}", show(&o));
        let (d, s, f) = summary(&o);
        assert_eq!((s, f), (0, 0));
        done += d;
        seen.extend(files(&sub));
    }
    assert_eq!(done, 7);
    seen.sort();
    let want: Vec<String> = (0..7).map(|i| format!("f{i}.json")).collect();
    assert_eq!(seen, want, "every file once over all shards");
    // a bad shard is refused before any work
    for bad in ["3/3", "0/0", "1"] {
        let o = lfast(&[&"detect", &dir, &"--out", &out, &"--shard", &bad]);
        assert_eq!(o.status.code(), Some(2), "{bad}: {}", show(&o));
    }
}

#[test]
fn unwritable_output_directory_fails_before_any_work() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = inputs(tmp.path());
    let file = tmp.path().join("a_file");
    std::fs::write(&file, "not a directory").unwrap();
    for out in [file.clone(), file.join("below")] {
        let o = lfast(&[&"detect", &dir, &"--out", &out]);
        assert_eq!(o.status.code(), Some(2), "{}", show(&o));
        assert_eq!(stdout(&o), "", "work was done: {}", show(&o));
        let err = stderr(&o);
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(err.contains("a_file"), "{err}");
    }
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "not a directory");
}

#[test]
fn backends_and_adapters() {
    let tmp = tempfile::tempdir().unwrap();
    let img = common::data("text.png");
    let out = tmp.path().join("out");
    // an adapter that does not exist: --backend gpu stops before any work
    let o = lfast(&[&"detect", &img, &"--out", &out, &"--backend", &"gpu", &"--adapter", &"no-such-adapter"]);
    assert_eq!(o.status.code(), Some(2), "{}", show(&o));
    assert!(stderr(&o).contains("no GPU adapter") && stderr(&o).contains("no-such-adapter"), "{}", show(&o));
    assert!(!out.join("text.json").exists());
    let o = lfast(&[&"edges", &img, &"--out", &out, &"--backend", &"gpu", &"--adapter", &"no-such-adapter"]);
    assert_eq!(o.status.code(), Some(2), "{}", show(&o));
    // ... and --backend auto falls back to the CPU with a note
    let o = lfast(&[&"detect", &img, &"--out", &out, &"--adapter", &"no-such-adapter"]);
    assert!(o.status.success(), "{}", show(&o));
    assert!(stdout(&o).contains("backend cpu") && stderr(&o).contains("running on the CPU"), "{}", show(&o));
    // the baselines are CPU-only
    let o = lfast(&[&"detect", &img, &"--out", &out, &"--backend", &"gpu", &"--detector", &"fast"]);
    assert_eq!(o.status.code(), Some(2), "{}", show(&o));
    assert!(stderr(&o).contains("CPU only"), "{}", show(&o));

    let cpu_out = tmp.path().join("cpu");
    let o = lfast(&[&"detect", &img, &"--out", &cpu_out, &"--backend", &"cpu"]);
    assert!(o.status.success(), "{}", show(&o));
    assert!(stdout(&o).contains("backend cpu"), "{}", show(&o));
    let o = lfast(&[&"detect", &img, &"--out", &out, &"--backend", &"cpu", &"--adapter", &"llvmpipe"]);
    assert_eq!(o.status.code(), Some(2), "{}", show(&o));
    assert!(stderr(&o).contains("--adapter"));
    let o = lfast(&[&"detect", &img, &"--out", &out, &"--backend", &"quantum"]);
    assert!(!o.status.success());

    let o = lfast(&[&"info"]);
    assert!(o.status.success(), "{}", show(&o));
    let s = stdout(&o);
    assert!(s.contains("GPU adapters found") && s.contains("rayon threads") && s.contains("avx2"), "{s}");
    assert!(s.contains("CPU kernels: the "), "{s}");
    // LFAST_SIMD caps the kernels' build; a value it does not know is named and ignored
    for (v, want) in [
        ("baseline", "CPU kernels: the baseline build, of "),
        ("avx3", "(LFAST_SIMD=avx3 is not baseline, avx2 or avx512: ignored)"),
    ] {
        let o = common::command(&[&"info"], &[("LFAST_SIMD", v)]).output().expect("the lfast binary runs");
        assert!(o.status.success() && stdout(&o).contains(want), "LFAST_SIMD={v}: {}", show(&o));
    }
    // --size: the workspace of each size, computed without a GPU; a size that does not fit
    // wgpu's defaults names the limit; a malformed size is a usage error
    let o = lfast(&[&"info", &"--size", &"1241x376,4000x3000"]);
    assert!(o.status.success(), "{}", show(&o));
    let s = stdout(&o);
    for part in [
        "GPU workspace for 1241x376: ",
        "bytes per pixel), largest buffer `",
        "GPU workspace for 4000x3000: ",
        "does not fit: GPU limits: a 4000x3000 frame needs storage buffers of 148596868 bytes",
    ] {
        assert!(s.contains(part), "{part} not in {s}");
    }
    let o = lfast(&[&"info", &"--size", &"1241by376"]);
    assert_eq!(o.status.code(), Some(2), "{}", show(&o));
    assert!(stderr(&o).contains("`1241by376` is not a frame size WxH"), "{}", show(&o));

    // with a GPU (lavapipe in CI, where REQUIRE_GPU=1 makes its absence a failure):
    // the GPU backend writes the same features as the CPU
    if lfast::testing::context().is_none() {
        return;
    }
    assert!(s.contains("--backend gpu opens: ") && s.contains("--backend auto uses: gpu on"), "{s}");
    let gpu_out = tmp.path().join("gpu");
    let o = lfast(&[&"detect", &img, &"--out", &gpu_out, &"--backend", &"gpu"]);
    assert!(o.status.success(), "{}", show(&o));
    assert!(stdout(&o).contains("backend gpu"), "{}", show(&o));
    let read = |d: &std::path::Path| std::fs::read_to_string(d.join("text.json")).unwrap();
    assert_eq!(read(&gpu_out), read(&cpu_out), "GPU and CPU features differ");
    let (ge, ce) = (tmp.path().join("g.png"), tmp.path().join("c.png"));
    assert!(lfast(&[&"edges", &img, &"--out", &ge, &"--backend", &"gpu"]).status.success());
    assert!(lfast(&[&"edges", &img, &"--out", &ce, &"--backend", &"cpu"]).status.success());
    assert_eq!(std::fs::read(&ge).unwrap(), std::fs::read(&ce).unwrap(), "GPU and CPU edge maps differ");
}

#[test]
fn globs_list_files_and_stdin() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = inputs(tmp.path());
    // a glob (quoted, so the shell does not expand it): the top-level PNGs
    let pat = format!("{}/c*.png", dir.display());
    let pat2 = format!("{}/[t]e?t.png", dir.display());
    let out = tmp.path().join("glob");
    let o = lfast(&[&"detect", &pat, &pat2, &"--out", &out]);
    assert!(o.status.success(), "{}", show(&o));
    assert_eq!(files(&out), vec!["coins.json", "text.json"]);
    let o = lfast(&[&"detect", &format!("{}/zz*.png", dir.display()), &"--out", &out]);
    assert_eq!(o.status.code(), Some(2), "a glob that matches nothing: {}", show(&o));

    // a list file with a comment, a blank line and a missing file
    let list = tmp.path().join("list.txt");
    let missing = dir.join("gone.png");
    std::fs::write(
        &list,
        format!(
            "# frames\n{}\n\n{}\n{}\n",
            dir.join("coins.png").display(),
            dir.join("sub/camera.png").display(),
            missing.display()
        ),
    )
    .unwrap();
    let out = tmp.path().join("list");
    let o = lfast(&[&"detect", &"--from-list", &list, &"--out", &out]);
    assert_eq!(summary(&o), (2, 0, 1), "{}", show(&o));
    assert!(stderr(&o).contains("gone.png"), "{}", show(&o));
    assert_eq!(files(&out), vec!["camera.json", "coins.json"]);

    // the list on standard input
    let out = tmp.path().join("stdin");
    let mut child = Command::new(env!("CARGO_BIN_EXE_lfast"))
        .args([OsStr::new("detect"), OsStr::new("--from-list"), OsStr::new("-"), OsStr::new("--out"), out.as_os_str()])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    writeln!(child.stdin.take().unwrap(), "{}", dir.join("text.png").display()).unwrap();
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success(), "{}", show(&o));
    assert_eq!(files(&out), vec!["text.json"]);

    // two inputs with one output name: the second fails, the first is written
    let other = tmp.path().join("other");
    std::fs::create_dir_all(&other).unwrap();
    std::fs::copy(common::data("text.png"), other.join("coins.png")).unwrap();
    let out = tmp.path().join("clash");
    let o = lfast(&[&"detect", &dir.join("coins.png"), &other.join("coins.png"), &"--out", &out]);
    assert_eq!(o.status.code(), Some(1), "{}", show(&o));
    assert_eq!(summary(&o), (1, 0, 1));
    assert!(stderr(&o).contains("already used"), "{}", show(&o));

    // no inputs at all
    let o = lfast(&[&"detect", &"--out", &out]);
    assert_eq!(o.status.code(), Some(2), "{}", show(&o));
}

#[test]
fn decoding_limits_reject_huge_images() {
    let tmp = tempfile::tempdir().unwrap();
    // a small file whose image is wider than lfast::image::MAX_SIDE
    let wide = tmp.path().join("wide.png");
    image::GrayImage::new(lfast::image::MAX_SIDE + 1, 1).save(&wide).unwrap();
    assert!(std::fs::metadata(&wide).unwrap().len() < 10_000);
    let good = common::data("text.png");
    let out = tmp.path().join("out");
    let o = lfast(&[&"detect", &wide, &good, &"--out", &out, &"--quiet"]);
    assert_eq!(o.status.code(), Some(1), "{}", show(&o));
    assert_eq!(summary(&o), (1, 0, 1));
    let err = stderr(&o);
    assert!(err.contains("wide.png") && err.to_lowercase().contains("limit"), "{err}");
    // --quiet: errors and the summary only
    assert_eq!(stdout(&o).lines().count(), 1, "{}", show(&o));
}

#[test]
fn detectors_and_jobs() {
    let tmp = tempfile::tempdir().unwrap();
    let img = common::data("coins.png");
    let g = lfast::image::load_gray(&img).unwrap();
    for (det, jobs) in [("fast", "1"), ("orb", "2"), ("lfast", "1")] {
        let out = tmp.path().join(det);
        let o = lfast(&[&"detect", &img, &"--out", &out, &"--detector", &det, &"--jobs", &jobs, &"--mode", &"paper"]);
        assert!(o.status.success(), "{det}: {}", show(&o));
        let f = read_features(&out.join("coins.json"));
        assert!(!f.keypoints.is_empty() && f.keypoints.len() == f.descriptors.len(), "{det}");
        assert!(stdout(&o).contains(&format!("detector {det}")), "{}", show(&o));
        match det {
            "fast" => assert_eq!(f.keypoints, lfast::baseline::fast::fast9(&g, 20, true)),
            "orb" => {
                let orb = lfast::baseline::orb::OrbDetector::new(Default::default()).unwrap();
                assert_eq!(f.keypoints, orb.detect_and_compute(g.view()).unwrap().0);
            }
            _ => {
                let cfg = lfast::Config { mode: lfast::Mode::Paper, ..Default::default() };
                assert_eq!(f.keypoints, lfast::cpu::CpuDetector::new(cfg).unwrap().detect(g.view(), None).unwrap());
            }
        }
    }
    let o = lfast(&[&"detect", &img, &"--out", &tmp.path().join("x"), &"--jobs", &"0"]);
    assert_eq!(o.status.code(), Some(2), "{}", show(&o));
}

/// `lfast detect --detector orb` builds ORB from the config as `lfast vo
/// --features orb` does (lfast::frontend): `orientation_bins` reaches the
/// descriptors (detect used to ignore it and always bin by 30).
#[test]
fn orb_detector_honours_orientation_bins() {
    use lfast::baseline::orb::{OrbDetector, OrbParams};
    let tmp = tempfile::tempdir().unwrap();
    let img = common::data("coins.png");
    let g = lfast::image::load_gray(&img).unwrap();
    let cfg = lfast::Config { orientation_bins: 0, ..Default::default() };
    let cfg_path = tmp.path().join("continuous.toml");
    std::fs::write(&cfg_path, cfg.to_toml_string()).unwrap();
    let out = tmp.path().join("orb");
    let o =
        lfast(&[&"detect", &img, &"--out", &out, &"--detector", &"orb", &"--backend", &"cpu", &"--config", &cfg_path]);
    assert!(o.status.success(), "{}", show(&o));
    let f = read_features(&out.join("coins.json"));
    let params = OrbParams { orientation_bins: 0, ..OrbParams::default() };
    assert_eq!(lfast::frontend::orb_params(&cfg, 20, 500), params);
    let (kps, desc) = OrbDetector::new(params).unwrap().detect_and_compute(g.view()).unwrap();
    assert!(!kps.is_empty());
    assert_eq!(f.keypoints, kps);
    let hex = |d: &[lfast::Descriptor]| d.iter().map(lfast::io::hex).collect::<Vec<_>>();
    assert_eq!(f.descriptors, hex(&desc), "descriptors of continuous (unbinned) orientation");
    let (_, binned) = OrbDetector::new(OrbParams::default()).unwrap().detect_and_compute(g.view()).unwrap();
    assert_ne!(f.descriptors, hex(&binned), "binned descriptors differ, so the test tells the two apart");
}

#[test]
fn edges_batch_with_debug_images() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = inputs(tmp.path());
    let out = tmp.path().join("edges");
    let o = lfast(&[&"edges", &dir, &"--out", &out, &"--debug"]);
    assert_eq!(o.status.code(), Some(1), "{}", show(&o));
    assert_eq!(summary(&o), (3, 0, 2), "{}", show(&o));
    let got = files(&out);
    for stem in ["coins", "text", "sub/camera"] {
        for kind in ["edges", "denoised", "magnitude", "classes", "threshold"] {
            assert!(got.contains(&format!("{stem}.{kind}.png")), "{stem}.{kind}.png missing: {got:?}");
        }
    }
    let g = lfast::image::load_gray(dir.join("coins.png")).unwrap();
    let det = lfast::cpu::CpuDetector::new(lfast::Config::default()).unwrap();
    let em = det.edges(g.view()).unwrap();
    assert_eq!(image::open(out.join("coins.edges.png")).unwrap().to_luma8().as_raw(), &em.edges.data);
    assert_eq!(image::open(out.join("coins.denoised.png")).unwrap().to_luma8().as_raw(), &em.denoised.data);
    assert_eq!(
        image::open(out.join("coins.threshold.png")).unwrap().to_luma8().as_raw(),
        &em.local_threshold_map(35).data
    );
    assert!(matches!(image::open(out.join("coins.classes.png")).unwrap(), image::DynamicImage::ImageRgb8(_)));
    // without --debug: the edge maps only
    let out2 = tmp.path().join("plain");
    let o = lfast(&[&"edges", &dir.join("coins.png"), &dir.join("text.png"), &"--out", &out2]);
    assert!(o.status.success(), "{}", show(&o));
    assert_eq!(files(&out2), vec!["coins.edges.png", "text.edges.png"]);
}
