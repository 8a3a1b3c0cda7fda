//! Issue 8, the command-line side: every kind of bad input file in one batch,
//! the memory used to refuse a huge PNG header, a frame over the GPU's limits
//! run on the CPU with a warning, bad config values, byte-identical outputs
//! across --jobs / RAYON_NUM_THREADS / backends, and SIGINT / SIGKILL in the
//! middle of a batch followed by a --skip-existing rerun. docs/reliability.md
//! lists each case with its test.

mod common;

use common::{command, files, lfast, read_features, show, stderr, stdout, summary};
use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// A decoder seed kept for the fuzzer: the file without its first byte (which
/// only picks the fuzzer's file name extension).
fn seed_file(name: &str) -> Vec<u8> {
    std::fs::read(common::data("regress/decode_detect").join(format!("seed-{name}"))).unwrap()[1..].to_vec()
}

// ------------------------------------------------------------ input files

#[test]
fn one_batch_with_every_format_and_every_broken_input() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("in");
    std::fs::create_dir_all(dir.join("frame.png")).unwrap();
    // (file name, seed): output names must differ, so no two share a stem
    let good = [
        ("gray8.png", "gray8.png"),
        ("gray16.png", "gray16.png"),
        ("rgb.png", "rgb.png"),
        ("rgba.png", "rgba.png"),
        ("la.png", "la.png"),
        ("palette.png", "palette.png"),
        ("gray_jpg.jpg", "gray.jpg"),
        ("rgb_jpeg.jpeg", "rgb.jpeg"),
        ("gray_tif.tif", "gray.tif"),
        ("rgb_bmp.bmp", "rgb.bmp"),
        ("gray_pgm.pgm", "gray.pgm"),
        ("rgb_ppm.ppm", "rgb.ppm"),
    ];
    for (name, seed) in good {
        std::fs::write(dir.join(name), seed_file(seed)).unwrap();
    }
    // a directory named like an image is a directory: searched, not decoded
    std::fs::write(dir.join("frame.png/inner.png"), seed_file("rgb.png")).unwrap();
    let png = seed_file("gray8.png");
    std::fs::write(dir.join("truncated_png.png"), &png[..png.len() / 2]).unwrap();
    let jpg = seed_file("rgb.jpeg");
    std::fs::write(dir.join("truncated_jpg.jpg"), &jpg[..200]).unwrap();
    std::fs::write(dir.join("empty.png"), b"").unwrap();
    std::fs::write(dir.join("notes.png"), "this is text\n").unwrap();
    let mut bad = vec!["truncated_png.png", "truncated_jpg.jpg", "empty.png", "notes.png"];
    #[cfg(target_os = "linux")]
    {
        // opens, but every read fails (EIO), even for root
        std::os::unix::fs::symlink("/proc/self/mem", dir.join("unreadable.png")).unwrap();
        bad.push("unreadable.png");
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let locked = dir.join("locked.png");
        std::fs::write(&locked, &png).unwrap();
        std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o000)).unwrap();
        if std::fs::File::open(&locked).is_err() {
            bad.push("locked.png");
        } else {
            // root (as in CI): mode 000 does not deny reads, the file is processed
            eprintln!("note: privileged: mode 000 does not deny reads; unreadable.png covers the case");
        }
    }
    let missing = tmp.path().join("missing.png");
    let out = tmp.path().join("out");
    let o = lfast(&[&"detect", &dir, &missing, &"--out", &out, &"--backend", &"cpu", &"--format", &"json,npy"]);
    assert_eq!(o.status.code(), Some(1), "{}", show(&o));
    let n_good = good.len() as u64 + 1 + (!bad.contains(&"locked.png")) as u64;
    assert_eq!(summary(&o), (n_good, 0, bad.len() as u64 + 1), "{}", show(&o));
    let err = stderr(&o);
    for name in bad.iter().chain(&["missing.png"]) {
        let lines: Vec<&str> = err.lines().filter(|l| l.contains(name)).collect();
        assert_eq!(lines.len(), 1, "one line naming {name}:\n{err}");
    }
    assert_eq!(err.lines().count(), bad.len() + 1, "{err}");
    // every good file's features equal the library's on the same file
    let det = lfast::cpu::CpuDetector::new(lfast::Config::default()).unwrap();
    for name in good.iter().map(|n| n.0.to_string()).chain(["frame.png/inner.png".to_string()]) {
        let stem = name.rsplit_once('.').unwrap().0;
        let f = read_features(&out.join(format!("{stem}.json")));
        let g = lfast::image::load_gray(dir.join(&name)).unwrap();
        assert_eq!((f.width, f.height), (40, 36), "{name}");
        assert_eq!(f.keypoints, det.detect(g.view(), None).unwrap(), "{name}");
        assert!(out.join(format!("{stem}.keypoints.npy")).is_file());
    }
    for name in &bad {
        let stem = name.rsplit_once('.').unwrap().0;
        assert!(!out.join(format!("{stem}.json")).exists(), "{name}");
    }
}

