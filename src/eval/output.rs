//! What every suite writes and the report reads back: the section
//! (`OUT/<suite>.md`) and the summary (`OUT/<suite>.json`), and the machine
//! the timings were taken on.

use super::{EvalError, Result, Suite, write_text};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Writes a suite's report section (`OUT/<suite>.md`) and its numbers (`OUT/<suite>.json`).
pub fn write_section<T: Serialize>(out: &Path, suite: Suite, markdown: &str, summary: &T) -> Result<()> {
    write_text(&out.join(format!("{}.md", suite.name())), markdown)?;
    let json = serde_json::to_string_pretty(summary)
        .map_err(|e| EvalError::Output { path: out.join(format!("{}.json", suite.name())), reason: e.to_string() })?;
    write_text(&out.join(format!("{}.json", suite.name())), &json)
}

/// Reads a suite's numbers back; `None` when the suite has not run in `out`.
pub fn read_summary<T: for<'de> Deserialize<'de>>(out: &Path, suite: Suite) -> Result<Option<T>> {
    let path = out.join(format!("{}.json", suite.name()));
    let Ok(text) = std::fs::read_to_string(&path) else { return Ok(None) };
    serde_json::from_str(&text)
        .map(Some)
        .map_err(|e| EvalError::Data { path, reason: format!("unreadable suite summary ({e}); rerun the suite") })
}

/// A short description of the machine the timings were taken on.
pub fn machine() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|s| s.trim().to_string())
        })
        .unwrap_or_else(|| std::env::consts::ARCH.to_string());
    format!("{cpu}, {} worker threads", rayon::current_num_threads())
}

/// The 1-minute load average (`/proc/loadavg`), when the system reports one.
pub fn load_average() -> Option<f64> {
    std::fs::read_to_string("/proc/loadavg").ok()?.split_whitespace().next()?.parse().ok()
}
