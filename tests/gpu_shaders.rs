//! Every shader parses and validates with naga, has a compute entry point,
//! and declares exactly the bindings its pass struct binds; on a device, a
//! shader that does not compile or a pipeline that fails validation makes
//! the build an error naming it.
//!
//! Run the device tests with `WGPU_ADAPTER_NAME=llvmpipe REQUIRE_GPU=1 cargo test --test gpu_shaders`.

use lfast::gpu::SHADERS;
use lfast::gpu::kernel::{Binding, PARAMS, Slot, b, full_source};
use lfast::gpu::stages::build_kernels;
use lfast::testing as t;
use naga::{AddressSpace, StorageAccess};

fn module(name: &str, source: &str) -> naga::Module {
    let src = full_source(source);
    let m = naga::front::wgsl::parse_str(&src).unwrap_or_else(|e| panic!("{name}.wgsl: {}", e.emit_to_string(&src)));
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::empty())
        .validate(&m)
        .unwrap_or_else(|e| panic!("{name}.wgsl does not validate: {e:?}"));
    m
}

#[test]
fn every_shader_validates_and_has_an_entry_point() {
    assert_eq!(SHADERS.len(), 22);
    for s in SHADERS {
        let m = module(s.name, s.source);
        assert!(
            m.entry_points.iter().any(|e| e.stage == naga::ShaderStage::Compute),
            "{}.wgsl has no compute entry point",
            s.name
        );
        for e in &m.entry_points {
            let [x, y, z] = e.workgroup_size;
            assert!(
                x * y * z <= 256,
                "{}::{}: workgroup of {} invocations exceeds wgpu's default limit",
                s.name,
                e.name,
                x * y * z
            );
        }
    }
}

#[test]
fn reflected_bindings_match_the_pass_structs() {
    for s in SHADERS {
        let m = module(s.name, s.source);
        let mut found: Vec<(u32, String, Slot)> = m
            .global_variables
            .iter()
            .filter_map(|(_, g)| {
                let rb = g.binding.as_ref()?;
                assert_eq!(rb.group, 0, "{}: {:?} not in group 0", s.name, g.name);
                let slot = match g.space {
                    AddressSpace::Uniform => Slot::Uniform,
                    AddressSpace::Storage { access } if access.contains(StorageAccess::STORE) => Slot::ReadWrite,
                    AddressSpace::Storage { .. } => Slot::Read,
                    AddressSpace::Handle => Slot::Texture,
                    other => panic!("{}: unexpected address space {other:?}", s.name),
                };
                Some((rb.binding, g.name.clone().unwrap_or_default(), slot))
            })
            .collect();
        found.sort_by_key(|f| f.0);
        let mut declared: Vec<(u32, String, Slot)> = s
            .bindings
            .iter()
            .map(|b| {
                (b.binding, b.name.to_string(), if b.slot == Slot::UniformDynamic { Slot::Uniform } else { b.slot })
            })
            .collect();
        declared.sort_by_key(|f| f.0);
        assert_eq!(found, declared, "{}: shader bindings vs src/gpu/{}.rs BINDINGS", s.name, s.name);
    }
}

// ---------------------------------------------------------------------------
// build errors on a device (each kernel built on its own thread, as the
// detector's stages are)

const OUT: &[Binding] = &[PARAMS, b(1, "out", Slot::ReadWrite)];
/// The same shader's output declared read-only: the layout contradicts it.
const OUT_READ_ONLY: &[Binding] = &[PARAMS, b(1, "out", Slot::Read)];

const GOOD: &str = "@group(0) @binding(1) var<storage, read_write> out: array<u32>;
@compute @workgroup_size(64) fn main(@builtin(global_invocation_id) id: vec3<u32>) { out[id.x] = P.n_levels; }";
/// Does not parse: shader module creation fails.
const SYNTAX: &str = "@group(0) @binding(1) var<storage, read_write> out: array<u32>;
@compute @workgroup_size(64) fn main(@builtin(global_invocation_id) id: vec3<u32>) { out[id.x] = ; }";
/// Parses but does not type-check (u32 = f32).
const TYPES: &str = "@group(0) @binding(1) var<storage, read_write> out: array<u32>;
@compute @workgroup_size(64) fn main(@builtin(global_invocation_id) id: vec3<u32>) { out[id.x] = 1.5; }";
/// Compiles, but has no entry point `main`: the pipeline fails validation.
const NO_MAIN: &str = "@group(0) @binding(1) var<storage, read_write> out: array<u32>;
@compute @workgroup_size(64) fn other(@builtin(global_invocation_id) id: vec3<u32>) { out[id.x] = 0u; }";

#[test]
fn good_kernels_build_on_their_threads() {
    let Some(ctx) = t::context() else { return };
    build_kernels(&ctx.device, &[("good_a", GOOD, OUT), ("good_b", GOOD, OUT)]).expect("valid kernels build");
}

#[test]
fn a_shader_that_does_not_compile_is_an_error_naming_it() {
    let Some(ctx) = t::context() else { return };
    for (name, source) in [("broken_syntax", SYNTAX), ("broken_types", TYPES)] {
        let e = build_kernels(&ctx.device, &[("good", GOOD, OUT), (name, source, OUT)])
            .expect_err("a shader that does not compile must fail the build")
            .to_string();
        assert!(e.contains(&format!("stage `{name}`")), "{name}: error does not name the stage: {e}");
        assert!(!e.contains("stage `good`"), "{name}: the valid kernel is blamed too: {e}");
    }
}

#[test]
fn a_pipeline_that_fails_validation_is_an_error_naming_it() {
    let Some(ctx) = t::context() else { return };
    let e = build_kernels(&ctx.device, &[("no_main", NO_MAIN, OUT), ("good", GOOD, OUT)])
        .expect_err("a missing entry point must fail the build")
        .to_string();
    assert!(e.contains("stage `no_main`") && !e.contains("stage `good`"), "{e}");
    let e = build_kernels(&ctx.device, &[("read_only_out", GOOD, OUT_READ_ONLY)])
        .expect_err("a layout that contradicts the shader must fail the build")
        .to_string();
    assert!(e.contains("stage `read_only_out`"), "{e}");
}

#[test]
fn every_failing_kernel_is_named() {
    let Some(ctx) = t::context() else { return };
    let e = build_kernels(&ctx.device, &[("first", SYNTAX, OUT), ("ok", GOOD, OUT), ("second", NO_MAIN, OUT)])
        .expect_err("two broken kernels")
        .to_string();
    assert!(e.contains("stage `first`") && e.contains("stage `second`") && !e.contains("stage `ok`"), "{e}");
}

#[test]
fn the_detector_builds_every_stage_without_error() {
    let Some(ctx) = t::context() else { return };
    lfast::gpu::GpuDetector::new(ctx, lfast::Config::default()).expect("every stage builds");
}