/// Runs `cmd` and returns its output and peak resident memory in KiB.
#[cfg(unix)]
#[allow(clippy::zombie_processes)] // reaped by libc::wait4 below, which also reports the peak memory
fn run_measuring_memory(mut cmd: Command) -> (std::process::ExitStatus, String, i64) {
    use std::io::Read;
    use std::os::unix::process::ExitStatusExt;
    let mut child = cmd.stdout(Stdio::null()).stderr(Stdio::piped()).spawn().unwrap();
    let mut err = String::new();
    child.stderr.take().unwrap().read_to_string(&mut err).unwrap();
    let mut status = 0;
    // SAFETY: a zeroed rusage is a valid out-parameter; the pid is our child's.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let pid = unsafe { libc::wait4(child.id() as libc::pid_t, &mut status, 0, &mut usage) };
    assert_eq!(pid, child.id() as libc::pid_t, "wait4");
    (std::process::ExitStatus::from_raw(status), err, usage.ru_maxrss)
}

#[cfg(unix)]
#[test]
fn a_png_declaring_65535x65535_is_refused_without_a_large_allocation() {
    let tmp = tempfile::tempdir().unwrap();
    // signature, IHDR 65535 x 65535 8-bit gray, no data: 33 bytes
    let mut ihdr = b"IHDR".to_vec();
    ihdr.extend(65535u32.to_be_bytes());
    ihdr.extend(65535u32.to_be_bytes());
    ihdr.extend([8, 0, 0, 0, 0]);
    let crc = {
        let mut c = !0u32;
        for &b in &ihdr {
            c ^= b as u32;
            for _ in 0..8 {
                c = if c & 1 != 0 { 0xEDB8_8320 ^ (c >> 1) } else { c >> 1 };
            }
        }
        !c
    };
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    png.extend(13u32.to_be_bytes());
    png.extend(&ihdr);
    png.extend(crc.to_be_bytes());
    let huge = tmp.path().join("huge.png");
    std::fs::write(&huge, &png).unwrap();
    let good = tmp.path().join("good.png");
    std::fs::write(&good, seed_file("gray8.png")).unwrap();
    let out = tmp.path().join("out");
    let cmd = command(&[&"detect", &huge, &good, &"--out", &out, &"--backend", &"cpu", &"--jobs", &"1"], &[]);
    let (status, err, peak_kib) = run_measuring_memory(cmd);
    assert_eq!(status.code(), Some(1), "{err}");
    assert!(err.contains("huge.png") && err.to_lowercase().contains("limit"), "{err}");
    assert!(out.join("good.json").is_file());
    // 65535^2 gray pixels would be 4 GiB; refusing them from the header takes
    // no more than the process's usual few tens of MiB
    eprintln!("peak resident memory: {} MiB", peak_kib / 1024);
    assert!(peak_kib < 256 * 1024, "peak resident memory {peak_kib} KiB");
}

// ----------------------------------------------------------------- limits

