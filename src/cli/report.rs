//! Progress (a bar on a terminal, plain lines otherwise), per-file error lines,
//! the summary, and the output-directory checks done before any work.

use super::CliError;
use indicatif::{ProgressBar, ProgressState, ProgressStyle};
use signal_hook::consts::{SIGINT, SIGTERM};
use signal_hook::flag;
use std::io::IsTerminal;
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
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
    /// Entries the directory walk could not follow or read (a symbolic link
    /// loop, an unreadable directory): errors, but not files.
    pub walk_errors: u64,
}

/// Reports progress and errors; owned by the one thread that finishes files.
pub struct Reporter {
    bar: Option<ProgressBar>,
    lines: bool,
    start: Instant,
    /// What the summary counts: "files", or "frames" for recordings.
    unit: &'static str,
    /// The bar's position is set by [`Reporter::position`], not by each file.
    positioned: bool,
    /// The counts so far.
    pub counts: Counts,
    /// The kinds of the walk errors, in the order first met, with their counts.
    walk_kinds: Vec<(&'static str, u64)>,
}

impl Reporter {
    /// A bar on stderr when it is a terminal (and not `quiet`), else one line
    /// per file on stdout (none when `quiet`). `total` counts files, not walk errors.
    pub fn new(total: u64, quiet: bool) -> Self {
        Self::counting(total, quiet, "files", "files")
    }

    /// A reporter whose bar counts `bar_unit` ("messages": set by
    /// [`Reporter::position`]) and whose summary counts `unit` ("frames").
    pub fn counting(total: u64, quiet: bool, unit: &'static str, bar_unit: &'static str) -> Self {
        let tty = std::io::stderr().is_terminal();
        let bar = (!quiet && tty).then(|| {
            let b = ProgressBar::new(total);
            let template = format!("{{bar:40}} {{pos}}/{{len}} {bar_unit}  {{fps}}  ETA {{eta}}");
            if let Ok(style) = ProgressStyle::with_template(&template) {
                b.set_style(style.with_key("fps", move |s: &ProgressState, w: &mut dyn std::fmt::Write| {
                    let _ = write!(w, "{:.1} {bar_unit}/s", s.per_sec());
                }));
            }
            b
        });
        Reporter {
            bar,
            lines: !quiet && !tty,
            start: Instant::now(),
            unit,
            positioned: unit != bar_unit,
            counts: Counts::default(),
            walk_kinds: Vec::new(),
        }
    }

    /// Sets the bar to `pos` of `len` (`len` 0: unknown, left as it was).
    pub fn position(&self, pos: u64, len: u64) {
        if let Some(b) = &self.bar {
            if len > 0 {
                b.set_length(len);
            }
            b.set_position(pos);
        }
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
            if !self.positioned {
                b.inc(1);
            }
        } else if self.lines {
            println!("{}", one_line(&line()));
        }
    }

    /// A file failed: one line on stderr naming it and the reason.
    pub fn failed(&mut self, path: &Path, reason: &str) {
        // one line per file, whatever the decoder's message holds (zune-jpeg's end in '\n')
        let reason = reason.split_whitespace().collect::<Vec<_>>().join(" ");
        self.error_line(&format!("lfast: {}: {reason}", path.display()));
        if let Some(b) = &self.bar
            && !self.positioned
        {
            b.inc(1);
        }
    }

    /// An entry the directory walk could not follow or read: one line on
    /// stderr naming it and the reason; counted apart from files, by `kind`.
    pub fn walk_error(&mut self, path: &Path, kind: &'static str, reason: &str) {
        self.print_error(&format!("lfast: {}: {reason}", path.display()));
        self.counts.walk_errors += 1;
        match self.walk_kinds.iter_mut().find(|(k, _)| *k == kind) {
            Some((_, n)) => *n += 1,
            None => self.walk_kinds.push((kind, 1)),
        }
    }

    /// An entry known up front to be unprocessable: a walk error or a failed file.
    pub fn problem(&mut self, path: &Path, p: &super::inputs::Problem) {
        match p {
            super::inputs::Problem::Walk { kind, reason } => self.walk_error(path, kind, reason),
            super::inputs::Problem::File(reason) => self.failed(path, reason),
        }
    }

    /// The batch cannot go on (a full disk): the file being written counts as
    /// failed, and `line` is printed on stderr as `lfast: LINE`.
    pub fn stopped(&mut self, line: &str) {
        self.error_line(&format!("lfast: {line}"));
    }

    fn error_line(&mut self, line: &str) {
        self.counts.failed += 1;
        self.print_error(line);
    }

