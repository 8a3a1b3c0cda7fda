//! Every shader parses and validates with naga, has a compute entry point,
//! and declares exactly the bindings its pass struct binds.

use lfast::gpu::SHADERS;
use lfast::gpu::kernel::{Slot, full_source};
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
