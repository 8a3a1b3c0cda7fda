//! Progress (a bar on a terminal, plain lines otherwise), per-file error lines,
//! the summary, and the output-directory checks done before any work.

use super::CliError;
use indicatif::{ProgressBar, ProgressState, ProgressStyle};
use std::io::IsTerminal;
use std::path::Path;
use std::time::Instant;

/// Counts of one run.
#[derive(Clone, Copy, Debug, Default)]
pub struct Counts {
    /// Files processed and written.
    pub done: u64,
    /// Files skipped (--skip-existing).
    pub skipped: u64,
    /// Files that failed.
    pub failed: u64,
    /// Keypoints (or edge pixels) over the files done.
    pub items: u64,
}

/// Reports progress and errors; owned by the one thread that finishes files.
pub struct Reporter {
    bar: Option<ProgressBar>,
    lines: bool,
    start: Instant,
    /// The counts so far.
    pub counts: Counts,
}

impl Reporter {
    /// A bar on stderr when it is a terminal (and not `quiet`), else one line
    /// per file on stdout (none when `quiet`).
    pub fn new(total: u64, quiet: bool) -> Self {
        let tty = std::io::stderr().is_terminal();
        let bar = (!quiet && tty).then(|| {
            let b = ProgressBar::new(total);
            if let Ok(style) = ProgressStyle::with_template("{bar:40} {pos}/{len} files  {fps}  ETA {eta}") {
                b.set_style(style.with_key("fps", |s: &ProgressState, w: &mut dyn std::fmt::Write| {
                    let _ = write!(w, "{:.1} files/s", s.per_sec());
                }));
            }
            b
        });
        Reporter { bar, lines: !quiet && !tty, start: Instant::now(), counts: Counts::default() }
    }

    /// A file done, with `items` keypoints/pixels and the line to print.
    pub fn done(&mut self, items: u64, line: impl FnOnce() -> String) {
        self.counts.done += 1;
        self.counts.items += items;
        self.tick(line);
    }

    /// A file skipped.
    pub fn skipped(&mut self, line: impl FnOnce() -> String) {
        self.counts.skipped += 1;
        self.tick(line);
    }

    fn tick(&self, line: impl FnOnce() -> String) {
        if let Some(b) = &self.bar {
            b.inc(1);
        } else if self.lines {
            println!("{}", line());
        }
    }

    /// A file failed: one line on stderr naming it and the reason.
    pub fn failed(&mut self, path: &Path, reason: &str) {
        self.counts.failed += 1;
        // one line per file, whatever the decoder's message holds (zune-jpeg's end in '\n')
        let reason = reason.split_whitespace().collect::<Vec<_>>().join(" ");
        let line = format!("lfast: {}: {reason}", path.display());
        match &self.bar {
            Some(b) => {
                b.suspend(|| eprintln!("{line}"));
                b.inc(1);
            }
            None => eprintln!("{line}"),
        }
    }

    /// Clears the bar and prints the summary line on stdout; `what` names the
    /// items counted ("keypoints"), `tail` is appended. Returns whether nothing failed.
    pub fn finish(self, what: &str, tail: &str) -> bool {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
        let secs = self.start.elapsed().as_secs_f64();
        let c = self.counts;
        let fps = if secs > 0.0 { c.done as f64 / secs } else { 0.0 };
        println!(
            "summary: done {}, skipped {}, failed {} of {} files; {} {what}; {secs:.2} s, {fps:.1} frames/s; {tail}",
            c.done,
            c.skipped,
            c.failed,
            c.done + c.skipped + c.failed,
            c.items
        );
        c.failed == 0
    }
}

/// The signal that interrupted the batch (SIGINT, SIGTERM), 0 while none did.
static INTERRUPTED: std::sync::atomic::AtomicI32 = std::sync::atomic::AtomicI32::new(0);

#[cfg(unix)]
extern "C" fn on_interrupt(sig: libc::c_int) {
    // Only async-signal-safe work here: note the signal and restore the
    // default action, so a second Ctrl-C ends the process at once.
    INTERRUPTED.store(sig, std::sync::atomic::Ordering::SeqCst);
    // SAFETY: signal() is async-signal-safe; SIG_DFL is a valid action.
    unsafe {
        libc::signal(sig, libc::SIG_DFL);
    }
}