#[test]
fn a_frame_over_the_gpu_limits_runs_on_the_cpu_with_a_warning() {
    let Some(ctx) = lfast::testing::context() else {
        return;
    };
    // One keypoint slot per pixel (no corner NMS, smallest border): the
    // smallest square frame whose slots exceed the storage binding limit.
    let cfg = lfast::Config { nms_radius: 0, border: 7, n_features: 300, ..Default::default() };
    let lim = ctx.device.limits();
    let limit = lim.max_storage_buffer_binding_size.min(lim.max_buffer_size);
    let over = |s: u32| {
        let l = lfast::gpu::FrameLayout::new(&cfg, s, s);
        l.capacity as u64 * 48 > limit || l.total_px as u64 * 4 > limit
    };
    let Some(side) = (64..=2048u32).step_by(64).find(|&s| over(s)) else {
        eprintln!("NOT RUN: storage bindings of {limit} bytes hold every frame up to 2048x2048 on this device");
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let toml = tmp.path().join("cfg.toml");
    std::fs::write(&toml, "nms_radius = 0\nborder = 7\nn_features = 300\n").unwrap();
    let big = lfast::testing::test_image(side, side, 5);
    let small = lfast::testing::test_image(150, 100, 5);
    lfast::image::save_gray(&big, tmp.path().join("big.png")).unwrap();
    lfast::image::save_gray(&small, tmp.path().join("small.png")).unwrap();
    let cpu = lfast::cpu::CpuDetector::new(cfg.clone()).unwrap();
    let out = tmp.path().join("out");
    let ins = [tmp.path().join("big.png"), tmp.path().join("small.png")];
    let o = lfast(&[&"detect", &ins[0], &ins[1], &"--out", &out, &"--config", &toml, &"--backend", &"auto"]);
    assert!(o.status.success(), "{}", show(&o));
    assert!(stdout(&o).contains("backend gpu"), "{}", show(&o));
    let err = stderr(&o);
    let warn: Vec<&str> = err.lines().filter(|l| l.starts_with("lfast: warning:")).collect();
    assert_eq!(warn.len(), 1, "one warning, for the big frame:\n{err}");
    assert!(warn[0].contains("runs on the CPU") && warn[0].contains(&format!("{side}x{side}")), "{}", warn[0]);
    assert!(!err.contains("panicked") && !err.contains("Validation"), "{err}");
    for (name, img) in [("big", &big), ("small", &small)] {
        let f = read_features(&out.join(format!("{name}.json")));
        assert_eq!(f.keypoints, cpu.detect(img.view(), None).unwrap(), "{name}");
    }
    // --backend gpu: the big frame is a per-file error naming the limit, the small one is done
    let out2 = tmp.path().join("out2");
    let o = lfast(&[&"detect", &ins[0], &ins[1], &"--out", &out2, &"--config", &toml, &"--backend", &"gpu"]);
    assert_eq!(o.status.code(), Some(1), "{}", show(&o));
    assert_eq!(summary(&o), (1, 0, 1));
    assert!(stderr(&o).contains("big.png") && stderr(&o).contains("GPU limits"), "{}", show(&o));
    // --quiet: no warning
    let o = lfast(&[&"detect", &ins[0], &"--out", &out2, &"--config", &toml, &"--quiet"]);
    assert!(o.status.success() && stderr(&o).is_empty(), "{}", show(&o));
}

// ----------------------------------------------------------------- config

#[test]
fn nan_infinite_negative_and_zero_options_fail_before_any_work() {
    let tmp = tempfile::tempdir().unwrap();
    let img = common::data("text.png");
    let out = tmp.path().join("out");
    for (flag, value, field) in [
        ("--scale-factor", "nan", "scale_factor"),
        ("--scale-factor", "NaN", "scale_factor"),
        ("--scale-factor", "inf", "scale_factor"),
        ("--scale-factor", "-inf", "scale_factor"),
        ("--scale-factor", "-1.2", "scale_factor"),
        ("--scale-factor", "0", "scale_factor"),
        ("--n-levels", "0", "n_levels"),
        ("--n-levels", "33", "n_levels"),
        ("--alpha-pct", "100", "alpha_pct"),
    ] {
        let arg = format!("{flag}={value}");
        for cmd in ["detect", "edges"] {
            let o = lfast(&[&cmd, &img, &"--out", &out, &arg]);
            assert_eq!(o.status.code(), Some(2), "{cmd} {arg}: {}", show(&o));
            assert!(stderr(&o).contains(field), "{cmd} {arg}: {}", show(&o));
        }
    }
    // negative integers are refused by the parser, naming the option
    let o = lfast(&[&"detect", &img, &"--out", &out, &"--n-levels=-1"]);
    assert_eq!(o.status.code(), Some(2), "{}", show(&o));
    assert!(stderr(&o).contains("--n-levels"), "{}", show(&o));
    // a config file with NaN / infinity
    let toml = tmp.path().join("bad.toml");
    for (text, field) in
        [("delta = nan\n", "delta"), ("scale_factor = inf\n", "scale_factor"), ("delta = -0.5\n", "delta")]
    {
        std::fs::write(&toml, text).unwrap();
        let o = lfast(&[&"detect", &img, &"--out", &out, &"--config", &toml]);
        assert_eq!(o.status.code(), Some(2), "{text}: {}", show(&o));
        assert!(stderr(&o).contains(field), "{text}: {}", show(&o));
    }
    assert!(files(&out).iter().all(|f| !f.ends_with(".json")), "{:?}", files(&out));
}

// ------------------------------------------------------------ determinism

#[test]
fn outputs_are_byte_identical_across_jobs_threads_and_backends() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("in");
    std::fs::create_dir(&dir).unwrap();
    for name in ["coins.png", "text.png", "astronaut_256.png", "camera_cc0_v0.18plus.png"] {
        std::fs::copy(common::data(name), dir.join(name)).unwrap();
    }
    let gpu = lfast::testing::context().is_some();
    type Run<'a> = (&'a str, Vec<&'a str>, Vec<(&'a str, &'a str)>);
    let runs: Vec<Run> = vec![
        ("jobs1", vec!["--backend", "cpu", "--jobs", "1"], vec![]),
        ("jobs2", vec!["--backend", "cpu", "--jobs", "2"], vec![]),
        ("jobs2-again", vec!["--backend", "cpu", "--jobs", "2"], vec![]),
        ("jobs7", vec!["--backend", "cpu", "--jobs", "7"], vec![]),
        ("rayon1", vec!["--backend", "cpu"], vec![("RAYON_NUM_THREADS", "1")]),
        ("rayon3", vec!["--backend", "cpu"], vec![("RAYON_NUM_THREADS", "3")]),
        ("gpu", vec!["--backend", "gpu"], vec![]),
        ("gpu-jobs1", vec!["--backend", "gpu", "--jobs", "1"], vec![]),
    ];
    type Outputs = (String, Vec<(String, Vec<u8>)>);
    let mut reference: Option<Outputs> = None;
    for (name, flags, env) in runs {
        if name.starts_with("gpu") && !gpu {
            continue;
        }
        let out = tmp.path().join(name);
        let mut args: Vec<&dyn AsRef<OsStr>> = vec![&"detect", &dir, &"--out", &out, &"--format", &"json,csv,npy,yaml"];
        for f in &flags {
            args.push(f);
        }
        let o = command(&args, &env).output().unwrap();
        assert!(o.status.success(), "{name}: {}", show(&o));
        let got: Vec<(String, Vec<u8>)> = files(&out)
            .into_iter()
            .map(|f| {
                let b = std::fs::read(out.join(&f)).unwrap();
                (f, b)
            })
            .collect();
        assert_eq!(got.len(), 4 * 5, "{name}: {:?}", got.iter().map(|g| &g.0).collect::<Vec<_>>());
        match &reference {
            None => reference = Some((name.to_string(), got)),
            Some((rname, want)) => {
                for ((f, a), (_, b)) in got.iter().zip(want) {
                    assert!(a == b, "{name} vs {rname}: {f} differs");
                }
            }
        }
    }
}

