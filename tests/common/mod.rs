//! Helpers shared by the integration tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

/// The project root: `LFAST_ROOT` when set (test executables carried to
/// another machine, run from a copy of the repository there), else the
/// directory this crate was built in.
pub fn root() -> PathBuf {
    std::env::var_os("LFAST_ROOT").map_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")), PathBuf::from)
}

/// The real test data of ../shared/README.md (never committed): the folder
/// named by `LFAST_TEST_DATA`, else `../shared/data` beside the project.
/// `scripts/fetch_test_data.sh DIR` downloads it.
pub fn data_dir() -> PathBuf {
    std::env::var_os("LFAST_TEST_DATA")
        .filter(|v| !v.is_empty())
        .map_or_else(|| root().join("../shared/data"), PathBuf::from)
}

/// `<data_dir>/<rel>` if it exists. When it does not: in CI (env CI set)
/// the test fails, elsewhere it says why, logs the skip (see [`note_skip`])
/// and the caller skips.
pub fn shared(rel: &str) -> Option<PathBuf> {
    let p = data_dir().join(rel);
    if p.exists() {
        return Some(p);
    }
    if std::env::var_os("CI").is_some() {
        panic!("{} is missing, and CI must have the test data (LFAST_TEST_DATA or ../shared/data)", p.display());
    }
    note_skip(&p);
    None
}

/// Says on stderr that the running test skips for want of `missing`, and
/// appends a line to the file named by `LFAST_SKIP_LOG` when set (`.ci/run`
/// counts the skips there).
pub fn note_skip(missing: &Path) {
    let test = std::thread::current().name().unwrap_or("?").to_string();
    eprintln!("skipping {test}: {} not found (LFAST_TEST_DATA or ../shared/data)", missing.display());
    if let Some(log) = std::env::var_os("LFAST_SKIP_LOG") {
        use std::io::Write;
        let line = format!("{}: {test}: {} not found\n", env!("CARGO_CRATE_NAME"), missing.display());
        // one write of one short line to a file opened for appending: lines of parallel tests do not mix
        let f = std::fs::OpenOptions::new().create(true).append(true).open(&log);
        if let Err(e) = f.and_then(|mut f| f.write_all(line.as_bytes())) {
            eprintln!("warning: cannot log the skip to {}: {e}", std::path::Path::new(&log).display());
        }
    }
}

/// A file under tests/data.
pub fn data(rel: &str) -> PathBuf {
    root().join("tests/data").join(rel)
}

/// The `lfast` binary with `args` and extra environment variables, not yet started.
pub fn command(args: &[&dyn AsRef<std::ffi::OsStr>], env: &[(&str, &str)]) -> std::process::Command {
    // No XDG_RUNTIME_DIR here: lfast's Vulkan instance does not need one on a
    // headless machine (src/gpu/context.rs, tests/first_run.rs), and the tests
    // count stderr lines.
    let mut c = std::process::Command::new(env!("CARGO_BIN_EXE_lfast"));
    for a in args {
        c.arg(a);
    }
    for (k, v) in env {
        c.env(k, v);
    }
    c
}

/// Runs the `lfast` binary with `args`.
pub fn lfast(args: &[&dyn AsRef<std::ffi::OsStr>]) -> std::process::Output {
    command(args, &[]).output().expect("the lfast binary runs")
}

/// A process's stdout as text.
pub fn stdout(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// A process's stderr as text.
pub fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Exit status, stdout and stderr of a run, for assertion messages.
pub fn show(o: &std::process::Output) -> String {
    format!("exit {:?}\nstdout: {}\nstderr: {}", o.status, stdout(o), stderr(o))
}

/// The `summary:` line's (done, skipped, failed) of a batch run.
pub fn summary(o: &std::process::Output) -> (u64, u64, u64) {
    let text = stdout(o);
    let line = text.lines().rfind(|l| l.starts_with("summary: ")).unwrap_or_else(|| panic!("no summary\n{}", show(o)));
    let num = |key: &str| -> u64 {
        let rest = &line[line.find(key).unwrap_or_else(|| panic!("no `{key}` in {line:?}")) + key.len()..];
        rest.trim_start().split(|c: char| !c.is_ascii_digit()).next().unwrap().parse().unwrap()
    };
    (num("done"), num("skipped"), num("failed"))
}

/// The features `lfast detect` wrote to a JSON file.
pub fn read_features(p: &Path) -> lfast::io::Features {
    let text = std::fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// Every file under `dir` (hidden ones included), relative with `/`, sorted;
/// empty when `dir` does not exist.
pub fn files(dir: &Path) -> Vec<String> {
    fn walk(root: &Path, d: &Path, out: &mut Vec<String>) {
        for e in std::fs::read_dir(d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(root, &p, out);
            } else {
                out.push(p.strip_prefix(root).unwrap().to_string_lossy().replace('\\', "/"));
            }
        }
    }
    let mut v = Vec::new();
    if dir.exists() {
        walk(dir, dir, &mut v);
    }
    v.sort();
    v
}

/// A `w x h` plane with `f(x, y)` at every pixel.
pub fn plane_fn(w: u32, h: u32, mut f: impl FnMut(u32, u32) -> u8) -> lfast::Plane<u8> {
    lfast::Plane::from_vec(w, h, (0..w * h).map(|i| f(i % w, i / w)).collect()).expect("plane size")
}

/// The `w x h` window of `img` at (x0, y0), clipped to the image.
pub fn crop(img: &lfast::Plane<u8>, x0: u32, y0: u32, w: u32, h: u32) -> lfast::Plane<u8> {
    let (w, h) = (w.min(img.width - x0), h.min(img.height - y0));
    plane_fn(w, h, |x, y| img.at(x0 + x, y0 + y))
}

/// Test data from the crate's one generator, [`lfast::rng::SplitMix64`]:
/// every test file draws its random inputs here (no local generators).
pub struct TestRng(lfast::rng::SplitMix64);

impl TestRng {
    /// A generator started at `seed`.
    pub fn new(seed: u64) -> Self {
        Self(lfast::rng::SplitMix64::new(seed))
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0.next_u64()
    }

    /// The next 32 random bits (the high half of a 64-bit draw).
    pub fn next_u32(&mut self) -> u32 {
        (self.0.next_u64() >> 32) as u32
    }

    /// In `0..n` (`n > 0`), as `next_u64() % n`: test data, not statistics.
    pub fn below(&mut self, n: u32) -> u32 {
        (self.next_u64() % n as u64) as u32
    }

    /// [`below`](Self::below) for 64-bit bounds.
    pub fn below_u64(&mut self, n: u64) -> u64 {
        self.next_u64() % n
    }
}

/// `n` random bytes from `seed`.
pub fn random_bytes(n: usize, seed: u64) -> Vec<u8> {
    let mut r = TestRng::new(seed);
    (0..n).map(|_| r.next_u32() as u8).collect()
}

/// A `w x h` plane of uniform noise (every value 0..=255) from `seed`.
pub fn noise(w: u32, h: u32, seed: u64) -> lfast::Plane<u8> {
    let mut r = TestRng::new(seed);
    plane_fn(w, h, |_, _| r.next_u32() as u8)
}