/// Makes SIGINT and SIGTERM stop a batch between files instead of killing it
/// in the middle of writing one: no file is taken after the signal, the file
/// being written is completed, its temporary files are renamed, the summary is
/// printed, and [`exit_if_interrupted`] then ends the process by the signal.
pub fn catch_interrupts() {
    #[cfg(unix)]
    // SAFETY: the handler only stores to an atomic and calls signal().
    unsafe {
        let h = on_interrupt as extern "C" fn(libc::c_int) as libc::sighandler_t;
        libc::signal(libc::SIGINT, h);
        libc::signal(libc::SIGTERM, h);
    }
}

/// Whether SIGINT or SIGTERM arrived since [`catch_interrupts`].
pub fn interrupted() -> bool {
    INTERRUPTED.load(std::sync::atomic::Ordering::SeqCst) != 0
}

/// After an interrupted batch has printed its summary: a note on stderr, then
/// the signal again with its default action, so the parent (a shell loop, a
/// job runner) sees the process ended by it. Returns when nothing interrupted.
pub fn exit_if_interrupted() {
    let sig = INTERRUPTED.load(std::sync::atomic::Ordering::SeqCst);
    if sig == 0 {
        return;
    }
    eprintln!("lfast: interrupted; finished files are complete, rerun with --skip-existing to do the rest");
    #[cfg(unix)]
    // SAFETY: restoring the default action and raising a signal are plain libc calls.
    unsafe {
        libc::signal(sig, libc::SIG_DFL);
        libc::raise(sig);
    }
    std::process::exit(130);
}

/// Prints lfast's own warnings (`log` records whose target starts with
/// `lfast`, such as a frame the GPU cannot take running on the CPU) on stderr
/// as `lfast: warning: ...`; other crates' records are dropped.
struct Warnings;

impl log::Log for Warnings {
    fn enabled(&self, m: &log::Metadata) -> bool {
        m.level() <= log::Level::Warn && m.target().starts_with("lfast")
    }
    fn log(&self, r: &log::Record) {
        if self.enabled(r.metadata()) {
            eprintln!("lfast: warning: {}", r.args());
        }
    }
    fn flush(&self) {}
}

/// Installs the stderr logger of lfast's warnings (unless `quiet`); a no-op
/// when a logger is already installed.
pub fn log_warnings(quiet: bool) {
    if !quiet && log::set_logger(&Warnings).is_ok() {
        log::set_max_level(log::LevelFilter::Warn);
    }
}

/// The reason of a per-file error, without the path (the line names it first).
pub fn reason(e: &crate::Error) -> String {
    match e {
        crate::Error::Io { source, .. } => source.to_string(),
        crate::Error::Image { source, .. } => source.to_string(),
        other => other.to_string(),
    }
}

/// Creates `dir` and checks that a file can be written there, so that an
/// unusable output directory fails before any work; removes temporary files
/// left there by interrupted runs (`.NAME.PID.tmp` of a process that is gone).
pub fn prepare_out_dir(dir: &Path) -> Result<(), CliError> {
    let bad = |e: std::io::Error| CliError::OutDir { path: dir.to_path_buf(), reason: e.to_string() };
    if dir.exists() && !dir.is_dir() {
        return Err(CliError::OutDir { path: dir.to_path_buf(), reason: "exists and is not a directory".into() });
    }
    std::fs::create_dir_all(dir).map_err(bad)?;
    let probe = dir.join(format!(".lfast-write-check.{}.tmp", std::process::id()));
    std::fs::write(&probe, b"").map_err(bad)?;
    let _ = std::fs::remove_file(&probe);
    remove_stale(dir, 0);
    Ok(())
}

/// Whether `name` is `.ANY.PID.tmp` for a process that no longer runs.
fn is_stale_tmp(name: &str) -> bool {
    let Some(inner) = name.strip_prefix('.').and_then(|n| n.strip_suffix(".tmp")) else {
        return false;
    };
    let Some((_, pid)) = inner.rsplit_once('.') else {
        return false;
    };
    let Ok(pid) = pid.parse::<u32>() else {
        return false;
    };
    // Only where liveness can be checked.
    cfg!(target_os = "linux") && pid != std::process::id() && !Path::new(&format!("/proc/{pid}")).exists()
}

fn remove_stale(dir: &Path, depth: u32) {
    let Ok(rd) = std::fs::read_dir(dir) else { return };
    for e in rd.flatten() {
        let p = e.path();
        let Ok(ft) = e.file_type() else { continue };
        if ft.is_dir() && depth < 16 {
            remove_stale(&p, depth + 1);
        } else if ft.is_file() && e.file_name().to_str().is_some_and(is_stale_tmp) {
            let _ = std::fs::remove_file(&p);
        }
    }
}
