//! Runs the detector over many frames in one process and samples its resident
//! memory and frame rate along the way (`scripts/soak.sh` runs it and checks
//! that the memory stays flat).
//!
//! ```text
//! cargo run --release --example soak -- [--backend cpu|gpu] [--frames N] [--samples S] [--size WxH] IMAGE
//! ```
//!
//! The frames are WxH windows (default 256x256) of IMAGE (cut at eight offsets along its
//! diagonal, so that consecutive frames differ), passed to
//! `Detector::detect_and_compute` as strided views of the one decoded image:
//! what is measured is the detector, not the decoder. Every `N / S` frames one
//! tab-separated line goes to stdout: frames done, seconds, resident set size
//! in KiB (`VmRSS` of `/proc/self/status`), frames/s over the last interval.

use lfast::{Backend, Config, Detector, GrayView};
use std::hint::black_box;
use std::time::Instant;

fn usage() -> ! {
    eprintln!("usage: soak [--backend cpu|gpu] [--frames N] [--samples S] [--size WxH] IMAGE");
    std::process::exit(2);
}

/// The resident set size of this process in KiB (0 where /proc is missing).
fn rss_kib() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        .unwrap_or(0)
}

fn main() {
    let mut args = std::env::args().skip(1);
    let (mut backend, mut frames, mut samples, mut image) = (Backend::Cpu, 1000u64, 100u64, None);
    let (mut w, mut h) = (256u32, 256u32);
    while let Some(a) = args.next() {
        let mut value = || args.next().unwrap_or_else(|| usage());
        match a.as_str() {
            "--backend" => {
                backend = match value().as_str() {
                    "cpu" => Backend::Cpu,
                    "gpu" => Backend::Gpu,
                    _ => usage(),
                }
            }
            "--frames" => frames = value().parse().unwrap_or_else(|_| usage()),
            "--samples" => samples = value().parse().unwrap_or_else(|_| usage()),
            "--size" => {
                let v = value();
                let (a, b) = v.split_once('x').unwrap_or_else(|| usage());
                (w, h) = (a.parse().unwrap_or_else(|_| usage()), b.parse().unwrap_or_else(|_| usage()));
            }
            _ if a.starts_with('-') => usage(),
            _ => image = Some(a),
        }
    }
    let Some(image) = image else { usage() };
    if frames == 0 || samples == 0 || w == 0 || h == 0 {
        usage();
    }
    let img = lfast::image::load_gray(&image).unwrap_or_else(|e| {
        eprintln!("soak: {e}");
        std::process::exit(1);
    });
    if img.width < w || img.height < h {
        eprintln!("soak: {image} is {}x{}, smaller than {w}x{h}", img.width, img.height);
        std::process::exit(1);
    }
    let det = Detector::new(Config::default(), backend).unwrap_or_else(|e| {
        eprintln!("soak: {e}");
        std::process::exit(1);
    });
    let stride = img.width as usize;
    // eight windows along the diagonal
    let offsets: Vec<usize> = (0..8)
        .map(|i| {
            let (x, y) = ((img.width - w) as usize * i / 7, (img.height - h) as usize * i / 7);
            y * stride + x
        })
        .collect();
    eprintln!(
        "soak: {frames} frames of {w}x{h} from {image} on {} ({})",
        det.backend_name(),
        det.adapter_name().unwrap_or_else(|| "cpu".into())
    );
    println!("frames\tseconds\trss_kib\tframes_per_s");
    let every = (frames / samples).max(1);
    let start = Instant::now();
    let (mut last_t, mut last_n, mut keypoints) = (0.0f64, 0u64, 0u64);
    for n in 1..=frames {
        let off = offsets[(n % 8) as usize];
        let view = GrayView::new(w, h, stride, &img.data[off..]).expect("a window inside the image");
        let (kps, desc) = det.detect_and_compute(view, None).unwrap_or_else(|e| {
            eprintln!("soak: frame {n}: {e}");
            std::process::exit(1);
        });
        keypoints += black_box(kps.len() + desc.len()) as u64 / 2;
        if n % every == 0 || n == frames {
            let t = start.elapsed().as_secs_f64();
            let fps = (n - last_n) as f64 / (t - last_t).max(1e-9);
            println!("{n}\t{t:.3}\t{}\t{fps:.1}", rss_kib());
            (last_t, last_n) = (t, n);
        }
    }
    eprintln!("soak: {keypoints} keypoints in {:.1} s", start.elapsed().as_secs_f64());
}
