//! `lfast info`: backends and CPU features of this build.

use super::CliError;

/// Prints what this build can use.
pub(super) fn run() -> Result<bool, CliError> {
    println!("lfast {}", env!("CARGO_PKG_VERSION"));
    println!("GPU backend: not built in this version (no adapters enumerated; --backend gpu fails)");
    println!("backend in use: cpu (the CPU reference path; --backend auto and cpu both use it)");
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
