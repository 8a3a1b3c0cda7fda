//! GPU timings on real frames: per-pass times from timestamp queries,
//! single-frame latency (upload -> keypoints + descriptors in host memory),
//! the host side of the readback alone (a mapped staging buffer -> `Frame`),
//! and sustained throughput with frames in flight through the staging ring;
//! first the workspace's size (`lfast::gpu::workspace_report`).
//!
//! ```text
//! cargo run --release --example gpu_bench -- ../shared/data/kitti/seq01_000000-000050/image_0 --frames 50
//! ```
//! Options: `--frames N` (default 30), `--ring R` (frames in flight, default 3),
//! `--size WxH` (resize every frame first, bilinear: e.g. 1920x1080 from KITTI),
//! `--json FILE` (machine-readable results).

const USAGE: &str = "usage: gpu_bench DIR|IMAGE... [--frames N] [--ring R] [--size WxH] [--json FILE]
  DIR|IMAGE  PNG frames (a directory: its *.png, sorted)
  --frames N frames to use (default 30)
  --ring R   frames in flight for the sustained figure (default 3)
  --size WxH resize every frame first (bilinear), e.g. 1920x1080
  --json FILE write the results as JSON
Prints per-pass GPU times (timestamp queries), latency, the host-side readback
time, GPU time back to back, record + submit time and sustained throughput.";

use lfast::gpu::detector::{GpuDetector, GpuDetectorOptions, GpuInput, GpuWorkspace, STAGES};
use lfast::gpu::{Finish, GpuContext, GpuOptions, Ticket};
use lfast::{Config, Plane};
use std::collections::VecDeque;
use std::time::Instant;

fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

