//! What a storage read costs on the chosen adapter: 1M u32 read as u32, as
//! vec2<u32> and as vec4<u32> from a storage buffer, and as texels of an
//! R32Uint texture, each by a column walk of 16 (or 8, 4) reads per
//! invocation. On lavapipe every storage access is a loop over the SIMD
//! group's lanes, so the count of accesses, not the bytes, sets a pass's
//! time (docs/gpu.md); this measures it.
//!
//! Then what other operations cost, 64 per invocation over 1M invocations
//! (scattered addresses in a 4 MB buffer), less a loop of arithmetic alone:
//! a load, a store, an atomic add (in storage and in workgroup memory), an
//! atomic load and store, a vector component picked by an index that
//! differs per lane against the same by selects; and a dispatch of one
//! workgroup (with wgpu's barrier between dispatches).
//!
//! ```text
//! WGPU_ADAPTER_NAME=llvmpipe cargo run --release --example load_costs
//! ```
//!
//! Wall-clock per dispatch (submit and wait, best of 10, four dispatches a
//! submit): a microbenchmark of the access, not of lfast.

use lfast::gpu::{GpuContext, GpuOptions};
use lfast::wgpu;
use std::time::Instant;

const W: u32 = 1024;
const H: u32 = 1024;

/// A shader reading column x of `src` in `n`-word elements, 16 / n reads per
/// invocation, as `ty` (the WGSL element type) or as a texture.
fn source(ty: &str, n: u32) -> String {
    let (decl, read) = if ty == "texture" {
        ("var src: texture_2d<u32>;".to_string(), "textureLoad(src, vec2<u32>(x, id.y * 16u + k), 0).x".to_string())
    } else {
        (format!("var<storage, read> src: array<{ty}>;"), format!("src[(id.y * {per}u + k) * {W}u + x]", per = 16 / n))
    };
    let acc = match n {
        1 => "acc",
        2 => "acc.x + acc.y",
        _ => "acc.x + acc.y + acc.z + acc.w",
    };
    let zero = if ty == "texture" { "0u".to_string() } else { format!("{ty}(0u)") };
    format!(
        "@group(0) @binding(0) {decl}
@group(0) @binding(1) var<storage, read_write> dst: array<u32>;
@compute @workgroup_size(64) fn main(@builtin(global_invocation_id) id: vec3<u32>) {{
  let x = id.x;
  var acc = {zero};
  for (var k = 0u; k < {per}u; k++) {{ acc += {read}; }}
  dst[id.y * {W}u + x] = {acc};
}}",
        per = 16 / n
    )
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let ctx = GpuContext::new(&GpuOptions::default())?;
    let (device, queue) = (&ctx.device, &ctx.queue);
    println!("adapter: {}; 1M u32 read per dispatch", ctx.info.name);
    let data: Vec<u32> = (0..W * H).map(|i| i.wrapping_mul(2654435761)).collect();
    let src = wgpu::util::DeviceExt::create_buffer_init(
        device,
        &wgpu::util::BufferInitDescriptor {
            label: None,
            contents: bytemuck::cast_slice(&data),
            usage: wgpu::BufferUsages::STORAGE,
        },
    );
    let dst = device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size: u64::from(W * H / 16 * 4),
        usage: wgpu::BufferUsages::STORAGE,
        mapped_at_creation: false,
    });
    let tex = device.create_texture(&wgpu::TextureDescriptor {
        label: None,
        size: wgpu::Extent3d { width: W, height: H, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::R32Uint,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    queue.write_texture(
        tex.as_image_copy(),
        bytemuck::cast_slice(&data),
        wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(W * 4), rows_per_image: None },
        tex.size(),
    );
    let view = tex.create_view(&Default::default());
    for (ty, n) in [("u32", 1), ("vec2<u32>", 2), ("vec4<u32>", 4), ("texture", 1)] {
        let pipeline = compile(device, &source(ty, n));
        let input = if ty == "texture" { wgpu::BindingResource::TextureView(&view) } else { src.as_entire_binding() };
        let bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: input },
                wgpu::BindGroupEntry { binding: 1, resource: dst.as_entire_binding() },
            ],
        });
        let mut best = f64::MAX;
        for _ in 0..10 {
            let mut enc = device.create_command_encoder(&Default::default());
            {
                let mut cp = enc.begin_compute_pass(&Default::default());
                cp.set_pipeline(&pipeline);
                cp.set_bind_group(0, &bg, &[]);
                for _ in 0..4 {
                    cp.dispatch_workgroups(W / 64, H / 16, 1);
                }
            }
            let t = Instant::now();
            queue.submit([enc.finish()]);
            device.poll(wgpu::PollType::wait_indefinitely())?;
            best = best.min(t.elapsed().as_secs_f64() * 1e3 / 4.0);
        }
        println!("  as {ty:<10} {best:.3} ms ({} reads)", W * H / n);
    }
    op_costs(&ctx)
}