// ------------------------------------------------------------ interruption

const FORMATS: &str = "json,csv,npy,yaml";

/// A folder of `n` frames (the 256x256 test image, shifted per frame so each
/// has its own keypoints).
fn frames(root: &Path, n: u32) -> PathBuf {
    let dir = root.join("frames");
    std::fs::create_dir_all(&dir).unwrap();
    let base = lfast::image::load_gray(common::data("astronaut_256.png")).unwrap();
    for i in 0..n {
        let mut p = base.clone();
        p.data.rotate_left(i as usize * 7);
        lfast::image::save_gray(&p, dir.join(format!("f{i:03}.png"))).unwrap();
    }
    dir
}

/// Every output (temporary files aside) is complete: JSON parses, CSV has a row per keypoint, the
/// .npy lengths match their headers, the YAML is closed, the overlay decodes.
fn assert_complete(out: &Path) {
    for f in files(out).into_iter().filter(|f| !f.ends_with(".tmp")) {
        let p = out.join(&f);
        let bytes = std::fs::read(&p).unwrap();
        if f.ends_with(".json") {
            let feats = read_features(&p);
            let csv = out.join(f.replace(".json", ".csv"));
            if csv.exists() {
                let rows = std::fs::read_to_string(&csv).unwrap().lines().count();
                assert_eq!(rows, feats.keypoints.len() + 1, "{f}");
            }
        } else if f.ends_with(".npy") {
            let hlen = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
            let header = std::str::from_utf8(&bytes[10..10 + hlen]).unwrap();
            let shape = &header[header.find("'shape': (").unwrap() + 10..];
            let (rows, cols): (usize, usize) = {
                let s = &shape[..shape.find(')').unwrap()];
                let (a, b) = s.split_once(',').unwrap();
                (a.trim().parse().unwrap(), b.trim().parse().unwrap())
            };
            let item = if header.contains("<f4") { 4 } else { 1 };
            assert_eq!(bytes.len(), 10 + hlen + rows * cols * item, "{f}: truncated");
        } else if f.ends_with(".yaml") {
            assert!(bytes.ends_with(b" ]\n") && bytes.starts_with(b"%YAML:1.0"), "{f}: truncated");
        } else if f.ends_with(".png") {
            image::load_from_memory(&bytes).unwrap_or_else(|e| panic!("{f}: {e}"));
        } else if !f.ends_with(".csv") {
            panic!("unexpected file {f}");
        }
    }
}

