//! Runs the detector over many frames in one process and samples its resident
//! memory and frame rate along the way (`scripts/soak.sh` runs it and checks
//! that the memory stays flat).
//!
//! ```text
//! cargo run --release --example soak -- [--backend cpu|gpu] [--frames N] [--samples S] [--size WxH] IMAGE
//! cargo run --release --example soak -- --write-bag BAG.mcap [--frames N] [--size WxH] IMAGE
//! ```
//!
//! `--write-bag` writes the same N windows instead, as `sensor_msgs/msg/Image`
//! mono8 messages (CDR) of the topic `/soak/image` at 30 Hz, in an MCAP file
//! (uncompressed chunks), for `scripts/soak.sh --bag` to run `lfast detect` over.
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
    let mut bag: Option<String> = None;
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
            "--write-bag" => bag = Some(value()),
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
    if let Some(bag) = bag {
        write_bag(&bag, &img, w, h, frames).unwrap_or_else(|e| {
            eprintln!("soak: {bag}: {e}");
            std::process::exit(1);
        });
        return;
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

/// Window `n` of the eight along the diagonal of `img`, `w` x `h`, as rows.
fn window(img: &lfast::Plane<u8>, w: u32, h: u32, n: u64) -> Vec<u8> {
    let i = (n % 8) as u32;
    let (x0, y0) = ((img.width - w) * i / 7, (img.height - h) * i / 7);
    (0..h).flat_map(|y| img.row(y0 + y)[x0 as usize..(x0 + w) as usize].to_vec()).collect()
}

/// `frames` windows as sensor_msgs/msg/Image mono8 messages in an MCAP file.
fn write_bag(
    path: &str,
    img: &lfast::Plane<u8>,
    w: u32,
    h: u32,
    frames: u64,
) -> Result<(), Box<dyn std::error::Error>> {
    const MSGDEF: &str = "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\nuint8 is_bigendian\nuint32 step\nuint8[] data\n================================================================================\nMSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n================================================================================\nMSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n";
    let file = std::io::BufWriter::new(std::fs::File::create(path)?);
    // uncompressed chunks: writing a 2 GB bag is then a matter of seconds
    let mut out = mcap::WriteOptions::new().profile("ros2").compression(None).create(file)?;
    let schema = out.add_schema("sensor_msgs/msg/Image", "ros2msg", MSGDEF.as_bytes())?;
    let channel = out.add_channel(schema, "/soak/image", "cdr", &Default::default())?;
    let t0 = 1_700_000_000_000_000_000u64;
    for n in 0..frames {
        let t = t0 + n * 33_333_333;
        // CDR little-endian: header (stamp, frame_id ""), height, width, encoding, is_bigendian, step, data
        let mut m = vec![0u8, 1, 0, 0];
        m.extend(((t / 1_000_000_000) as u32).to_le_bytes());
        m.extend(((t % 1_000_000_000) as u32).to_le_bytes());
        m.extend(1u32.to_le_bytes());
        m.extend([0, 0, 0, 0]);
        m.extend(h.to_le_bytes());
        m.extend(w.to_le_bytes());
        m.extend(6u32.to_le_bytes());
        m.extend(b"mono8\0");
        m.extend([0, 0]); // is_bigendian, padding
        m.extend(w.to_le_bytes());
        m.extend((w * h).to_le_bytes());
        m.extend(window(img, w, h, n));
        let header =
            mcap::records::MessageHeader { channel_id: channel, sequence: n as u32, log_time: t, publish_time: t };
        out.write_to_known_channel(&header, &m)?;
    }
    out.finish()?;
    Ok(())
}
