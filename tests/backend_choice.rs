//! `Backend::Auto` takes a hardware GPU or the CPU, never a software adapter
//! it was not asked for (src/gpu/context.rs `new_auto`, src/detector.rs;
//! `lfast info` says which and why). In CI the only adapter is lavapipe, so
//! there Auto must run on the CPU unless lavapipe is named, and run on it when
//! it is. On a machine with a hardware GPU, Auto must take that GPU.

mod common;

use common::{data, stdout};
use lfast::gpu::{GpuContext, GpuOptions, is_hardware, is_software, list_adapters};
use lfast::{Backend, Config, Detector};

fn hardware_present() -> bool {
    list_adapters(&GpuOptions::ignoring_env()).iter().any(is_hardware)
}

#[test]
fn auto_never_takes_an_unnamed_software_adapter() {
    let opts = GpuOptions::ignoring_env();
    let all = list_adapters(&opts);
    match GpuContext::new_auto(&opts) {
        Ok(ctx) => {
            assert!(is_hardware(&ctx.info), "auto opened {:?} ({:?})", ctx.info.name, ctx.info.device_type);
        }
        Err(e) => {
            assert!(!all.iter().any(is_hardware), "a hardware adapter exists in {all:?}, but auto failed: {e}");
            let msg = e.to_string();
            for a in all.iter().filter(|a| is_software(a)) {
                assert!(msg.contains(&a.name), "the reason names the software adapter {}: {msg}", a.name);
            }
        }
    }
    let det = Detector::with_gpu_options(Config::default(), Backend::Auto, &opts).unwrap();
    let want = if hardware_present() { "gpu" } else { "cpu" };
    assert_eq!(det.backend_name(), want, "adapters: {all:?}");
}

#[test]
fn a_named_software_adapter_is_taken_by_auto_and_gpu() {
    // lavapipe in CI (REQUIRE_GPU=1 makes its absence a failure there)
    let Some(ctx) = lfast::testing::context() else { return };
    let name = ctx.info.name.clone();
    let opts = GpuOptions { adapter_name: Some(name.clone()), ..GpuOptions::ignoring_env() };
    for backend in [Backend::Auto, Backend::Gpu] {
        let det = Detector::with_gpu_options(Config::default(), backend, &opts).unwrap();
        assert_eq!(det.backend_name(), "gpu", "{backend:?} with {name} named");
        assert_eq!(det.adapter_name().as_deref(), Some(name.as_str()));
    }
    // an explicit GPU request without a name may take a software adapter
    assert!(GpuContext::new(&GpuOptions::ignoring_env()).is_ok());
}

#[test]
fn a_name_that_matches_nothing_falls_back_in_auto_and_fails_in_gpu() {
    let opts = GpuOptions { adapter_name: Some("no such adapter 7f3a".into()), ..GpuOptions::ignoring_env() };
    let det = Detector::with_gpu_options(Config::default(), Backend::Auto, &opts).unwrap();
    assert_eq!(det.backend_name(), "cpu");
    let e = Detector::with_gpu_options(Config::default(), Backend::Gpu, &opts).unwrap_err();
    assert!(e.to_string().contains("no such adapter 7f3a"), "{e}");
}

/// The CLI with the environment's adapter name removed, as on a user's machine.
fn lfast_unnamed(args: &[&str]) -> std::process::Output {
    let mut c = std::process::Command::new(env!("CARGO_BIN_EXE_lfast"));
    c.env_remove("WGPU_ADAPTER_NAME").env_remove("WGPU_BACKEND");
    c.args(args).output().expect("the lfast binary runs")
}

#[test]
fn cli_auto_and_info_follow_the_rule() {
    let tmp = tempfile::tempdir().unwrap();
    let img = data("text.png");
    let img = img.to_str().unwrap();
    let out = tmp.path().join("auto");
    let o = lfast_unnamed(&["detect", img, "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    let info = stdout(&lfast_unnamed(&["info"]));
    if hardware_present() {
        assert!(stdout(&o).contains("backend gpu"), "{}", stdout(&o));
        assert!(info.contains("--backend auto uses: gpu on"), "{info}");
    } else {
        assert!(stdout(&o).contains("backend cpu"), "{}", stdout(&o));
        assert!(info.contains("--backend auto uses: cpu (no hardware GPU adapter"), "{info}");
    }
    // naming the software adapter is asking for it
    if let Some(ctx) = lfast::testing::context() {
        let name = ctx.info.name.clone();
        let out = tmp.path().join("named");
        let o = lfast_unnamed(&["detect", img, "--out", out.to_str().unwrap(), "--adapter", &name]);
        assert!(o.status.success(), "{}", common::stderr(&o));
        assert!(stdout(&o).contains("backend gpu"), "{}", stdout(&o));
        let info = stdout(&lfast_unnamed(&["info", "--adapter", &name]));
        assert!(info.contains(&format!("--backend auto uses: gpu on {name} (named")), "{info}");
        let read = |d: &std::path::Path| std::fs::read_to_string(d.join("text.json")).unwrap();
        assert_eq!(read(&out), read(&tmp.path().join("auto")), "named GPU and auto outputs differ");
    }
}
