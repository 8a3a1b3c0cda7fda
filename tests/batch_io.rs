//! `lfast detect`'s file handling against what users meet: symbolic-link
//! loops and files reachable twice, a full disk, names with control
//! characters. (The full disk without root, where no tmpfs can be mounted, is
//! `cli::detect::tests::a_full_disk_stops_the_batch_at_the_first_failed_write_and_skip_existing_finishes`,
//! with a writer that fails on cue.)
#![cfg(unix)]

mod common;

use common::{files, lfast, read_features, show, stderr, stdout, summary};
use std::os::unix::fs::symlink;
use std::path::{Path, PathBuf};

/// in/: a.png, b.png, c.png, sub/d.png, sub/e.png, and sub/loop -> ../
fn looped(root: &Path) -> PathBuf {
    let dir = root.join("in");
    std::fs::create_dir_all(dir.join("sub")).unwrap();
    let png = std::fs::read(common::data("chessboard_GRAY.png")).unwrap();
    for f in ["a.png", "b.png", "c.png", "sub/d.png", "sub/e.png"] {
        std::fs::write(dir.join(f), &png).unwrap();
    }
    symlink("../", dir.join("sub/loop")).unwrap();
    dir
}

/// The lines of stdout that report one file (all but the summary).
fn file_lines(o: &std::process::Output) -> Vec<String> {
    stdout(o).lines().filter(|l| !l.starts_with("summary: ")).map(String::from).collect()
}

#[test]
fn a_symlink_loop_is_named_once_and_each_file_is_processed_once() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = looped(tmp.path());
    let out = tmp.path().join("out");
    let o = lfast(&[&"detect", &dir, &"--out", &out, &"--backend", &"cpu"]);
    assert_eq!(o.status.code(), Some(1), "{}", show(&o));
    let err = stderr(&o);
    assert_eq!(err.lines().count(), 1, "one error line: {}", show(&o));
    let loop_path = dir.join("sub/loop");
    assert!(
        err.starts_with(&format!(
            "lfast: {}: symbolic link loop (leads back to {})",
            loop_path.display(),
            dir.display()
        )),
        "{err}"
    );
    // five files, all done; the loop is an error of the walk, not a sixth file
    assert_eq!(summary(&o), (5, 0, 0), "{}", show(&o));
    assert!(
        stdout(&o).contains("summary: done 5, skipped 0, failed 0 of 5 files; 1 error (symbolic link loop); "),
        "{}",
        show(&o)
    );
    assert_eq!(file_lines(&o).len(), 5, "{}", show(&o));
    assert_eq!(files(&out), ["a.json", "b.json", "c.json", "sub/d.json", "sub/e.json"]);
}

#[test]
fn a_file_reachable_twice_is_processed_once_under_the_path_first_found() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = looped(tmp.path());
    // in/alias -> sub (found first: "alias" < "sub"), in/c2.png -> c.png,
    // and a dangling link that is not named like an image
    symlink("sub", dir.join("alias")).unwrap();
    symlink("c.png", dir.join("c2.png")).unwrap();
    symlink("gone", dir.join("notes.txt")).unwrap();
    let out = tmp.path().join("out");
    let o = lfast(&[&"detect", &dir, &"--out", &out, &"--backend", &"cpu", &"--quiet"]);
    assert_eq!(o.status.code(), Some(1), "{}", show(&o));
    // the one loop, seen as alias/loop first, is named once
    let err = stderr(&o);
    assert_eq!(err.lines().count(), 1, "{}", show(&o));
    assert!(err.starts_with(&format!("lfast: {}: symbolic link loop", dir.join("alias/loop").display())), "{err}");
    assert_eq!(summary(&o), (5, 0, 0), "{}", show(&o));
    assert!(stdout(&o).contains("of 5 files; 1 error (symbolic link loop); "), "{}", show(&o));
    assert_eq!(files(&out), ["a.json", "alias/d.json", "alias/e.json", "b.json", "c.json"]);
    let f = read_features(&out.join("alias/d.json"));
    assert_eq!(f.image, dir.join("alias/d.png").display().to_string());
    // named files: a link and its target are one file, under the name given first
    let out2 = tmp.path().join("out2");
    let o = lfast(&[
        &"detect",
        &dir.join("b.png"),
        &dir.join("c2.png"),
        &dir.join("c.png"),
        &"--out",
        &out2,
        &"--backend",
        &"cpu",
    ]);
    assert!(o.status.success(), "{}", show(&o));
    assert_eq!(summary(&o), (2, 0, 0), "{}", show(&o));
    assert_eq!(files(&out2), ["b.json", "c2.json"]);
}

