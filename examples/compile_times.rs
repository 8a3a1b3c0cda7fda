//! What each stage's pipelines cost to create on the chosen adapter, one
//! stage after another on one thread: as the detector builds the stage
//! (`gpu::time_each_stage`), then split into the shader module (naga's WGSL
//! front end, validation) and each entry point's compute pipeline (naga's
//! SPIR-V and the driver's compile). A detector builds every stage's pipelines at its
//! start (`gpu::stages`, a thread per stage), so on a software adapter,
//! where the driver's compile is CPU work, this is part of every run of the
//! CLI; the table says which shaders to make cheaper to compile.
//!
//! ```text
//! WGPU_BACKEND=vulkan WGPU_ADAPTER_NAME=llvmpipe cargo run --release --example compile_times
//! ```
//!
//! Wall-clock milliseconds, best of `--rounds N` (default 3). A stage's
//! module may hold entry points the detector does not build (snap's holds
//! response's `main`): the "built" column is what the detector pays. The
//! WGSL is parsed once per process (`gpu::kernel::compile`; `GpuContext::new`
//! starts parsing every shader on a thread of its own), so the best rounds
//! show the module's validation only: `--rounds 1` right after the context
//! may still include some shaders' parsing.

use lfast::gpu::{GpuContext, GpuOptions, SHADERS, kernel, time_each_stage};
use lfast::wgpu;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let mut rounds = 3usize;
    while let Some(a) = args.next() {
        match a.as_str() {
            "--rounds" => rounds = args.next().ok_or("--rounds N")?.parse::<usize>()?.max(1),
            other => return Err(format!("unknown argument {other}; usage: compile_times [--rounds N]").into()),
        }
    }
    let ctx = GpuContext::new(&GpuOptions::default())?;
    let device = &ctx.device;
    println!("adapter: {}; best of {rounds}, ms on one thread", ctx.info.name);
    // each stage as the detector builds it (its module and the pipelines it uses)
    let mut stage_ms: Vec<(&str, f64)> = Vec::new();
    for _ in 0..rounds {
        let mut k = 0;
        time_each_stage(device, |name, s| {
            match stage_ms.get_mut(k) {
                Some((_, best)) => *best = best.min(s * 1e3),
                None => stage_ms.push((name, s * 1e3)),
            }
            k += 1;
        });
    }
    println!("{:<16} {:>6}  every entry point of its module, one pipeline each", "stage", "built");
    for &(name, built) in &stage_ms {
        let s = SHADERS.iter().find(|s| s.name == name).ok_or("a stage without its shader")?;
        println!("{name:<16} {built:>6.1}  {}", entry_points(device, s.source, rounds)?);
    }
    println!("total {:.1} ms", stage_ms.iter().map(|s| s.1).sum::<f64>());
    Ok(())
}

/// "module M, entry T, ..." for a stage's source: the shader module's
/// creation and each entry point's pipeline, best of `rounds`.
fn entry_points(device: &wgpu::Device, source: &str, rounds: usize) -> Result<String, Box<dyn std::error::Error>> {
    let names: Vec<String> =
        naga::front::wgsl::parse_str(&kernel::full_source(source))?.entry_points.into_iter().map(|e| e.name).collect();
    let mut module_ms = f64::MAX;
    let mut entry_ms = vec![f64::MAX; names.len()];
    for _ in 0..rounds {
        let t = Instant::now();
        let module = kernel::compile(device, "compile_times", source);
        module_ms = module_ms.min(ms(t));
        for (e, best) in names.iter().zip(&mut entry_ms) {
            let t = Instant::now();
            let _p = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(e),
                layout: None,
                module: &module,
                entry_point: Some(e),
                compilation_options: Default::default(),
                cache: None,
            });
            *best = best.min(ms(t));
        }
    }
    let each: Vec<String> = names.iter().zip(&entry_ms).map(|(e, t)| format!("{e} {t:.1}")).collect();
    Ok(format!("module {module_ms:.1}, {}", each.join(", ")))
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}
