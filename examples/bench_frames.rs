//! Times the CPU pipeline over a list of image files and prints JSON to stdout.
//!
//! ```text
//! cargo run --release --example bench_frames -- [--repeats R] [--only METHOD] [--keypoints KPS.json] FILE...
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
//! - `orb_baseline`: `baseline::orb::OrbDetector` with `n_features = 2000`;
//! - `edges_pyramid`: the fused edge path on each of the 8 levels of the
//!   default pyramid (built once per frame before timing, as the OpenCV side's),
//!   level after level with a scratch per level as `detect` keeps them;
//!   with `describe`, the floor analysis of `scripts/bench_opencv.py`;
//! - `describe`: `CpuDetector::compute` on the frame's own L-FAST keypoints
//!   (found before timing): pyramid, blur, orientation and rBRIEF;
//! - `describe_opencv` (with `--keypoints`): `CpuDetector::compute` with
//!   `descriptor = "opencv"` on the keypoints of `KPS.json`, one list per
//!   file in the files' order, each keypoint `[x, y, size, angle, response,
//!   octave]` (cv2 ORB's, as `scripts/bench_opencv.py` writes them): OpenCV's
//!   pyramid, blur and rotated rBRIEF, against cv2's `compute()` on the same
//!   keypoints; the mean count is of keypoints described.
//!
//! `scripts/bench_opencv.py` runs this and times OpenCV on the same frames.

use lfast::baseline::orb::{OrbDetector, OrbParams};
use lfast::config::DELTA_DEN;
use lfast::cpu::{CpuDetector, fused, pyramid};
use lfast::{Config, Plane};
use serde_json::json;
use std::hint::black_box;
use std::time::Instant;

fn usage() -> ! {
    eprintln!(
        "usage: bench_frames [--repeats R] [--only edges|lfast_detect_and_compute|orb_baseline|edges_pyramid|describe|describe_opencv] [--keypoints KPS.json] FILE..."
    );
    std::process::exit(2);
}

/// Runs `f` on every frame once (warm-up), then `repeats` times; returns ms per frame of each timed pass.
fn time_passes(frames: &[Plane<u8>], repeats: usize, mut f: impl FnMut(&Plane<u8>) -> usize) -> (Vec<f64>, f64) {
    time_indexed(frames.len(), repeats, |i| f(&frames[i]))
}

/// [`time_passes`] over frame indices `0..n` (for inputs prepared per frame).
fn time_indexed(n: usize, repeats: usize, mut f: impl FnMut(usize) -> usize) -> (Vec<f64>, f64) {
    let mut count = 0usize;
    for i in 0..n {
        count += black_box(f(i));
    }
    let mut per_frame = Vec::with_capacity(repeats);
    for _ in 0..repeats {
        let t = Instant::now();
        for i in 0..n {
            black_box(f(i));
        }
        per_frame.push(t.elapsed().as_secs_f64() * 1e3 / n as f64);
    }
    (per_frame, count as f64 / n as f64)
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
    let mut keypoints: Option<String> = None;
    while let Some(a) = args.next() {
        match a.as_str() {
            "--keypoints" => keypoints = Some(args.next().unwrap_or_else(|| usage())),
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

    const METHODS: [&str; 6] =
        ["edges", "lfast_detect_and_compute", "orb_baseline", "edges_pyramid", "describe", "describe_opencv"];
    if only.as_deref().is_some_and(|m| !METHODS.contains(&m)) {
        usage();
    }
    let run = |m: &str| only.as_deref().is_none_or(|o| o == m);
    let mut methods = serde_json::Map::new();
    let edge_count = |e: &Plane<u8>| {
        // a vectorised count (byte sums over chunks of 255): this runs inside the timed loop
        e.data.chunks(255).map(|c| c.iter().map(|&v| (v != 0) as u8).sum::<u8>() as usize).sum::<usize>()
    };
    if run(METHODS[0]) {
        let mut e = Plane::default();
        let (t, n) = time_passes(&frames, repeats, |img| {
            det.edge_image_into(img.view(), &mut e).expect("valid image");
            edge_count(&e)
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
    if run(METHODS[3]) {
        let pyramids: Vec<Vec<Plane<u8>>> = frames
            .iter()
            .map(|f| {
                let mut levels = Vec::new();
                pyramid::pyramid_into(f, &det.config().level_sizes(f.width, f.height), &mut levels);
                levels
            })
            .collect();
        // one scratch per level, as `detect` keeps them (each level keeps its size)
        let mut sc: Vec<fused::EdgeScratch> = Vec::new();
        let cfg = det.config();
        let (t, n) = time_indexed(frames.len(), repeats, |i| {
            sc.resize_with(pyramids[i].len(), Default::default);
            pyramids[i]
                .iter()
                .zip(&mut sc)
                .map(|(lv, sc)| {
                    fused::edges_fused_into(lv.view(), cfg.delta_num(), DELTA_DEN, cfg.alpha_pct, sc);
                    edge_count(&sc.edges)
                })
                .sum()
        });
        methods.insert(METHODS[3].into(), summary(&t, n, "mean_edge_pixels"));
    }
    if run(METHODS[4]) {
        let kps: Vec<_> = frames.iter().map(|f| det.detect(f.view(), None)).collect::<lfast::Result<_>>()?;
        let (t, n) = time_indexed(frames.len(), repeats, |i| {
            det.compute(frames[i].view(), &kps[i]).expect("own keypoints").len()
        });
        methods.insert(METHODS[4].into(), summary(&t, n, "mean_keypoints"));
    }
    if let Some(path) = keypoints.as_deref().filter(|_| run(METHODS[5])) {
        let kps = read_keypoints(path, frames.len())?;
        let ocv = CpuDetector::new(Config {
            descriptor: lfast::config::DescriptorKind::Opencv,
            orientation_bins: 0,
            ..Config::default()
        })?;
        let (t, n) = time_indexed(frames.len(), repeats, |i| {
            ocv.compute(frames[i].view(), &kps[i]).expect("valid keypoints").len()
        });
        methods.insert(METHODS[5].into(), summary(&t, n, "mean_keypoints"));
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

/// The keypoints of `--keypoints`: per frame, `[x, y, size, angle, response, octave]` rows.
fn read_keypoints(path: &str, frames: usize) -> lfast::Result<Vec<Vec<lfast::KeyPoint>>> {
    let bad = |reason: String| lfast::Error::Io { path: path.into(), source: std::io::Error::other(reason) };
    let text = std::fs::read_to_string(path).map_err(|e| lfast::Error::Io { path: path.into(), source: e })?;
    let rows: Vec<Vec<[f64; 6]>> = serde_json::from_str(&text).map_err(|e| bad(e.to_string()))?;
    if rows.len() != frames {
        return Err(bad(format!("{} keypoint lists for {frames} files", rows.len())));
    }
    Ok(rows
        .iter()
        .map(|f| {
            f.iter()
                .map(|&[x, y, size, angle, response, octave]| lfast::KeyPoint {
                    angle: angle as f32,
                    response: response as f32,
                    octave: octave as i32,
                    ..lfast::KeyPoint::new(x as f32, y as f32, size as f32)
                })
                .collect()
        })
        .collect())
}
