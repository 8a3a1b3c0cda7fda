//! Compute pipelines with their bind group layouts, built once, and bind
//! groups whose buffers are given by name and checked against the shader's.

use crate::error::{Error, Result};

/// The WGSL prelude every stage shader is compiled with: the `Params`
/// uniform at binding 0 and the atlas helpers.
pub const COMMON: &str = include_str!("../../shaders/common.wgsl");

/// The kind of a binding slot.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Slot {
    /// `var<uniform>`, whole buffer.
    Uniform,
    /// `var<uniform>` bound with a dynamic offset (one 256-byte record per use).
    UniformDynamic,
    /// `var<storage, read>`.
    Read,
    /// `var<storage, read_write>`.
    ReadWrite,
    /// `texture_2d<f32>` read with `textureLoad` (no sampler).
    Texture,
}

/// One binding of a shader: its number, the name of the WGSL variable, its kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Binding {
    /// `@binding(n)` in group 0.
    pub binding: u32,
    /// The WGSL global's name; bind groups pass buffers under this name.
    pub name: &'static str,
    /// How it is accessed.
    pub slot: Slot,
}

/// Shorthand for the table of a pass's bindings.
pub const fn b(binding: u32, name: &'static str, slot: Slot) -> Binding {
    Binding { binding, name, slot }
}

/// The `Params` uniform every stage has at binding 0.
pub const PARAMS: Binding = b(0, "P", Slot::Uniform);

/// Size of one record of a dynamic-offset uniform (the minimum alignment wgpu guarantees).
pub const DYNAMIC_STRIDE: u64 = 256;

/// A shader's full source: the common prelude, the counters' slots
/// ([`counter::wgsl`](super::buffers::counter::wgsl)), `DESC_REACH`
/// ([`descriptor_reach`](crate::spec::pattern::descriptor_reach)), then the stage.
pub fn full_source(stage_source: &str) -> String {
    format!(
        "{COMMON}\n{}const DESC_REACH: i32 = {};\n\n{stage_source}",
        super::buffers::counter::wgsl(),
        crate::spec::pattern::descriptor_reach()
    )
}

/// Compiles a stage shader (prelude + `stage_source`) into a module.
/// Every pass compiles its shader through here: one place decides how.
///
/// A shader of [`SHADERS`](super::SHADERS) goes to wgpu as the naga module
/// its WGSL parses to ([`parse_shaders_in_background`]; parsed here if not
/// yet), so each is parsed once per process, not once per detector; wgpu
/// validates it as it does WGSL. If the WGSL does not parse, it goes to wgpu
/// as WGSL, whose error names the line.
pub fn compile(device: &wgpu::Device, label: &str, stage_source: &str) -> wgpu::ShaderModule {
    let source = match parsed(stage_source) {
        Some(module) => wgpu::ShaderSource::Naga(std::borrow::Cow::Owned(module)),
        None => wgpu::ShaderSource::Wgsl(full_source(stage_source).into()),
    };
    device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some(label), source })
}

/// [`SHADERS`](super::SHADERS)[i] parsed (`None`: it does not parse).
static PARSED: [std::sync::OnceLock<Option<naga::Module>>; super::SHADERS.len()] =
    [const { std::sync::OnceLock::new() }; super::SHADERS.len()];

/// The naga module of a shader of [`SHADERS`](super::SHADERS) (its full
/// source parsed once per process); `None` for another source or WGSL that
/// does not parse.
fn parsed(stage_source: &str) -> Option<naga::Module> {
    let i = super::SHADERS.iter().position(|s| s.source == stage_source)?;
    PARSED[i].get_or_init(|| naga::front::wgsl::parse_str(&full_source(stage_source)).ok()).clone()
}

/// Parses the stages' shaders (the first [`STAGES`](super::STAGES)`.len()` of
/// [`SHADERS`](super::SHADERS), in pipeline order; the standalone ones parse
/// when first compiled) on a thread of its own, once per process (later calls
/// return at once). `GpuContext::new` starts it
/// before opening the adapter: the Vulkan loader's start (~30 ms on one core
/// with lavapipe) leaves the other core free, and naga's WGSL front end is
/// most of what creating a shader module costs (~1.1 ms a shader on the
/// 2-vCPU VM, ~19 ms for a detector's 17). A detector built before it is
/// done parses what it needs itself, as [`compile`] does.
pub fn parse_shaders_in_background() {
    static STARTED: std::sync::Once = std::sync::Once::new();
    STARTED.call_once(|| {
        let parse = || {
            for s in &super::SHADERS[..super::STAGES.len()] {
                let _ = parsed(s.source);
            }
        };
        // no thread to spare: the builders parse as they go
        let _ = std::thread::Builder::new().name("lfast-wgsl".into()).spawn(parse);
    });
}