/// The operations of [`op_costs`], each 64 times per invocation at scattered
/// addresses (`i`) of `buf` / `abuf` (1M words) or the workgroup's `sh`.
const OPS: &str = "
@group(0) @binding(0) var<storage, read_write> buf: array<u32>;
@group(0) @binding(1) var<storage, read_write> abuf: array<atomic<u32>>;
@group(0) @binding(2) var<storage, read_write> out: array<u32>;
var<workgroup> sh: array<atomic<u32>, 256>;
fn pick(v: vec4<u32>, c: u32) -> u32 { return select(select(select(v.w, v.z, c == 2u), v.y, c == 1u), v.x, c == 0u); }
@compute @workgroup_size(64) fn main(@builtin(global_invocation_id) id: vec3<u32>) {
  var s = 0u;
  var i = id.x * 3u;
  let v = vec4<u32>(id.x, id.x * 3u, id.x * 5u, id.x * 7u);
  for (var k = 0u; k < 64u; k++) {
    let a = i & 0xfffffu;
    OP;
    i += 4099u;
  }
  out[id.x] = s + buf[id.x] + atomicLoad(&abuf[id.x]) + atomicLoad(&sh[id.x & 255u]);
}";

/// Per lane-operation cost of each of [`OPS`]' operations, the arithmetic
/// loop's subtracted, and the cost of a small dispatch.
fn op_costs(ctx: &GpuContext) -> Result<(), Box<dyn std::error::Error>> {
    let (device, queue) = (&ctx.device, &ctx.queue);
    let words = 1u64 << 20;
    let storage = |usage| {
        device.create_buffer(&wgpu::BufferDescriptor { label: None, size: words * 4, usage, mapped_at_creation: false })
    };
    let buffers = [0, 1, 2].map(|_| storage(wgpu::BufferUsages::STORAGE));
    let ops = [
        ("arithmetic", "s += a * 7u"),
        ("load", "s += buf[a]"),
        ("store", "buf[a] = k"),
        ("atomic add", "atomicAdd(&abuf[a], 1u)"),
        ("shared atomic add", "atomicAdd(&sh[a & 255u], 1u)"),
        ("atomic load", "s += atomicLoad(&abuf[a])"),
        ("atomic store", "atomicStore(&abuf[a], k)"),
        ("v[lane index]", "s += v[a & 3u]"),
        ("pick(v, index)", "s += pick(v, a & 3u)"),
    ];
    let invocations = 1u32 << 20;
    println!("per lane-operation, {invocations} invocations x 64, less the arithmetic loop alone:");
    let mut base = 0.0;
    for (name, op) in ops {
        let (pipeline, bg) = op_pipeline(device, &OPS.replace("OP", op), &buffers);
        let ms = best_ms(device, queue, &pipeline, &bg, invocations / 64, 1)?;
        let ns = ms * 1e6 / (f64::from(invocations) * 64.0);
        if name == "arithmetic" {
            base = ns;
            println!("  {name:<18} {ns:.3} ns");
        } else {
            println!("  {name:<18} {:.3} ns", ns - base);
        }
    }
    let (pipeline, bg) = op_pipeline(device, &OPS.replace("OP", "s += a"), &buffers);
    let ms = best_ms(device, queue, &pipeline, &bg, 1, 100)?;
    println!("a dispatch of one workgroup: {:.1} us", ms * 1e3 / 100.0);
    Ok(())
}

/// The pipeline of `src`'s entry point `main` (its layout from the shader).
fn compile(device: &wgpu::Device, src: &str) -> wgpu::ComputePipeline {
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: None,
        source: wgpu::ShaderSource::Wgsl(src.into()),
    });
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: None,
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    })
}

/// The pipeline of [`OPS`] with one operation, and its bind group.
fn op_pipeline(
    device: &wgpu::Device,
    src: &str,
    buffers: &[wgpu::Buffer; 3],
) -> (wgpu::ComputePipeline, wgpu::BindGroup) {
    let pipeline = compile(device, src);
    let layout = pipeline.get_bind_group_layout(0);
    // every shader uses the three buffers (the final line reads them all)
    let entries: Vec<wgpu::BindGroupEntry> = (0..3u32)
        .map(|b| wgpu::BindGroupEntry { binding: b, resource: buffers[b as usize].as_entire_binding() })
        .collect();
    let bg = device.create_bind_group(&wgpu::BindGroupDescriptor { label: None, layout: &layout, entries: &entries });
    (pipeline, bg)
}

/// The best of 7 submissions of `dispatches` dispatches of `groups`
/// workgroups, in ms.
fn best_ms(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    pipeline: &wgpu::ComputePipeline,
    bg: &wgpu::BindGroup,
    groups: u32,
    dispatches: u32,
) -> Result<f64, Box<dyn std::error::Error>> {
    let mut best = f64::MAX;
    for _ in 0..7 {
        let mut enc = device.create_command_encoder(&Default::default());
        {
            let mut cp = enc.begin_compute_pass(&Default::default());
            cp.set_pipeline(pipeline);
            cp.set_bind_group(0, bg, &[]);
            for _ in 0..dispatches {
                cp.dispatch_workgroups(groups, 1, 1);
            }
        }
        let t = Instant::now();
        queue.submit([enc.finish()]);
        device.poll(wgpu::PollType::wait_indefinitely())?;
        best = best.min(t.elapsed().as_secs_f64() * 1e3);
    }
    Ok(best)
}
