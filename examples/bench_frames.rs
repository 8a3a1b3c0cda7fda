//! Times the CPU pipeline over a list of image files and prints JSON to stdout.
//!
//! ```text
//! cargo run --release --example bench_frames -- [--repeats R] [--only METHOD] FILE...
//! ```
//!
//! `--only METHOD` runs one method (for profiling it alone with `perf record`).
//!
//! For each method the frames are loaded once (decoding is not timed), the
//! whole list is run once to warm up, then `R` (default 5) more times; each
//! pass gives a time per frame (pass time / number of frames). Reported: the
//! median and the minimum of those `R` values, in ms per frame. Methods:
//!
//! - `edges`: `CpuDetector::edge_image_into` (SPEC 1-7 on level 0 only, fused path),
//!   one output plane reused from frame to frame as a video loop would;
//! - `lfast_detect_and_compute`: `CpuDetector::detect_and_compute`, default config;
//! - `orb_baseline`: `baseline::orb::OrbDetector` with `n_features = 2000`.
//!
//! `scripts/bench_opencv.py` runs this and times OpenCV on the same frames.

use lfast::baseline::orb::{OrbDetector, OrbParams};
use lfast::cpu::CpuDetector;
use lfast::{Config, Plane};
use serde_json::json;
use std::hint::black_box;
use std::time::Instant;

fn usage() -> ! {
    eprintln!("usage: bench_frames [--repeats R] [--only edges|lfast_detect_and_compute|orb_baseline] FILE...");
    std::process::exit(2);
}

/// Runs `f` on every frame once (warm-up), then `repeats` times; returns ms per frame of each timed pass.
fn time_passes(frames: &[Plane<u8>], repeats: usize, mut f: impl FnMut(&Plane<u8>) -> usize) -> (Vec<f64>, f64) {
    let mut count = 0usize;
    for img in frames {
        count += black_box(f(img));
    }
    let mut per_frame = Vec::with_capacity(repeats);
    for _ in 0..repeats {
        let t = Instant::now();
        for img in frames {
            black_box(f(img));
        }
        per_frame.push(t.elapsed().as_secs_f64() * 1e3 / frames.len() as f64);
    }
    (per_frame, count as f64 / frames.len() as f64)
}

fn summary(per_frame: &[f64], mean_count: f64, count_name: &str) -> serde_json::Value {
    let mut s = per_frame.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    let median = if n % 2 == 1 { s[n / 2] } else { (s[n / 2 - 1] + s[n / 2]) / 2.0 };
    json!({
        "median_ms": median,
        "min_ms": s[0],
        "passes_ms": per_frame,
        count_name: mean_count,
    })
}

fn main() -> lfast::Result<()> {
    let mut args = std::env::args().skip(1);
    let mut repeats = 5usize;
    let mut files = Vec::new();
    let mut only: Option<String> = None;
    while let Some(a) = args.next() {
        match a.as_str() {
            "--repeats" | "-r" => {
                repeats = args.next().and_then(|v| v.parse().ok()).filter(|&r| r > 0).unwrap_or_else(|| usage());
            }
            "--only" => only = Some(args.next().unwrap_or_else(|| usage())),
            "-h" | "--help" => usage(),
            _ => files.push(a),
        }
    }
    if files.is_empty() {
        usage();
    }
    let frames: Vec<Plane<u8>> = files.iter().map(lfast::image::load_gray).collect::<lfast::Result<_>>()?;

    let det = CpuDetector::new(Config::default())?;
    let orb = OrbDetector::new(OrbParams { n_features: 2000, ..OrbParams::default() })?;

    const METHODS: [&str; 3] = ["edges", "lfast_detect_and_compute", "orb_baseline"];
    if only.as_deref().is_some_and(|m| !METHODS.contains(&m)) {
        usage();
    }
    let run = |m: &str| only.as_deref().is_none_or(|o| o == m);
    let mut methods = serde_json::Map::new();
    if run(METHODS[0]) {
        let mut e = Plane::default();
        let (t, n) = time_passes(&frames, repeats, |img| {
            det.edge_image_into(img.view(), &mut e).expect("valid image");
            // a vectorised count (byte sums over chunks of 255): this runs inside the timed loop
            e.data.chunks(255).map(|c| c.iter().map(|&v| (v != 0) as u8).sum::<u8>() as usize).sum::<usize>()
        });
        methods.insert(METHODS[0].into(), summary(&t, n, "mean_edge_pixels"));
    }
    if run(METHODS[1]) {
        let (t, n) =
            time_passes(&frames, repeats, |img| det.detect_and_compute(img.view(), None).expect("valid image").0.len());
        methods.insert(METHODS[1].into(), summary(&t, n, "mean_keypoints"));
    }
    if run(METHODS[2]) {
        let (t, n) =
            time_passes(&frames, repeats, |img| orb.detect_and_compute(img.view()).expect("valid image").0.len());
        methods.insert(METHODS[2].into(), summary(&t, n, "mean_keypoints"));
    }

    let mut sizes: Vec<[u32; 2]> = frames.iter().map(|f| [f.width, f.height]).collect();
    sizes.sort_unstable();
    sizes.dedup();
    let out = json!({
        "frames": frames.len(),
        "sizes": sizes,
        "repeats": repeats,
        "threads": rayon::current_num_threads(),
        "methods": methods,
    });
    println!("{}", serde_json::to_string_pretty(&out).expect("JSON"));
    Ok(())
}