/// A compute pipeline and the layout of its single bind group.
#[derive(Debug)]
pub struct Kernel {
    /// The pipeline.
    pub pipeline: wgpu::ComputePipeline,
    /// Its bind group layout (group 0).
    pub layout: wgpu::BindGroupLayout,
    bindings: &'static [Binding],
    label: String,
}

impl Kernel {
    /// Compiles entry point `entry` of `stage_source` (without the prelude).
    pub fn new(
        device: &wgpu::Device,
        label: &str,
        stage_source: &str,
        entry: &str,
        bindings: &'static [Binding],
    ) -> Self {
        let module = compile(device, label, stage_source);
        Self::from_module(device, label, &module, entry, bindings)
    }

    /// A kernel from an already compiled module (several entry points of one shader).
    pub fn from_module(
        device: &wgpu::Device,
        label: &str,
        module: &wgpu::ShaderModule,
        entry: &str,
        bindings: &'static [Binding],
    ) -> Self {
        let entries: Vec<wgpu::BindGroupLayoutEntry> = bindings
            .iter()
            .map(|bd| wgpu::BindGroupLayoutEntry {
                binding: bd.binding,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: match bd.slot {
                    Slot::Uniform => wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    Slot::UniformDynamic => wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: true,
                        min_binding_size: wgpu::BufferSize::new(16),
                    },
                    Slot::Texture => wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: false },
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    Slot::Read | Slot::ReadWrite => wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Storage { read_only: bd.slot == Slot::Read },
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                },
                count: None,
            })
            .collect();
        let layout =
            device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some(label), entries: &entries });
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(label),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(label),
            layout: Some(&pl),
            module,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            cache: None,
        });
        Self { pipeline, layout, bindings, label: label.to_string() }
    }

    /// The bindings this kernel was built with.
    pub fn bindings(&self) -> &'static [Binding] {
        self.bindings
    }

    /// A bind group from buffers named as the shader's variables, in any order.
    /// A missing or unknown name is an error naming it (a bug in the pass, not in user input).
    pub fn bind(&self, device: &wgpu::Device, buffers: &[(&str, &wgpu::Buffer)]) -> Result<wgpu::BindGroup> {
        self.bind_with(device, buffers, &[])
    }

    /// [`bind`](Self::bind) from a list that may name more buffers than this
    /// kernel binds (the buffers of every entry point of a module): those its
    /// bindings name, the others ignored.
    pub fn bind_from(&self, device: &wgpu::Device, buffers: &[(&str, &wgpu::Buffer)]) -> Result<wgpu::BindGroup> {
        let mine: Vec<_> =
            buffers.iter().copied().filter(|(n, _)| self.bindings.iter().any(|bd| bd.name == *n)).collect();
        self.bind(device, &mine)
    }

    /// [`bind`](Self::bind) with textures too, also by name.
    pub fn bind_with(
        &self,
        device: &wgpu::Device,
        buffers: &[(&str, &wgpu::Buffer)],
        textures: &[(&str, &wgpu::TextureView)],
    ) -> Result<wgpu::BindGroup> {
        let mut entries = Vec::with_capacity(self.bindings.len());
        for bd in self.bindings {
            if bd.slot == Slot::Texture {
                let view = textures.iter().find(|(n, _)| *n == bd.name).map(|(_, t)| *t).ok_or_else(|| Error::Gpu {
                    reason: format!("pass {}: no texture given for binding `{}`", self.label, bd.name),
                })?;
                entries.push(wgpu::BindGroupEntry {
                    binding: bd.binding,
                    resource: wgpu::BindingResource::TextureView(view),
                });
                continue;
            }
            let buf = buffers.iter().find(|(n, _)| *n == bd.name).map(|(_, b)| *b).ok_or_else(|| Error::Gpu {
                reason: format!("pass {}: no buffer given for binding `{}`", self.label, bd.name),
            })?;
            let resource = if bd.slot == Slot::UniformDynamic {
                wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: buf,
                    offset: 0,
                    size: wgpu::BufferSize::new(16),
                })
            } else {
                buf.as_entire_binding()
            };
            entries.push(wgpu::BindGroupEntry { binding: bd.binding, resource });
        }
        let names = buffers.iter().map(|(n, _)| *n).chain(textures.iter().map(|(n, _)| *n));
        if let Some(n) = names.clone().find(|n| !self.bindings.iter().any(|bd| bd.name == *n)) {
            return Err(Error::Gpu { reason: format!("pass {}: shader has no binding `{n}`", self.label) });
        }
        Ok(device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(&self.label),
            layout: &self.layout,
            entries: &entries,
        }))
    }

    /// Sets the pipeline and bind group and dispatches `groups` workgroups.
    pub fn dispatch(&self, pass: &mut wgpu::ComputePass<'_>, bg: &wgpu::BindGroup, groups: [u32; 3]) {
        if groups.contains(&0) && !warming_up() {
            return;
        }
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, bg, &[]);
        dispatch_or_warm(pass, groups);
    }

    /// As [`dispatch`](Self::dispatch) with the bind group's dynamic offset.
    pub fn dispatch_at(&self, pass: &mut wgpu::ComputePass<'_>, bg: &wgpu::BindGroup, offset: u32, groups: [u32; 3]) {
        if groups.contains(&0) && !warming_up() {
            return;
        }
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, bg, &[offset]);
        dispatch_or_warm(pass, groups);
    }

    /// Dispatches with the workgroup counts read from `indirect` at `offset`
    /// (sized on the GPU by an earlier pass, e.g. by the keypoint count).
    pub fn dispatch_indirect(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        bg: &wgpu::BindGroup,
        indirect: &wgpu::Buffer,
        offset: u64,
    ) {
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, bg, &[]);
        if warming_up() {
            pass.dispatch_workgroups(0, 0, 0);
        } else {
            pass.dispatch_workgroups_indirect(indirect, offset);
        }
    }
}

