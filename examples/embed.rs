//! A headless renderer embedding lfast: upload a frame to a texture, record
//! the detector into the renderer's own command encoder, then a render pass
//! that draws the keypoints straight from the GPU keypoint buffer (instanced,
//! `draw_indirect` with the count the detector wrote — no readback), and save
//! the picture as a PNG.
//!
//! ```text
//! cargo run --release --example embed -- tests/data/astronaut_256.png embed.png
//! ```

use lfast::gpu::buffers::indirect;
use lfast::gpu::detector::{GpuDetector, GpuInput};
use lfast::gpu::{GpuContext, GpuOptions};
use lfast::wgpu;

const SHADER: &str = r#"
struct Kp { x: f32, y: f32, size: f32, angle: f32, response: f32, level: u32,
            px: u32, py: u32, m10: i32, m01: i32, bin: u32, pad: u32 }
struct View { size: vec2<f32> }
@group(0) @binding(0) var frame: texture_2d<f32>;
@group(0) @binding(1) var<storage, read> kps: array<Kp>;
@group(0) @binding(2) var<uniform> view: View;

struct VOut { @builtin(position) pos: vec4<f32>, @location(0) local: vec2<f32>, @location(1) @interpolate(flat) inst: u32 }

// The frame as a full-screen triangle.
@vertex fn bg_vs(@builtin(vertex_index) i: u32) -> VOut {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    var o: VOut;
    o.pos = vec4<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, 0.0, 1.0);
    o.local = uv;
    o.inst = 0u;
    return o;
}
@fragment fn bg_fs(v: VOut) -> @location(0) vec4<f32> {
    let p = vec2<i32>(v.pos.xy);
    let g = textureLoad(frame, p, 0);
    return vec4<f32>(g.rgb * 0.8, 1.0);
}

