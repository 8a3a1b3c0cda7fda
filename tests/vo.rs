//! Visual odometry and ATE end to end: `lfast ate` against evo's numbers
//! (tests/data/ate), `lfast vo` on the first KITTI frames with a bounded
//! ATE, the GPU path giving the CPU's trajectory, and the input errors.
mod common;

use common::{data, lfast, shared, stderr, stdout};
use lfast::vo::ate::{Align, ate};
use lfast::vo::kitti::read_poses;
use lfast::vo::{FrontEnd, VoOptions, run_sequence, run_suite};
use std::path::Path;

const SEQ: &str = "kitti/seq01_000000-000050";

fn expected() -> serde_json::Value {
    let text = std::fs::read_to_string(data("ate/expected.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

const STATS: [&str; 7] = ["rmse", "mean", "median", "std", "min", "max", "sse"];

#[test]
fn ate_equals_evo_on_the_stored_vector() {
    let gt = read_poses(&data("ate/gt.txt")).unwrap();
    let est = read_poses(&data("ate/est.txt")).unwrap();
    assert_eq!((gt.len(), est.len()), (20, 20));
    let want = expected();
    for (name, align) in [("none", Align::None), ("se3", Align::Se3), ("sim3", Align::Sim3)] {
        let a = ate(&gt, &est, align).unwrap();
        let got = serde_json::to_value(a.stats).unwrap();
        for k in STATS {
            let (g, w) = (got[k].as_f64().unwrap(), want[name][k].as_f64().unwrap());
            assert!((g - w).abs() < 1e-9, "{name} {k}: ours {g}, evo {w}");
        }
    }
}

#[test]
fn ate_cli_prints_evo_numbers() {
    let (gt, est) = (data("ate/gt.txt"), data("ate/est.txt"));
    let want = expected();
    for align in ["none", "se3", "sim3"] {
        let o = lfast(&[&"ate", &gt, &est, &"--align", &align, &"--json"]);
        assert!(o.status.success(), "{}", stderr(&o));
        let j: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
        assert_eq!(j["poses"], 20);
        for k in STATS {
            let (g, w) = (j["stats"][k].as_f64().unwrap(), want[align][k].as_f64().unwrap());
            assert!((g - w).abs() < 1e-9, "{align} {k}: ours {g}, evo {w}");
        }
    }
    // the table, as evo prints it (6 decimals)
    let o = lfast(&[&"ate", &gt, &est, &"--align", &"sim3"]);
    let out = stdout(&o);
    let rmse = want["sim3"]["rmse"].as_f64().unwrap();
    assert!(out.contains(&format!("rmse {rmse:.6}")), "{out}");
    assert!(out.contains("scale "), "{out}");
}

#[test]
fn ate_cli_rejects_bad_input_with_a_reason() {
    let dir = tempfile::tempdir().unwrap();
    let short = dir.path().join("short.txt");
    let text = std::fs::read_to_string(data("ate/gt.txt")).unwrap();
    std::fs::write(&short, text.lines().take(5).collect::<Vec<_>>().join("\n")).unwrap();
    let o = lfast(&[&"ate", &data("ate/gt.txt"), &short]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("20 poses and the estimate 5"), "{}", stderr(&o));
    let bad = dir.path().join("bad.txt");
    std::fs::write(&bad, "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 x 0 1 0 0 0 0 1 0\n").unwrap();
    let o = lfast(&[&"ate", &bad, &bad]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("bad.txt, line 2: `x` is not a number"), "{}", stderr(&o));
    // a straight line cannot be aligned (rank-1 covariance), as evo refuses too
    let line = dir.path().join("line.txt");
    let rows: Vec<String> = (0..5).map(|i| format!("1 0 0 0 0 1 0 0 0 0 1 {i}")).collect();
    std::fs::write(&line, rows.join("\n")).unwrap();
    let o = lfast(&[&"ate", &line, &line, &"--align", &"se3"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("degenerate"), "{}", stderr(&o));
    let o = lfast(&[&"ate", &line, &line, &"--align", &"none"]);
    assert!(o.status.success() && stdout(&o).contains("rmse 0.000000"), "{}", stdout(&o));
}

/// Sum of the ground-truth step lengths.
fn path_length(gt: &[lfast::vo::Pose]) -> f64 {
    gt.windows(2).map(|w| (w[1].translation - w[0].translation).norm()).sum()
}

#[test]
fn vo_on_the_first_10_kitti_frames_has_a_bounded_ate() {
    let Some(seq) = shared(SEQ) else { return };
    let out = tempfile::tempdir().unwrap();
    let o = lfast(&[
        &"vo",
        &seq,
        &"--features",
        &"lfast,fast,orb",
        &"--frames",
        &"10",
        &"--backend",
        &"cpu",
        &"--out",
        &out.path(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let gt = read_poses(&seq.join("poses.txt")).unwrap();
    let travelled = path_length(&gt[..10]);
    assert!(travelled > 8.0, "{travelled}");
    for f in ["lfast", "fast", "orb"] {
        let d = out.path().join(f);
        for file in
            ["trajectory.txt", "gt.txt", "times.csv", "errors.csv", "summary.json", "trajectory.png", "error_cdf.png"]
        {
            assert!(d.join(file).is_file(), "{f}/{file} missing");
        }
        let est = read_poses(&d.join("trajectory.txt")).unwrap();
        assert_eq!(est.len(), 10);
        // first pose = ground truth's, every step as long as the ground truth's (the protocol)
        assert!((est[0].translation - gt[0].translation).norm() < 1e-9);
        for i in 1..10 {
            let (a, b) = (
                (est[i].translation - est[i - 1].translation).norm(),
                (gt[i].translation - gt[i - 1].translation).norm(),
            );
            assert!((a - b).abs() < 1e-6, "{f} step {i}: {a} vs {b}");
        }
        let s: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(d.join("summary.json")).unwrap()).unwrap();
        let rmse = s["ate_se3"]["stats"]["rmse"].as_f64().unwrap();
        // a camera standing still would be off by metres; a tracked one by centimetres
        assert!(rmse < 0.05 * travelled, "{f}: ATE RMSE {rmse} m over {travelled} m");
        assert_eq!(s["lost_frames"], 0, "{f}");
        assert_eq!(s["frames"], 10);
        // the stored ATE is `lfast ate` on the files written
        let a = ate(&read_poses(&d.join("gt.txt")).unwrap(), &est, Align::Se3).unwrap();
        assert!((a.stats.rmse - rmse).abs() < 1e-6);
        let times = std::fs::read_to_string(d.join("times.csv")).unwrap();
        assert_eq!(times.lines().count(), 11);
        assert!(times.starts_with("frame,name,load_ms,detect_ms,match_ms,pose_ms,total_ms,"));
    }
    let suite = std::fs::read_to_string(out.path().join("suite.md")).unwrap();
    assert_eq!(suite.lines().count(), 5, "{suite}");
    assert!(suite.lines().nth(2).unwrap().starts_with("| lfast | 10 |"), "{suite}");
}

#[test]
fn gpu_vo_gives_the_cpu_trajectory() {
    let Some(seq) = shared(SEQ) else { return };
    let Some(_) = lfast::testing::context() else { return };
    let base = VoOptions { frames: Some(3), ..VoOptions::default() };
    let cpu = run_sequence(&seq, &VoOptions { backend: lfast::Backend::Cpu, ..base.clone() }).unwrap();
    let gpu = run_sequence(&seq, &VoOptions { backend: lfast::Backend::Gpu, ..base }).unwrap();
    assert_eq!((gpu.detector_backend, cpu.detector_backend), ("gpu", "cpu"));
    assert_eq!(gpu.matcher_backend, lfast::vo::MatcherBackend::Gpu);
    for (g, c) in gpu.records.iter().zip(&cpu.records) {
        assert_eq!((g.keypoints, g.matches, g.inliers, g.good), (c.keypoints, c.matches, c.inliers, c.good));
    }
    assert_eq!(gpu.poses, cpu.poses, "bit-identical features and matches give the same trajectory");
}

#[test]
fn run_suite_tabulates_every_front_end() {
    let Some(seq) = shared(SEQ) else { return };
    let opts = VoOptions { backend: lfast::Backend::Cpu, frames: Some(4), ..VoOptions::default() };
    let t = run_suite(&seq, &FrontEnd::ALL, &opts, None).unwrap();
    assert_eq!(t.rows.iter().map(|r| r.features).collect::<Vec<_>>(), FrontEnd::ALL);
    for r in &t.rows {
        assert_eq!(r.summary.frames, 4);
        assert!(r.summary.mean_keypoints > 100.0 && r.summary.mean_inliers > 20.0, "{:?}", r.summary);
        assert!(r.summary.ate_se3.is_some() && r.summary.ate_sim3.is_some());
    }
    let md = t.to_markdown();
    assert_eq!(md.lines().count(), 2 + FrontEnd::ALL.len(), "{md}");
    let orb = 2 + FrontEnd::ALL.iter().position(|f| *f == FrontEnd::Orb).unwrap();
    assert!(md.lines().nth(orb).unwrap().starts_with("| orb | 4 |"), "{md}");
}

/// A sequence folder from the bundled CC0 images (not a real motion).
fn fake_sequence(dir: &Path, calib: &str, poses: Option<&str>) {
    std::fs::create_dir_all(dir.join("image_0")).unwrap();
    for (i, name) in ["astronaut_256.png", "coins.png"].iter().enumerate() {
        std::fs::copy(data(name), dir.join(format!("image_0/{i:06}.png"))).unwrap();
    }
    std::fs::write(dir.join("calib.txt"), calib).unwrap();
    if let Some(p) = poses {
        std::fs::write(dir.join("poses.txt"), p).unwrap();
    }
}

#[test]
fn vo_errors_name_the_problem() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    // no image_0
    let o = lfast(&[&"vo", &tmp.path(), &"--out", &out, &"--backend", &"cpu"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("image_0"), "{}", stderr(&o));
    // a calibration without P0
    let seq = tmp.path().join("s1");
    fake_sequence(&seq, "P1: 1 0 0 0 0 1 0 0 0 0 1 0\n", None);
    let o = lfast(&[&"vo", &seq, &"--out", &out, &"--backend", &"cpu"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("calib.txt") && stderr(&o).contains("P0"), "{}", stderr(&o));
    // fewer poses than frames
    let seq = tmp.path().join("s2");
    fake_sequence(&seq, "P0: 200 0 128 0 0 200 128 0 0 0 1 0\n", Some("1 0 0 0 0 1 0 0 0 0 1 0\n"));
    let o = lfast(&[&"vo", &seq, &"--out", &out, &"--backend", &"cpu"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("has 1 poses for 2 frames"), "{}", stderr(&o));
    // bad options
    let o = lfast(&[&"vo", &seq, &"--out", &out, &"--backend", &"cpu", &"--ratio", &"1.5"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("ratio"), "{}", stderr(&o));
    let o = lfast(&[&"vo", &seq, &"--out", &out, &"--backend", &"cpu", &"--frames", &"0"]);
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn vo_without_poses_runs_at_unit_scale() {
    let tmp = tempfile::tempdir().unwrap();
    let seq = tmp.path().join("s");
    fake_sequence(&seq, "200 0 128 0 0 200 128 0 0 0 1 0\n200 0 128 -50 0 200 128 0 0 0 1 0\n", None);
    let out = tmp.path().join("out");
    let o = lfast(&[&"vo", &seq, &"--out", &out, &"--backend", &"cpu", &"--features", &"orb"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("no ground truth"), "{}", stdout(&o));
    let est = read_poses(&out.join("trajectory.txt")).unwrap();
    assert_eq!(est.len(), 2);
    assert_eq!(est[0], lfast::vo::Pose::identity());
    // two unrelated images: the pair is lost or tracked, but a step is at most one unit
    assert!(est[1].translation.norm() <= 1.0 + 1e-9);
    assert!(
        out.join("trajectory.png").is_file() && !out.join("error_cdf.png").exists() && !out.join("gt.txt").exists()
    );
}
