//! Times `CpuDetector::detect_and_compute` under several configurations, in
//! interleaved rounds, and prints JSON to stdout.
//!
//! ```text
//! cargo run --release --example bench_configs -- [--rounds R] NAME=CONFIG.toml... FILE...
//! ```
//!
//! `NAME=default` and `NAME=paper` stand for `Config::default()` and
//! `Config::paper()`; any other value is a TOML file (`lfast detect --config`'s
//! format). The frames are decoded once; each round runs every configuration
//! over every frame, one configuration after the other, so that a slow spell
//! of a shared machine falls on all of them alike. One warm-up round is not
//! timed. Reported per configuration: the minimum and the median over the
//! rounds of the time per frame (ms), the mean keypoints per frame, and the
//! minimum as a ratio of the first configuration's. docs/quality.md (cost)
//! runs it with `RAYON_NUM_THREADS=1`.
//!
//! On Linux it also reports the CPU time of the whole process per frame
//! (`cpu_min_ms`, `cpu_median_ms`, `cpu_min_vs_first`: the on-CPU time of all
//! its threads, from `/proc/self/task/*/schedstat`, in nanoseconds). On a
//! loaded machine that time moves much less than the wall clock, since time
//! spent waiting for a core is not counted.

use lfast::cpu::CpuDetector;
use lfast::{Config, Plane};
use serde_json::json;
use std::hint::black_box;
use std::time::Instant;

fn usage() -> ! {
    eprintln!("usage: bench_configs [--rounds R] NAME=default|paper|CONFIG.toml... FILE...");
    std::process::exit(2);
}

fn main() -> lfast::Result<()> {
    let mut args = std::env::args().skip(1);
    let mut rounds = 15usize;
    let (mut configs, mut files) = (Vec::new(), Vec::new());
    while let Some(a) = args.next() {
        if a == "--rounds" {
            rounds = args.next().and_then(|v| v.parse().ok()).filter(|&r| r > 0).unwrap_or_else(|| usage());
        } else if let Some((name, what)) = a.split_once('=') {
            let cfg = match what {
                "default" => Config::default(),
                "paper" => Config::paper(),
                path => Config::load(path)?,
            };
            configs.push((name.to_string(), CpuDetector::new(cfg)?));
        } else if a.starts_with('-') {
            usage();
        } else {
            files.push(a);
        }
    }
    if configs.is_empty() || files.is_empty() {
        usage();
    }
    let frames: Vec<Plane<u8>> = files.iter().map(lfast::image::load_gray).collect::<lfast::Result<_>>()?;
    let mut times = vec![Vec::with_capacity(rounds); configs.len()];
    let mut cpu = vec![Vec::with_capacity(rounds); configs.len()];
    let mut points = vec![0usize; configs.len()];
    for round in 0..=rounds {
        for (c, (_, det)) in configs.iter().enumerate() {
            let (t, c0) = (Instant::now(), cpu_ns());
            let mut n = 0;
            for f in &frames {
                n += black_box(det.detect_and_compute(f.view(), None)?.0.len());
            }
            let ms = t.elapsed().as_secs_f64() * 1e3 / frames.len() as f64;
            if round > 0 {
                times[c].push(ms);
                if let (Some(a), Some(b)) = (c0, cpu_ns()) {
                    cpu[c].push((b - a) as f64 / 1e6 / frames.len() as f64);
                }
            }
            points[c] = n;
        }
    }
    let min = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
    let median = |v: &[f64]| {
        let mut s = v.to_vec();
        s.sort_by(f64::total_cmp);
        s.get(s.len() / 2).copied()
    };
    let (base, cpu_base) = (min(&times[0]), min(&cpu[0]));
    let rows: Vec<_> = configs
        .iter()
        .zip(times.iter().zip(&cpu))
        .zip(&points)
        .map(|(((name, _), (t, c)), &n)| {
            let mut row = json!({
                "config": name,
                "min_ms": min(t),
                "median_ms": median(t),
                "mean_keypoints": n as f64 / frames.len() as f64,
                "min_vs_first": min(t) / base,
            });
            if !c.is_empty() {
                row["cpu_min_ms"] = json!(min(c));
                row["cpu_median_ms"] = json!(median(c));
                row["cpu_min_vs_first"] = json!(min(c) / cpu_base);
            }
            row
        })
        .collect();
    let out = json!({ "frames": frames.len(), "rounds": rounds, "configs": rows });
    println!("{}", serde_json::to_string_pretty(&out).expect("JSON"));
    Ok(())
}

/// On-CPU time of every thread of this process so far, in nanoseconds (the
/// first field of `/proc/self/task/*/schedstat`); `None` where there is none.
fn cpu_ns() -> Option<u64> {
    let mut total = 0u64;
    for t in std::fs::read_dir("/proc/self/task").ok()? {
        let stat = std::fs::read_to_string(t.ok()?.path().join("schedstat")).ok()?;
        total += stat.split_whitespace().next()?.parse::<u64>().ok()?;
    }
    Some(total)
}