    fn print_error(&self, line: &str) {
        let line = one_line(line);
        match &self.bar {
            Some(b) => b.suspend(|| eprintln!("{line}")),
            None => eprintln!("{line}"),
        }
    }

    /// Files finished so far: done or skipped because their outputs exist.
    pub fn finished(&self) -> u64 {
        self.counts.done + self.counts.skipped
    }

    /// Clears the bar and prints the summary line on stdout; `what` names the
    /// items counted ("keypoints"), `tail` is appended. Files are counted as
    /// files; walk errors follow them apart, by kind (`1 error (symbolic link
    /// loop)`). Returns whether nothing failed and the walk met no error.
    pub fn finish(self, what: &str, tail: &str) -> bool {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
        let secs = self.start.elapsed().as_secs_f64();
        let c = self.counts;
        let fps = if secs > 0.0 { c.done as f64 / secs } else { 0.0 };
        println!(
            "summary: done {}, skipped {}, failed {} of {} {};{} {} {what}; {secs:.2} s, {fps:.1} frames/s; {tail}",
            c.done,
            c.skipped,
            c.failed,
            c.done + c.skipped + c.failed,
            self.unit,
            walk_clause(c.walk_errors, &self.walk_kinds),
            c.items
        );
        c.failed == 0 && c.walk_errors == 0
    }
}

/// ` N error(s) (KIND, KIND N);` for the summary, empty when there is none;
/// a kind met more than once carries its count.
fn walk_clause(n: u64, kinds: &[(&str, u64)]) -> String {
    if n == 0 {
        return String::new();
    }
    let kinds: Vec<String> =
        kinds.iter().map(|&(k, m)| if m == 1 { k.to_string() } else { format!("{k} {m}") }).collect();
    format!(" {n} error{} ({});", if n == 1 { "" } else { "s" }, kinds.join(", "))
}

/// Set by the first SIGINT or SIGTERM after [`catch_interrupts`].
static INTERRUPTED: AtomicBool = AtomicBool::new(false);
/// The signal that set [`INTERRUPTED`], 0 while none did.
static SIGNAL: AtomicUsize = AtomicUsize::new(0);

/// Makes SIGINT and SIGTERM stop a batch between files instead of killing it
/// in the middle of writing one: no file is taken after the signal, the file
/// being written is completed, its temporary files are renamed, the summary is
/// printed, and [`exit_if_interrupted`] then ends the process by the signal.
/// A second signal has the default action at once (a second Ctrl-C kills).
/// signal-hook's handlers only store to atomics, which is async-signal-safe.
pub fn catch_interrupts() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        for sig in [SIGINT, SIGTERM] {
            // in registration order: the default action when already set, then note it
            let r = flag::register_conditional_default(sig, &INTERRUPTED)
                .and_then(|_| flag::register_usize(sig, &SIGNAL, sig as usize))
                .and_then(|_| flag::register(sig, &INTERRUPTED));
            if let Err(e) = r {
                eprintln!("lfast: warning: cannot catch signal {sig} ({e}); it will stop the batch mid-file");
            }
        }
    });
}

/// Whether SIGINT or SIGTERM arrived since [`catch_interrupts`].
pub fn interrupted() -> bool {
    INTERRUPTED.load(Ordering::SeqCst)
}