// One quad per keypoint instance, covering its circle.
@vertex fn kp_vs(@builtin(vertex_index) i: u32, @builtin(instance_index) k: u32) -> VOut {
    let corner = vec2<f32>(f32(i & 1u), f32(i >> 1u)) * 2.0 - 1.0;
    let kp = kps[k];
    let r = kp.size * 0.5 + 1.0;
    let px = vec2<f32>(kp.x, kp.y) + corner * r;
    var o: VOut;
    o.pos = vec4<f32>(px.x / view.size.x * 2.0 - 1.0, 1.0 - px.y / view.size.y * 2.0, 0.0, 1.0);
    o.local = corner * r;
    o.inst = k;
    return o;
}
@fragment fn kp_fs(v: VOut) -> @location(0) vec4<f32> {
    let kp = kps[v.inst];
    let r = kp.size * 0.5;
    let d = length(v.local);
    // the circle of the keypoint's size and a line along its orientation
    let a = radians(kp.angle);
    let dir = vec2<f32>(cos(a), sin(a));
    let along = dot(v.local, dir);
    let across = abs(v.local.x * dir.y - v.local.y * dir.x);
    let on_line = along >= 0.0 && along <= r && across < 0.75;
    if (abs(d - r) > 0.75 && !on_line) { discard; }
    let hue = f32(kp.level % 6u) / 6.0;
    return vec4<f32>(0.5 + 0.5 * cos(6.2831 * (hue + vec3<f32>(0.0, 0.33, 0.67))), 1.0);
}
"#;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let input = args.get(1).map(String::as_str).unwrap_or("tests/data/astronaut_256.png");
    let output = args.get(2).map(String::as_str).unwrap_or("embed.png");
    let rgba = image::open(input)?.to_rgba8();
    let (w, h) = rgba.dimensions();

    // The renderer's device (here from the environment, as wgpu examples do).
    let ctx = GpuContext::new(&GpuOptions::default())?;
    let (device, queue) = (ctx.device.clone(), ctx.queue.clone());
    println!("adapter: {} ({:?})", ctx.info.name, ctx.info.backend);

    let frame = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("frame"),
        size: wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Rgba8Unorm,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    queue.write_texture(
        frame.as_image_copy(),
        &rgba,
        wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(4 * w), rows_per_image: Some(h) },
        frame.size(),
    );
    let frame_view = frame.create_view(&Default::default());

    let det = GpuDetector::new(ctx, lfast::Config::default())?;
    let mut ws = det.workspace(w, h)?;

    let target = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("target"),
        size: frame.size(),
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Rgba8Unorm,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    });
    let target_view = target.create_view(&Default::default());
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("embed"),
        source: wgpu::ShaderSource::Wgsl(SHADER.into()),
    });
    let view_uniform = {
        let data: [f32; 4] = [w as f32, h as f32, 0.0, 0.0];
        let b = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("view"),
            size: 16,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        queue.write_buffer(&b, 0, bytemuck::cast_slice(&data));
        b
    };
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("embed"),
        entries: &[
            wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: false },
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
                count: None,
            },
            wgpu::BindGroupLayoutEntry {
                binding: 1,
                visibility: wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Storage { read_only: true },
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            },
            wgpu::BindGroupLayoutEntry {
                binding: 2,
                visibility: wgpu::ShaderStages::VERTEX,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            },
        ],
    });
    let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("embed"),
        layout: &layout,
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&frame_view) },
            // the detector's keypoint buffer, read directly by the vertex shader
            wgpu::BindGroupEntry { binding: 1, resource: ws.buffers.keypoints.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 2, resource: view_uniform.as_entire_binding() },
        ],
    });
    let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("embed"),
        bind_group_layouts: &[Some(&layout)],
        immediate_size: 0,
    });
    let pipeline = |vs: &str, fs: &str, blend: Option<wgpu::BlendState>, topology| {
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(vs),
            layout: Some(&pl),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some(vs),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState { topology, ..Default::default() },
            depth_stencil: None,
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some(fs),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: wgpu::TextureFormat::Rgba8Unorm,
                    blend,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        })
    };
    let bg_pipeline = pipeline("bg_vs", "bg_fs", None, wgpu::PrimitiveTopology::TriangleList);
    let kp_pipeline =
        pipeline("kp_vs", "kp_fs", Some(wgpu::BlendState::REPLACE), wgpu::PrimitiveTopology::TriangleStrip);

    // One encoder: the detector's compute passes, then our render pass.
    let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frame") });
    det.encode(&mut enc, GpuInput::Texture(&frame_view, wgpu::TextureFormat::Rgba8Unorm), &mut ws)?;
    {
        let mut rp = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("draw keypoints"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &target_view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::BLACK), store: wgpu::StoreOp::Store },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        rp.set_bind_group(0, &bind, &[]);
        rp.set_pipeline(&bg_pipeline);
        rp.draw(0..3, 0..1);
        rp.set_pipeline(&kp_pipeline);
        // 4 vertices per keypoint, instance count written by the detector
        rp.draw_indirect(&ws.buffers.indirect, indirect::DRAW);
    }
    // read the picture back (the example's own readback; the keypoints never leave the GPU)
    let row = (4 * w).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("picture"),
        size: row as u64 * h as u64,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    enc.copy_texture_to_buffer(
        target.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &readback,
            layout: wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(row), rows_per_image: Some(h) },
        },
        target.size(),
    );
    queue.submit([enc.finish()]);
    let bytes = det.map_blocking(&readback, row as u64 * h as u64)?;
    let mut img = image::RgbaImage::new(w, h);
    for y in 0..h {
        let src = &bytes[(y * row) as usize..][..(4 * w) as usize];
        img.as_mut()[(y * 4 * w) as usize..][..(4 * w) as usize].copy_from_slice(src);
    }
    img.save(output)?;
    // how many were drawn: read the count only to report it
    let counters = det.read_buffer(&ws.buffers.counters)?;
    let n = u32::from_le_bytes([counters[4], counters[5], counters[6], counters[7]]);
    println!("{n} keypoints drawn from the GPU buffer into {output} ({w}x{h})");
    Ok(())
}