#[test]
fn a_name_with_a_newline_or_other_control_characters_is_one_escaped_line() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("in");
    std::fs::create_dir(&dir).unwrap();
    std::fs::copy(common::data("chessboard_GRAY.png"), dir.join("a.png")).unwrap();
    std::fs::copy(common::data("chessboard_GRAY.png"), dir.join("new\nline.png")).unwrap();
    std::fs::write(dir.join("bad\tname\r\u{1b}[31m.png"), "not a PNG\n").unwrap();
    let out = tmp.path().join("out");
    let o = lfast(&[&"detect", &dir, &"--out", &out, &"--backend", &"cpu"]);
    assert_eq!(o.status.code(), Some(1), "{}", show(&o));
    let lines = file_lines(&o);
    assert_eq!(lines.len(), 2, "one line per file done: {}", show(&o));
    let escaped = format!("{}: ", dir.join(r"new\nline.png").display());
    let line = lines.iter().find(|l| l.starts_with(&escaped)).unwrap_or_else(|| panic!("{}", show(&o)));
    assert!(line.ends_with(&out.join(r"new\nline.json").display().to_string()), "{line}");
    let err = stderr(&o);
    assert_eq!(err.lines().count(), 1, "{}", show(&o));
    assert!(err.starts_with(&format!("lfast: {}: ", dir.join(r"bad\tname\r\u{1b}[31m.png").display())), "{err:?}");
    assert!(!err.contains('\u{1b}') && !err.contains('\r'), "{err:?}");
    // the JSON keeps the exact name
    let f = read_features(&out.join("new\nline.json"));
    assert_eq!(f.image, dir.join("new\nline.png").display().to_string());
}

/// A tmpfs mounted at a directory for the life of the value (root only).
struct Tmpfs(PathBuf);

impl Tmpfs {
    fn mount(dir: &Path, size: &str) -> Option<Tmpfs> {
        std::fs::create_dir_all(dir).unwrap();
        let ok = std::process::Command::new("mount")
            .args(["-t", "tmpfs", "-o", &format!("size={size}"), "tmpfs"])
            .arg(dir)
            .stderr(std::process::Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
        ok.then(|| Tmpfs(dir.to_path_buf()))
    }

    fn resize(&self, size: &str) {
        let s = std::process::Command::new("mount")
            .args(["-o", &format!("remount,size={size}")])
            .arg(&self.0)
            .status()
            .unwrap();
        assert!(s.success(), "remount {}", self.0.display());
    }
}

impl Drop for Tmpfs {
    fn drop(&mut self) {
        let _ = std::process::Command::new("umount").arg(&self.0).status();
    }
}

#[test]
fn a_full_tmpfs_stops_the_batch_with_one_line_and_skip_existing_finishes() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("in");
    std::fs::create_dir(&dir).unwrap();
    for i in 0..10 {
        std::fs::copy(common::data("astronaut_256.png"), dir.join(format!("f{i:02}.png"))).unwrap();
    }
    let clean = tmp.path().join("clean");
    let args = |out: &Path| -> Vec<std::ffi::OsString> {
        let mut v: Vec<std::ffi::OsString> = vec!["detect".into(), dir.clone().into(), "--out".into(), out.into()];
        v.extend(["--format", "json,csv", "--backend", "cpu"].map(Into::into));
        v
    };
    let run = |a: Vec<std::ffi::OsString>| {
        let a: Vec<&dyn AsRef<std::ffi::OsStr>> = a.iter().map(|s| s as &dyn AsRef<std::ffi::OsStr>).collect();
        lfast(&a)
    };
    let o = run(args(&clean));
    assert!(o.status.success(), "{}", show(&o));
    let want = files(&clean);
    let bytes: u64 = want.iter().map(|f| std::fs::metadata(clean.join(f)).unwrap().len()).sum();