/// Hidden temporary files left in `out`.
fn temporaries(out: &Path) -> Vec<String> {
    files(out).into_iter().filter(|f| f.ends_with(".tmp")).collect()
}

/// Starts a batch, waits until `after` JSON outputs exist, sends `sig`;
/// returns the process's output, or `None` when it finished first.
#[cfg(unix)]
fn interrupt(dir: &Path, out: &Path, after: usize, sig: libc::c_int) -> Option<Output> {
    let mut child = command(
        &[&"detect", &dir, &"--out", &out, &"--format", &FORMATS, &"--draw", &"--backend", &"cpu", &"--jobs", &"1"],
        &[],
    )
    .stdout(Stdio::piped())
    .stderr(Stdio::piped())
    .spawn()
    .unwrap();
    let start = Instant::now();
    loop {
        if child.try_wait().unwrap().is_some() {
            return None;
        }
        if files(out).iter().filter(|f| f.ends_with(".json")).count() >= after {
            break;
        }
        assert!(start.elapsed() < Duration::from_secs(120), "no output after 120 s");
        std::thread::sleep(Duration::from_millis(2));
    }
    // SAFETY: kill() on our own child's pid.
    assert_eq!(unsafe { libc::kill(child.id() as libc::pid_t, sig) }, 0);
    Some(child.wait_with_output().unwrap())
}

