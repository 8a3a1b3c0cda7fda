//! Helpers shared by the integration tests.
#![allow(dead_code)]

use std::path::PathBuf;

/// `../shared/data/<rel>` if it exists. When it does not: in CI (env CI set)
/// the test fails, elsewhere it prints why and the caller skips.
pub fn shared(rel: &str) -> Option<PathBuf> {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data").join(rel);
    if p.exists() {
        return Some(p);
    }
    if std::env::var_os("CI").is_some() {
        panic!("{} is missing, and CI must have ../shared", p.display());
    }
    eprintln!("skipping: {} not found (../shared is absent in a plain clone)", p.display());
    None
}

/// A file under tests/data.
pub fn data(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(rel)
}

/// Runs the `lfast` binary with `args`.
pub fn lfast(args: &[&dyn AsRef<std::ffi::OsStr>]) -> std::process::Output {
    let mut c = std::process::Command::new(env!("CARGO_BIN_EXE_lfast"));
    // Mesa's Vulkan drivers print a line to stderr when this is unset (headless
    // machines); the tests count stderr lines.
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        c.env("XDG_RUNTIME_DIR", std::env::temp_dir());
    }
    for a in args {
        c.arg(a);
    }
    c.output().expect("the lfast binary runs")
}

/// A process's stdout as text.
pub fn stdout(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// A process's stderr as text.
pub fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}