thread_local! {
    /// Set by [`warm_up`] on its thread: every dispatch recorded is empty.
    static WARMING_UP: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

fn warming_up() -> bool {
    WARMING_UP.with(|w| w.get())
}

fn dispatch_or_warm(pass: &mut wgpu::ComputePass<'_>, groups: [u32; 3]) {
    if warming_up() {
        pass.dispatch_workgroups(0, 0, 0);
    } else {
        pass.dispatch_workgroups(groups[0], groups[1], groups[2]);
    }
}

/// Runs `record` with every dispatch it records through [`Kernel`] made empty
/// (0 x 0 x 0 workgroups: bound and validated, nothing runs). A driver that
/// prepares a pipeline at its first dispatch, as lavapipe does (~30 ms of the
/// first frame for a detector's 37, one after another on its queue thread),
/// prepares it then: a detector warms each stage up as soon as it is built,
/// while the other stages still build (`stages::Passes::new`).
pub(crate) fn warm_up<R>(record: impl FnOnce() -> R) -> R {
    struct Reset;
    impl Drop for Reset {
        fn drop(&mut self) {
            WARMING_UP.with(|w| w.set(false));
        }
    }
    WARMING_UP.with(|w| w.set(true));
    let _reset = Reset;
    record()
}

/// A buffer holding `contents` (padded to 4 bytes), like wgpu's
/// `create_buffer_init` but without its panic when the device was just lost:
/// then the buffer is returned unfilled and the loss surfaces as
/// [`Error::DeviceLost`] at the next check.
pub fn init_buffer(device: &wgpu::Device, label: &str, contents: &[u8], usage: wgpu::BufferUsages) -> wgpu::Buffer {
    let size = (contents.len() as u64).next_multiple_of(4).max(4);
    let buf =
        device.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size, usage, mapped_at_creation: true });
    if let Ok(mut view) = buf.slice(..).get_mapped_range_mut() {
        view.slice(..contents.len()).copy_from_slice(contents);
    }
    buf.unmap();
    buf
}

/// Workgroups of `size` threads needed to cover `n` items.
pub fn groups(n: u32, size: u32) -> u32 {
    n.div_ceil(size)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn warm_up_holds_on_its_thread_only_and_ends_with_the_call() {
        assert!(!warming_up());
        let inside = warm_up(|| (warming_up(), std::thread::spawn(warming_up).join().unwrap()));
        assert_eq!(inside, (true, false), "set inside, on this thread only");
        assert!(!warming_up());
        // a panic inside resets it too
        let r = std::panic::catch_unwind(|| warm_up(|| panic!("inside")));
        assert!(r.is_err());
        assert!(!warming_up());
    }
}
