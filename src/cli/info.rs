//! `lfast info`: GPU adapters, the one chosen and its limits, the CPU fallback,
//! and with `--size` the GPU workspace of a frame size.

use super::CliError;
use crate::config::Config;
use crate::gpu::{AutoChoice, GpuContext, GpuOptions, auto_choice, is_hardware, list_adapters, workspace_report};
use std::path::Path;

/// `WxH` (e.g. `3840x2160`) as `(width, height)`.
pub(super) fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("`{s}` is not a frame size WxH, e.g. 3840x2160");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let (w, h) = (w.trim().parse::<u32>().map_err(|_| bad())?, h.trim().parse::<u32>().map_err(|_| bad())?);
    if w == 0 || h == 0 {
        return Err(format!("`{s}`: width and height must be at least 1"));
    }
    Ok((w, h))
}

/// Megabytes (10^6 bytes) with one decimal.
fn mb(bytes: u64) -> String {
    format!("{:.1} MB", bytes as f64 / 1e6)
}

/// Prints the GPU workspace of each size under `cfg`, and whether it fits
/// wgpu's default limits and `limits` (the opened adapter's) when given.
fn print_workspaces(cfg: &Config, sizes: &[(u32, u32)], limits: Option<&crate::wgpu::Limits>) -> Result<(), CliError> {
    for &(w, h) in sizes {
        let r = workspace_report(cfg, w, h)?;
        let (name, largest) = r.largest();
        println!(
            "GPU workspace for {w}x{h}: {} ({:.1} bytes per pixel), largest buffer `{name}` {}; storage bindings up to {}",
            mb(r.total()),
            r.bytes_per_pixel(),
            mb(largest),
            mb(r.largest_storage)
        );
        let verdict = |l: &crate::wgpu::Limits| match r.fits(l) {
            Ok(()) => "fits".to_string(),
            Err(e) => format!("does not fit: {e}"),
        };
        println!("  wgpu's default limits: {}", verdict(&crate::wgpu::Limits::default()));
        if let Some(l) = limits {
            println!("  this adapter's limits: {}", verdict(l));
        }
    }
    Ok(())
}

/// Prints what this machine offers; `adapter` as `--adapter`; the GPU
/// workspace of each of `sizes` under the config file `config` (or the default).
pub(super) fn run(adapter: Option<String>, sizes: &[(u32, u32)], config: Option<&Path>) -> Result<bool, CliError> {
    let cfg = match config {
        Some(p) => Config::load(p)?,
        None => Config::default(),
    };
    cfg.validate()?;
    println!("lfast {} (wgpu 30)", env!("CARGO_PKG_VERSION"));
    let opts = GpuOptions { adapter_name: adapter, ..Default::default() };
    let env = |k: &str| std::env::var(k).unwrap_or_else(|_| "(unset)".into());
    println!("WGPU_BACKEND={} WGPU_ADAPTER_NAME={}", env("WGPU_BACKEND"), env("WGPU_ADAPTER_NAME"));
    let all = list_adapters(&opts);
    println!("GPU adapters found: {}", all.len());
    for a in &all {
        let kind = if is_hardware(a) { "hardware" } else { "software or unknown: never taken by auto unless named" };
        println!(
            "  - {} ({:?}, {:?}, {kind}, driver {} {})",
            a.name, a.backend, a.device_type, a.driver, a.driver_info
        );
    }
    match auto_choice(&opts) {
        AutoChoice::Gpu { info, named: true } => {
            println!("--backend auto uses: gpu on {} (named by --adapter or WGPU_ADAPTER_NAME)", info.name)
        }
        AutoChoice::Gpu { info, named: false } => {
            println!("--backend auto uses: gpu on {} ({:?}, the best hardware adapter)", info.name, info.device_type)
        }
        AutoChoice::Cpu(why) => println!("--backend auto uses: cpu ({why})"),
    }
    let mut limits = None;
    match GpuContext::new(&opts) {
        Ok(ctx) => {
            let l = ctx.device.limits();
            limits = Some(l.clone());
            println!("--backend gpu opens: {} ({:?}, {:?})", ctx.info.name, ctx.info.backend, ctx.info.device_type);
            println!(
                "  limits: max buffer {} MiB, storage binding {} MiB, workgroups per dimension {}, invocations per workgroup {}",
                l.max_buffer_size >> 20,
                l.max_storage_buffer_binding_size >> 20,
                l.max_compute_workgroups_per_dimension,
                l.max_compute_invocations_per_workgroup
            );
            println!("  per-pass timestamps: {}", if ctx.has_timestamps() { "yes" } else { "no" });
        }
        Err(e) => println!("--backend gpu opens: none ({e}); it exits with code 2"),
    }
    println!("rayon threads: {}", rayon::current_num_threads());
    println!("CPU features: {}", cpu_features());
    println!("{}", simd_line());
    print_workspaces(&cfg, sizes, limits.as_ref())?;
    Ok(true)
}

/// Which build of the row kernels runs, and why (`LFAST_SIMD`).
fn simd_line() -> String {
    use crate::cpu::simd::{Tier, detected_tier, tier};
    let why = match std::env::var("LFAST_SIMD") {
        Err(std::env::VarError::NotPresent) => String::new(),
        Ok(v) if Tier::from_name(&v).is_some() => format!(" (LFAST_SIMD={v})"),
        Ok(v) => format!(" (LFAST_SIMD={v} is not baseline, avx2 or avx512: ignored)"),
        Err(_) => " (LFAST_SIMD is not UTF-8: ignored)".into(),
    };
    format!("CPU kernels: the {} build, of {} this CPU allows{why}", tier().name(), detected_tier().name())
}

#[cfg(target_arch = "x86_64")]
fn cpu_features() -> String {
    let yn = |b: bool| if b { "yes" } else { "no" };
    format!(
        "x86_64, avx512 (F, BW, CD, DQ, VL) {}, avx2 {}, fma {}, sse4.1 {}",
        yn(crate::cpu::simd::detected_tier() == crate::cpu::simd::Tier::Avx512),
        yn(std::arch::is_x86_feature_detected!("avx2")),
        yn(std::arch::is_x86_feature_detected!("fma")),
        yn(std::arch::is_x86_feature_detected!("sse4.1"))
    )
}

#[cfg(target_arch = "aarch64")]
fn cpu_features() -> String {
    format!("aarch64, neon {}, avx2 no", if std::arch::is_aarch64_feature_detected!("neon") { "yes" } else { "no" })
}

#[cfg(not(any(target_arch = "x86_64", target_arch = "aarch64")))]
fn cpu_features() -> String {
    format!("{}, avx2 no", std::env::consts::ARCH)
}