    let out = tmp.path().join("out");
    // room for about three of the ten files' outputs
    let size = format!("{}k", (bytes * 3 / 10 / 1024).max(64));
    let Some(fs) = Tmpfs::mount(&out, &size) else {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI runs as root and must mount a tmpfs for this test (`mount -t tmpfs` failed)"
        );
        eprintln!("no tmpfs without root: the full disk is checked by the library's failing writer only");
        return;
    };
    let o = run(args(&out));
    assert_eq!(o.status.code(), Some(1), "{}", show(&o));
    let err = stderr(&o);
    assert_eq!(err.lines().count(), 1, "one clear line: {}", show(&o));
    let (done, skipped, failed) = summary(&o);
    assert!((1..10).contains(&done) && skipped == 0 && failed == 1, "{}", show(&o));
    let line = err.lines().next().unwrap();
    let head = format!("lfast: disk full writing {}/f", out.display());
    assert!(line.starts_with(&head), "{line}");
    assert!(line.contains(&format!(": {done} of 10 files done (no space left on device); ")), "{line}");
    // no temporary file, and every file there is whole (the clean run's bytes)
    let got = files(&out);
    assert!(got.iter().all(|f| !f.contains("/.") && !f.starts_with('.')), "{got:?}");
    assert!(got.len() >= 2 * done as usize, "{got:?}");
    for f in &got {
        assert_eq!(std::fs::read(out.join(f)).unwrap(), std::fs::read(clean.join(f)).unwrap(), "{f}");
    }

    // space freed: the rerun skips what is done and finishes the job
    fs.resize("16m");
    let mut a = args(&out);
    a.push("--skip-existing".into());
    let o = run(a);
    assert!(o.status.success(), "{}", show(&o));
    let (done2, skipped2, failed2) = summary(&o);
    assert_eq!((done2 + skipped2, failed2), (10, 0), "{}", show(&o));
    assert!(skipped2 >= done, "{}", show(&o));
    assert_eq!(files(&out), want);
    for f in &want {
        assert_eq!(std::fs::read(out.join(f)).unwrap(), std::fs::read(clean.join(f)).unwrap(), "{f}");
    }
}

#[test]
fn a_full_tmpfs_stops_lfast_edges_with_one_line() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("in");
    std::fs::create_dir(&dir).unwrap();
    for i in 0..20 {
        std::fs::copy(common::data("coins.png"), dir.join(format!("f{i:02}.png"))).unwrap();
    }
    let out = tmp.path().join("out");
    let Some(_fs) = Tmpfs::mount(&out, "64k") else {
        assert!(std::env::var_os("CI").is_none(), "CI runs as root and must mount a tmpfs for this test");
        eprintln!("no tmpfs without root: not checked here");
        return;
    };
    let o = lfast(&[&"edges", &dir, &"--out", &out, &"--debug", &"--backend", &"cpu"]);
    assert_eq!(o.status.code(), Some(1), "{}", show(&o));
    let err = stderr(&o);
    assert_eq!(err.lines().count(), 1, "{}", show(&o));
    let (done, _, failed) = summary(&o);
    assert!(done < 20 && failed == 1, "{}", show(&o));
    assert!(err.starts_with(&format!("lfast: disk full writing {}/f", out.display())), "{err}");
    assert!(err.contains(&format!(": {done} of 20 files done")), "{err}");
    let got = files(&out);
    assert!(got.iter().all(|f| !f.starts_with('.')), "no temporary file: {got:?}");
}
