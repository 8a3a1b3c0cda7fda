//! `lfast info`: GPU adapters, the one chosen and its limits, the CPU fallback.

use super::CliError;
use crate::gpu::{AutoChoice, GpuContext, GpuOptions, auto_choice, is_hardware, list_adapters};

/// Prints what this machine offers; `adapter` as `--adapter`.
pub(super) fn run(adapter: Option<String>) -> Result<bool, CliError> {
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
    match GpuContext::new(&opts) {
        Ok(ctx) => {
            let l = ctx.device.limits();
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
    Ok(true)
}

#[cfg(target_arch = "x86_64")]
fn cpu_features() -> String {
    let yn = |b: bool| if b { "yes" } else { "no" };
    format!(
        "x86_64, avx2 {}, fma {}, sse4.1 {}",
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
