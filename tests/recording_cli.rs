//! `lfast detect` / `edges` / `vo` with recordings: the usage errors, files
//! that are not what their name says, and a lossless video made by Debian's
//! `ffmpeg` from a bundled image (its keypoints equal the PNG's). The MCAP
//! tests, with bags written by Python's mcap, mcap-ros2-support and rosbags,
//! are python/tests/test_recordings.py.

mod common;

use common::{files, lfast, read_features, show, stderr, summary};
use std::path::{Path, PathBuf};

#[test]
fn recordings_and_images_go_in_separate_runs_and_recording_options_need_a_recording() {
    let tmp = tempfile::tempdir().unwrap();
    let bag = tmp.path().join("run.mcap");
    std::fs::write(&bag, b"not used").unwrap();
    let img = common::data("coins.png");
    let out = tmp.path().join("out");
    let o = lfast(&[&"detect", &bag, &img, &"--out", &out]);
    assert_eq!(o.status.code(), Some(2), "{}", show(&o));
    assert!(stderr(&o).contains("separate runs") && stderr(&o).contains("run.mcap"), "{}", show(&o));
    for opt in [&["--topic", "/cam"][..], &["--every", "2"], &["--frames", "0..3"], &["--time", "..1"]] {
        let mut args: Vec<&dyn AsRef<std::ffi::OsStr>> = vec![&"detect", &img, &"--out", &out];
        args.extend(opt.iter().map(|s| s as &dyn AsRef<std::ffi::OsStr>));
        let o = lfast(&args);
        assert_eq!(o.status.code(), Some(2), "{opt:?}: {}", show(&o));
        assert!(stderr(&o).contains("recordings"), "{}", show(&o));
    }
    let o = lfast(&[&"detect", &img, &"--out", &out, &"--format", &"mcap"]);
    assert_eq!(o.status.code(), Some(2), "{}", show(&o));
    let o = lfast(&[&"detect", &bag, &"--out", &out, &"--every", &"0"]);
    assert_eq!(o.status.code(), Some(2), "{}", show(&o));
    let o = lfast(&[&"detect", &bag, &"--out", &out, &"--frames", &"5..2"]);
    assert_eq!(o.status.code(), Some(2), "{}", show(&o));
    assert!(stderr(&o).contains("END must be above START"), "{}", show(&o));
}

#[test]
fn a_file_that_is_not_an_mcap_file_or_missing_is_one_error_line() {
    let tmp = tempfile::tempdir().unwrap();
    let text = tmp.path().join("notes.mcap");
    std::fs::write(&text, "a text file named .mcap\n").unwrap();
    let missing = tmp.path().join("missing.mcap");
    let out = tmp.path().join("out");
    for (input, says) in [(&text, "not an MCAP file"), (&missing, "No such file")] {
        let o = lfast(&[&"detect", input, &"--out", &out, &"--backend", &"cpu"]);
        assert_eq!(o.status.code(), Some(1), "{}", show(&o));
        let err = stderr(&o);
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(err.contains(&*input.to_string_lossy()) && err.contains(says), "{err}");
        assert_eq!(summary(&o), (0, 0, 1));
    }
    assert!(files(&out).is_empty(), "{:?}", files(&out));
}

#[test]
fn video_without_ffmpeg_says_what_to_install() {
    let tmp = tempfile::tempdir().unwrap();
    let video = tmp.path().join("clip.mkv");
    std::fs::write(&video, b"\x1a\x45\xdf\xa3 not really").unwrap();
    let out = tmp.path().join("out");
    let o = common::command(&[&"detect", &video, &"--out", &out], &[("PATH", "")]).output().unwrap();
    assert_eq!(o.status.code(), Some(1), "{}", show(&o));
    assert!(
        stderr(&o).contains("needs the `ffprobe` program") && stderr(&o).contains("apt-get install ffmpeg"),
        "{}",
        show(&o)
    );
}

/// Debian's ffmpeg, or `None` (skip) outside CI.
fn ffmpeg() -> Option<PathBuf> {
    let found = std::env::var_os("PATH")
        .and_then(|p| std::env::split_paths(&p).map(|d| d.join("ffmpeg")).find(|f| f.is_file()));
    if found.is_none() {
        if std::env::var_os("CI").is_some() {
            panic!("ffmpeg is missing; CI installs it (apt-get install ffmpeg)");
        }
        eprintln!("skipping: ffmpeg not installed");
    }
    found
}

/// Three frames (a bundled image, its mirror image, itself) as an FFV1 gray video.
fn ffv1(dir: &Path, ffmpeg: &Path) -> (PathBuf, Vec<PathBuf>) {
    let img = lfast::image::load_gray(common::data("coins.png")).unwrap();
    let mirror = common::plane_fn(img.width, img.height, |x, y| img.at(img.width - 1 - x, y));
    let pngs: Vec<PathBuf> = [&img, &mirror, &img]
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let f = dir.join(format!("{i:06}.png"));
            lfast::image::save_gray(p, &f).unwrap();
            f
        })
        .collect();
    let video = dir.join("coins.mkv");
    let st = std::process::Command::new(ffmpeg)
        .args(["-nostdin", "-v", "error", "-y", "-framerate", "25", "-i"])
        .arg(dir.join("%06d.png"))
        .args(["-c:v", "ffv1", "-pix_fmt", "gray"])
        .arg(&video)
        .status()
        .unwrap();
    assert!(st.success());
    (video, pngs)
}

#[test]
fn a_lossless_gray_video_gives_the_keypoints_of_its_frames_as_png_files() {
    let Some(ffmpeg) = ffmpeg() else { return };
    let tmp = tempfile::tempdir().unwrap();
    let (video, pngs) = ffv1(tmp.path(), &ffmpeg);
    let out = tmp.path().join("out");
    let o = lfast(&[&"detect", &video, &"--out", &out, &"--backend", &"cpu", &"--format", &"json,csv"]);
    assert!(o.status.success(), "{}", show(&o));
    assert_eq!(summary(&o), (3, 0, 0), "{}", show(&o));
    let names = ["000000_0", "000001_40000000", "000002_80000000"];
    let mut want = Vec::new();
    for n in names {
        want.push(format!("coins/{n}.csv"));
        want.push(format!("coins/{n}.json"));
    }
    assert_eq!(files(&out), want);
    let det = lfast::cpu::CpuDetector::new(lfast::Config::default()).unwrap();
    for (n, png) in names.iter().zip(&pngs) {
        let f = read_features(&out.join(format!("coins/{n}.json")));
        let (kps, desc) = det.detect_and_compute(lfast::image::load_gray(png).unwrap().view(), None).unwrap();
        assert_eq!(f.keypoints, kps, "{n}");
        assert_eq!(f.descriptors, desc.iter().map(lfast::io::hex).collect::<Vec<_>>(), "{n}");
        assert_eq!(f.image, video.display().to_string());
        let fr = f.frame.expect("a frame of a recording");
        assert_eq!((fr.topic, fr.stamp_ns), (None, None));
    }
    // edges of one frame, chosen by time; vo needs --calib for a video
    let o = lfast(&[&"edges", &video, &"--out", &out, &"--backend", &"cpu", &"--time", &"0.03..0.05"]);
    assert!(o.status.success(), "{}", show(&o));
    assert!(out.join("coins/000001_40000000.edges.png").is_file(), "{:?}", files(&out));
    let o = lfast(&[&"vo", &video, &"--out", &tmp.path().join("vo"), &"--backend", &"cpu"]);
    assert_eq!(o.status.code(), Some(2), "{}", show(&o));
    assert!(stderr(&o).contains("--calib"), "{}", show(&o));
}