/// After an interrupted batch has printed its summary: a note on stderr, then
/// the signal again with its default action, so the parent (a shell loop, a
/// job runner) sees the process ended by it. Returns when nothing interrupted.
pub fn exit_if_interrupted() {
    if !interrupted() {
        return;
    }
    eprintln!("lfast: interrupted; finished files are complete, rerun with --skip-existing to do the rest");
    let sig = SIGNAL.load(Ordering::SeqCst) as i32;
    if sig != 0 {
        let _ = signal_hook::low_level::emulate_default_handler(sig);
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

/// `s` on one line: control characters (newline, carriage return, tab, escape
/// and the rest of Unicode's Cc) and the Unicode line and paragraph separators
/// are written as Rust escapes (`\n`, `\u{1b}`), so that a file name holding
/// them still gives one line per file. The JSON output keeps the exact name.
pub fn one_line(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        if c.is_control() || c == '\u{2028}' || c == '\u{2029}' {
            out.extend(c.escape_debug());
        } else {
            out.push(c);
        }
    }
    out
}

/// The line that stops a batch on a full disk (`e` is a
/// [`crate::io::is_disk_full`] error): what was being written, how far the
/// batch got, and how to finish it.
pub fn disk_full(e: &crate::Error, finished: u64, total: usize) -> String {
    let (path, why) = match e {
        crate::Error::Io { path, source } if source.kind() == std::io::ErrorKind::QuotaExceeded => {
            (path.display().to_string(), "disk quota exceeded")
        }
        crate::Error::Io { path, .. } => (path.display().to_string(), "no space left on device"),
        other => (other.to_string(), "no space left on device"),
    };
    format!(
        "disk full writing {path}: {finished} of {total} files done ({why}); free some space and rerun with --skip-existing to finish"
    )
}

/// The reason of a per-file error, without the path (the line names it first).
pub fn reason(e: &crate::Error) -> String {
    match e {
        crate::Error::Io { source, .. } => source.to_string(),
        crate::Error::Image { source, .. } => source.to_string(),
        crate::Error::Recording { reason, .. } => reason.clone(),
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
    remove_stale(dir, 16);
    Ok(())
}

/// Whether `name` is a temporary file of [`crate::io::write_atomic`]
/// (`.ANY.PID-RANDOM.tmp`, or `.ANY.PID.tmp` of earlier versions) left by a
/// process that no longer runs.
fn is_stale_tmp(name: &str) -> bool {
    let Some(inner) = name.strip_prefix('.').and_then(|n| n.strip_suffix(crate::io::TMP_SUFFIX)) else {
        return false;
    };
    let Some((_, last)) = inner.rsplit_once('.') else {
        return false;
    };
    let pid = last.split_once('-').map_or(last, |(pid, _)| pid);
    let Ok(pid) = pid.parse::<u32>() else {
        return false;
    };
    // Only where liveness can be checked.
    cfg!(target_os = "linux") && pid != std::process::id() && !Path::new(&format!("/proc/{pid}")).exists()
}

/// Removes the stale temporary files under `dir` (16 levels deep at most,
/// symbolic links not followed).
fn remove_stale(dir: &Path, max_depth: usize) {
    let stale = walkdir::WalkDir::new(dir)
        .max_depth(max_depth)
        .into_iter()
        .flatten()
        .filter(|e| e.file_type().is_file() && e.file_name().to_str().is_some_and(is_stale_tmp));
    for e in stale {
        let _ = std::fs::remove_file(e.path());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_line_escapes_control_characters_only() {
        assert_eq!(one_line("in/new\nline.png"), r"in/new\nline.png");
        assert_eq!(one_line("a\r\tb\u{1b}[31m\u{7f}\u{85}\u{2028}"), r"a\r\tb\u{1b}[31m\u{7f}\u{85}\u{2028}");
        assert_eq!(one_line("été/ü ñ 画像.png"), "été/ü ñ 画像.png");
        assert!(!one_line(&(0..=0x10ffu32).filter_map(char::from_u32).collect::<String>()).contains(['\n', '\r']));
    }

    #[test]
    fn walk_errors_are_counted_apart_from_files_by_kind() {
        assert_eq!(walk_clause(0, &[]), "");
        assert_eq!(walk_clause(1, &[("symbolic link loop", 1)]), " 1 error (symbolic link loop);");
        assert_eq!(
            walk_clause(3, &[("symbolic link loop", 2), ("unreadable directory", 1)]),
            " 3 errors (symbolic link loop 2, unreadable directory);"
        );
        let mut r = Reporter::new(2, true);
        r.problem(
            Path::new("in/sub/loop"),
            &super::super::inputs::Problem::Walk { kind: "symbolic link loop", reason: "x".into() },
        );
        r.problem(Path::new("in/a.png"), &super::super::inputs::Problem::File("taken".into()));
        assert_eq!((r.counts.failed, r.counts.walk_errors), (1, 1));
        assert!(!r.finish("keypoints", ""));
    }

    #[test]
    fn stale_temporaries_are_those_of_dead_processes() {
        let dead = u32::MAX - 1; // above Linux's pid_max
        let me = std::process::id();
        let linux = cfg!(target_os = "linux");
        assert_eq!(is_stale_tmp(&format!(".x.json.{dead}-a1B2c3.tmp")), linux);
        assert_eq!(is_stale_tmp(&format!(".x.json.{dead}.tmp")), linux);
        assert!(!is_stale_tmp(&format!(".x.json.{me}-a1B2c3.tmp")));
        assert!(!is_stale_tmp(&format!(".x.json.{me}.tmp")));
        assert!(!is_stale_tmp("x.json.123-abcdef.tmp"));
        assert!(!is_stale_tmp(".x.json.abc-123.tmp"));
        assert!(!is_stale_tmp(".x.json"));
    }
}