/// `p` resized to `w` x `h` (bilinear, the image crate's Triangle filter).
fn resize(p: &Plane<u8>, w: u32, h: u32) -> Result<Plane<u8>, Box<dyn std::error::Error>> {
    let src = image::GrayImage::from_raw(p.width, p.height, p.data.clone()).ok_or("frame size")?;
    let dst = image::imageops::resize(&src, w, h, image::imageops::FilterType::Triangle);
    Ok(Plane { width: w, height: h, data: dst.into_raw() })
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let mut inputs = Vec::new();
    let (mut frames, mut ring, mut json, mut size) = (30usize, 3usize, None::<String>, None::<(u32, u32)>);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--frames" => frames = args.next().ok_or("--frames N")?.parse()?,
            "--ring" => ring = args.next().ok_or("--ring R")?.parse()?,
            "--json" => json = Some(args.next().ok_or("--json FILE")?),
            "--size" => {
                let v = args.next().ok_or("--size WxH")?;
                let (w, h) = v.split_once('x').ok_or("--size WxH, e.g. 1920x1080")?;
                size = Some((w.parse()?, h.parse()?));
            }
            "-h" | "--help" => {
                println!("{USAGE}");
                return Ok(());
            }
            _ if a.starts_with('-') => return Err(format!("unknown option {a}\n{USAGE}").into()),
            _ => inputs.push(std::path::PathBuf::from(a)),
        }
    }
    let mut paths = Vec::new();
    for p in &inputs {
        if p.is_dir() {
            let mut v: Vec<_> = std::fs::read_dir(p)?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.extension().is_some_and(|e| e == "png"))
                .collect();
            v.sort();
            paths.extend(v);
        } else {
            paths.push(p.clone());
        }
    }
    if paths.is_empty() {
        return Err("give image files or a directory of PNGs".into());
    }
    let mut imgs: Vec<Plane<u8>> =
        paths.iter().take(frames.max(1)).map(lfast::image::load_gray).collect::<Result<_, _>>()?;
    if let Some((w, h)) = size {
        imgs = imgs.iter().map(|p| resize(p, w, h)).collect::<Result<_, _>>()?;
    }
    let (w, h) = (imgs[0].width, imgs[0].height);
    if imgs.iter().any(|i| (i.width, i.height) != (w, h)) {
        return Err("all frames must have the same size".into());
    }
    let ctx = GpuContext::new(&GpuOptions::default())?;
    println!("adapter: {} ({:?}), {} frames of {w}x{h}, ring {ring}", ctx.info.name, ctx.info.backend, imgs.len());
    let report = lfast::gpu::workspace_report(&Config::default(), w, h)?;
    let (largest, largest_bytes) = report.largest();
    println!(
        "workspace: {:.1} MB, {:.1} bytes per pixel; largest buffer `{largest}` {:.1} MB",
        report.total() as f64 / 1e6,
        report.bytes_per_pixel(),
        largest_bytes as f64 / 1e6
    );
    // per-pass times: a detector that records timestamp queries
    let prof = GpuDetector::with_options(
        ctx.clone(),
        Config::default(),
        GpuDetectorOptions { ring, profile: true, ..Default::default() },
    )?;
    let mut pws = Some(prof.workspace(w, h)?);
    for img in imgs.iter().take(3) {
        prof.detect_and_compute(&mut pws, img.view(), None)?; // warm-up: compilation, first allocations
    }
    let mut per_pass: Vec<Vec<f64>> = vec![Vec::new(); STAGES.len()];
    let mut gpu_total = Vec::new();
    for img in &imgs {
        let f = prof.detect_and_compute(&mut pws, img.view(), None)?;
        for (i, (_, ms)) in f.pass_ms.iter().enumerate() {
            per_pass[i].push(*ms);
        }
        gpu_total.push(f.pass_ms.iter().map(|p| p.1).sum::<f64>());
    }
    drop(pws);

    // the rest without timestamps, as an application runs it
    let det = GpuDetector::with_options(
        ctx.clone(),
        Config::default(),
        GpuDetectorOptions { ring, profile: false, ..Default::default() },
    )?;
    let mut slot = Some(det.workspace(w, h)?);
    for img in imgs.iter().take(3) {
        det.detect_and_compute(&mut slot, img.view(), None)?;
    }
    // latency: one frame at a time, upload to host-side results
    let mut lat = Vec::new();
    let mut kps = 0usize;
    for img in &imgs {
        let t = Instant::now();
        let f = det.detect_and_compute(&mut slot, img.view(), None)?;
        lat.push(t.elapsed().as_secs_f64() * 1e3);
        kps += f.keypoints.len();
    }
    let ws = slot.as_mut().ok_or("workspace")?;
    let ring = ws.ring_len();
    // host side of the readback alone: wait until the frame's staging buffer
    // is mapped, then time turning it into a Frame (count, casts, copies of
    // the used part, exact angles, unmap)
    let mut host = Vec::new();
    for img in &imgs {
        ws.write_gray(&ctx.queue, img.view())?;
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        det.encode(&mut enc, GpuInput::Written, ws)?;
        let tk = det.encode_readback(&mut enc, ws)?;
        ctx.queue.submit([enc.finish()]);
        det.start_readback(ws, tk)?;
        ctx.wait()?;
        let t = Instant::now();
        let f = det.finish_readback(ws, tk)?;
        host.push(t.elapsed().as_secs_f64() * 1e3);
        std::hint::black_box(f);
    }
    // GPU time per frame with nothing read back: every frame recorded and
    // submitted back to back, one wait at the end (gaps between passes included)
    let reps = 4;
    let mut encode_ms = Vec::new();
    ctx.wait()?;
    let t = Instant::now();
    for _ in 0..reps {
        for img in &imgs {
            let te = Instant::now();
            ws.write_gray(&ctx.queue, img.view())?;
            let mut enc = ctx.device.create_command_encoder(&Default::default());
            det.encode(&mut enc, GpuInput::Written, ws)?;
            ctx.queue.submit([enc.finish()]);
            encode_ms.push(te.elapsed().as_secs_f64() * 1e3);
        }
    }
    ctx.wait()?;
    let gpu_only = t.elapsed().as_secs_f64() * 1e3 / (reps * imgs.len()) as f64;
    // throughput: `ring` frames in flight, each read back a frame or more later
    let t = Instant::now();
    let mut pending = VecDeque::new();
    let (mut done, mut redone) = (0usize, 0usize);
    // a frame in flight, read back; one whose keypoints outgrew its copy, the
    // rest overwritten by a later frame, once more on its own, as the newest
    // frame (what Detector::stream does); whether it ran again
    let redeem = |slot: &mut Option<GpuWorkspace>,
                  (tk, index, again): (Ticket, wgpu::SubmissionIndex, &Plane<u8>)|
     -> Result<bool, Box<dyn std::error::Error>> {
        loop {
            match det.finish_frame(slot.as_mut().ok_or("workspace")?, tk)? {
                Finish::Done(_) => return Ok(false),
                // wait for this frame's submission only: later ones keep the device busy
                Finish::Pending => ctx.wait_for(index.clone())?,
                Finish::Overrun { .. } => {
                    det.detect_and_compute(slot, again.view(), None)?;
                    return Ok(true);
                }
            }
        }
    };
    for _ in 0..reps {
        for img in &imgs {
            if pending.len() == ring {
                let oldest = pending.pop_front().ok_or("ring")?;
                redone += usize::from(redeem(&mut slot, oldest)?);
                done += 1;
            }
            let ws = slot.as_mut().ok_or("workspace")?;
            ws.write_gray(&ctx.queue, img.view())?;
            let mut enc = ctx.device.create_command_encoder(&Default::default());
            det.encode(&mut enc, GpuInput::Written, ws)?;
            let tk = det.encode_readback(&mut enc, ws)?;
            let index = ctx.queue.submit([enc.finish()]);
            det.start_readback(ws, tk)?;
            pending.push_back((tk, index, img));
        }
    }
    while let Some(oldest) = pending.pop_front() {
        redone += usize::from(redeem(&mut slot, oldest)?);
        done += 1;
    }
    let secs = t.elapsed().as_secs_f64();

    // The minimum is printed beside the median: on a shared machine it is the
    // figure least disturbed by other tenants.
    println!("\nper-pass GPU time over {} frames, timestamp queries (median, minimum):", imgs.len());
    let mut rows = Vec::new();
    for (i, name) in STAGES.iter().enumerate() {
        let m = median(&mut per_pass[i]);
        let lo = per_pass[i].iter().copied().fold(f64::INFINITY, f64::min);
        println!("  {name:<16} {m:9.3} ms {lo:9.3} ms");
        rows.push(format!("\"{name}\": {m:.4}"));
    }
    let gpu = median(&mut gpu_total);
    let gpu_lo = gpu_total.iter().copied().fold(f64::INFINITY, f64::min);
    let l = median(&mut lat);
    let host_lo = host.iter().copied().fold(f64::INFINITY, f64::min);
    let host_ms = median(&mut host);
    let enc_ms = median(&mut encode_ms);
    let fps = done as f64 / secs;
    println!("  {:<16} {gpu:9.3} ms {gpu_lo:9.3} ms", "sum of passes");
    println!("\nlatency upload -> keypoints + descriptors on the host: {l:.3} ms (median)");
    println!(
        "host-side readback, mapped -> keypoints + descriptors: {host_ms:.4} ms (median), {host_lo:.4} ms (minimum)"
    );
    println!("GPU time per frame, back to back, no readback: {gpu_only:.3} ms");
    println!("CPU time to record + submit a frame: {enc_ms:.3} ms (median)");
    println!(
        "sustained, {} in flight: {fps:.1} frames/s ({:.3} ms per frame; {redone} of {done} frames run again: their keypoints outgrew the copy)",
        ring,
        1e3 / fps
    );
    println!("mean keypoints per frame: {:.1}", kps as f64 / imgs.len() as f64);
    if let Some(p) = json {
        let s = format!(
            "{{\"adapter\": \"{}\", \"frames\": {}, \"width\": {w}, \"height\": {h}, \"latency_ms\": {l:.4}, \"readback_host_ms\": {host_ms:.4}, \"gpu_only_ms\": {gpu_only:.4}, \"encode_ms\": {enc_ms:.4}, \"fps\": {fps:.2}, \"gpu_sum_ms\": {gpu:.4}, \"workspace_bytes\": {}, \"largest_buffer_bytes\": {largest_bytes}, \"passes_ms\": {{{}}}}}\n",
            ctx.info.name,
            imgs.len(),
            report.total(),
            rows.join(", ")
        );
        std::fs::write(p, s)?;
    }
    Ok(())
}