#[cfg(unix)]
#[test]
fn sigint_and_sigkill_mid_batch_leave_no_partial_output_and_skip_existing_finishes() {
    use std::os::unix::process::ExitStatusExt;
    let tmp = tempfile::tempdir().unwrap();
    let n = 40;
    let dir = frames(tmp.path(), n);
    // the reference: one uninterrupted run
    let want_dir = tmp.path().join("want");
    let o = lfast(&[&"detect", &dir, &"--out", &want_dir, &"--format", &FORMATS, &"--draw", &"--backend", &"cpu"]);
    assert!(o.status.success(), "{}", show(&o));
    let want = files(&want_dir);
    assert_eq!(want.len(), n as usize * 6);
    for (sig, after) in [(libc::SIGINT, 1), (libc::SIGINT, 4), (libc::SIGKILL, 1), (libc::SIGKILL, 4)] {
        let what = format!("signal {sig} after {after} outputs");
        let out = tmp.path().join(format!("out-{sig}-{after}"));
        let Some(o) = interrupt(&dir, &out, after, sig) else {
            panic!("{what}: the batch of {n} frames finished before the signal");
        };
        assert_eq!(o.status.signal(), Some(sig), "{what}: {}", show(&o));
        let left = files(&out);
        let done = left.iter().filter(|f| f.ends_with(".json")).count();
        assert!(done >= after && done < n as usize, "{what}: {done} of {n} done");
        if sig == libc::SIGINT {
            // stopped between files: a summary, a note, every output of a
            // finished frame renamed into place, no temporary file
            assert!(stdout(&o).contains("summary: done"), "{what}: {}", show(&o));
            assert!(stderr(&o).contains("interrupted"), "{what}: {}", show(&o));
            assert_eq!(temporaries(&out), Vec::<String>::new(), "{what}");
            assert_eq!(left.len() % 6, 0, "{what}: a frame with some of its outputs: {left:?}");
        }
        // SIGKILL may leave a hidden .NAME.PID.tmp; never a partial final file
        assert_complete(&out);
        for f in left.iter().filter(|f| !f.ends_with(".tmp")) {
            assert!(std::fs::read(out.join(f)).unwrap() == std::fs::read(want_dir.join(f)).unwrap(), "{what}: {f}");
        }
        // the rerun skips what is there, does the rest, removes stale temporaries
        let o = lfast(&[
            &"detect",
            &dir,
            &"--out",
            &out,
            &"--format",
            &FORMATS,
            &"--draw",
            &"--backend",
            &"cpu",
            &"--skip-existing",
        ]);
        assert!(o.status.success(), "{what}: {}", show(&o));
        let (d, s, f) = summary(&o);
        assert_eq!((d + s, f), (n as u64, 0), "{what}: {}", show(&o));
        // every frame whose six outputs are all there is skipped (SIGKILL may
        // stop two frames between their files: count whole frames, not files)
        let whole = {
            let mut per = std::collections::HashMap::<&str, usize>::new();
            for f in left.iter().filter(|f| !f.ends_with(".tmp")) {
                *per.entry(f.split('.').next().unwrap_or_default()).or_default() += 1;
            }
            per.values().filter(|&&k| k == 6).count()
        };
        assert!(s as usize >= whole, "{what}: {s} skipped, {whole} frames whole");
        assert_eq!(files(&out), want, "{what}: after the rerun");
        for f in &want {
            assert!(std::fs::read(out.join(f)).unwrap() == std::fs::read(want_dir.join(f)).unwrap(), "{what}: {f}");
        }
    }
}

#[cfg(unix)]
#[test]
fn sigint_stops_lfast_edges_between_files() {
    use std::os::unix::process::ExitStatusExt;
    let tmp = tempfile::tempdir().unwrap();
    let dir = frames(tmp.path(), 30);
    let out = tmp.path().join("edges");
    let mut child = command(&[&"edges", &dir, &"--out", &out, &"--debug", &"--backend", &"cpu", &"--jobs", &"1"], &[])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while files(&out).iter().filter(|f| f.ends_with(".edges.png")).count() < 1 {
        assert!(child.try_wait().unwrap().is_none(), "finished before the signal");
        assert!(start.elapsed() < Duration::from_secs(120));
        std::thread::sleep(Duration::from_millis(2));
    }
    // SAFETY: kill() on our own child's pid.
    unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGINT) };
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.signal(), Some(libc::SIGINT), "{}", show(&o));
    let left = files(&out);
    assert_eq!(temporaries(&out), Vec::<String>::new());
    assert!(!left.is_empty() && left.len() < 30 * 5 && left.len().is_multiple_of(5), "{left:?}");
    for f in &left {
        image::open(out.join(f)).unwrap_or_else(|e| panic!("{f}: {e}"));
    }
}
