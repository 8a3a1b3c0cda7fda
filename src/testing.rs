//! Helpers for the GPU == CPU tests (hidden from the docs): the device
//! (failing, not skipping, when `REQUIRE_GPU=1` and there is none), uploads of
//! CPU planes into atlas levels, one pass run on its own, downloads. It lives
//! outside `gpu/` because it feeds the GPU passes with the CPU path's outputs.

use crate::error::{Error, Result};
use crate::gpu::buffers::Buffers;
use crate::gpu::context::{GpuContext, GpuOptions};
use crate::gpu::pass::Pass;
use crate::image::Plane;

/// The test device, or `None` (with a note on stderr) when there is no
/// adapter. Panics when `REQUIRE_GPU=1`: CI must not skip GPU tests silently.
pub fn context() -> Option<GpuContext> {
    static CTX: std::sync::OnceLock<std::result::Result<GpuContext, String>> = std::sync::OnceLock::new();
    match CTX.get_or_init(|| GpuContext::new(&GpuOptions::default()).map_err(|e| e.to_string())) {
        Ok(c) => Some(c.clone()),
        Err(e) => {
            if std::env::var("REQUIRE_GPU").is_ok_and(|v| v == "1") {
                panic!("REQUIRE_GPU=1 but no GPU device: {e}");
            }
            eprintln!("skipping GPU test: {e} (set REQUIRE_GPU=1 to make this a failure)");
            None
        }
    }
}

/// Writes `data` (one u32 per pixel) into level `l` of an atlas buffer.
pub fn upload_level(ctx: &GpuContext, b: &Buffers, buf: &wgpu::Buffer, l: usize, data: &[u32]) {
    let off = b.layout.offsets[l] as u64 * 4;
    assert_eq!(data.len(), b.layout.level_range(l).len(), "level {l} size");
    if !data.is_empty() {
        ctx.queue.write_buffer(buf, off, bytemuck::cast_slice(data));
    }
}

/// Writes a u8 plane into level `l` of an atlas buffer.
pub fn upload_plane<T: Copy + Into<u32>>(ctx: &GpuContext, b: &Buffers, buf: &wgpu::Buffer, l: usize, p: &Plane<T>) {
    let v: Vec<u32> = p.data.iter().map(|&x| x.into()).collect();
    upload_level(ctx, b, buf, l, &v);
}

/// Writes an 8-bit plane into level `l` of a column-packed buffer (`classes`, `edges`).
pub fn upload_packed(ctx: &GpuContext, b: &Buffers, buf: &wgpu::Buffer, l: usize, p: &Plane<u8>) {
    let r = b.layout.packed_range(l);
    let words = crate::gpu::layout::pack_level(p.width, p.height, &p.data);
    assert_eq!(words.len(), r.len(), "level {l} size");
    if !words.is_empty() {
        ctx.queue.write_buffer(buf, r.start as u64 * 4, bytemuck::cast_slice(&words));
    }
}

/// Writes SPEC 7's ruled classes (NONE, WEAK, STRONG) into level `l` of the
/// `ruled` plane ([`pack_ruled`](crate::gpu::layout::pack_ruled)).
pub fn upload_ruled(ctx: &GpuContext, b: &Buffers, l: usize, p: &Plane<u8>) {
    upload_tile_words(ctx, b, &b.ruled, l, &crate::gpu::layout::pack_ruled(p.width, p.height, &p.data));
}

/// Writes `words` (a word per column of every tile of level `l`) into level
/// `l` of a tile-column plane.
fn upload_tile_words(ctx: &GpuContext, b: &Buffers, buf: &wgpu::Buffer, l: usize, words: &[u32]) {
    let r = b.layout.tile_range(l);
    assert_eq!(words.len(), r.len(), "level {l} size");
    if !words.is_empty() {
        ctx.queue.write_buffer(buf, r.start as u64 * 4, bytemuck::cast_slice(words));
    }
}

/// Writes edge map `p` (255 = edge) into level `l` of `edge_bits` as
/// hysteresis leaves it for Paper mode's L-FAST test
/// ([`pack_edge_tiles`](crate::gpu::layout::pack_edge_tiles)).
pub fn upload_edge_tiles(ctx: &GpuContext, b: &Buffers, l: usize, p: &Plane<u8>) {
    upload_tile_words(ctx, b, &b.edge_bits, l, &crate::gpu::layout::pack_edge_tiles(p.width, p.height, &p.data));
}

/// Writes the walk list of the ruled classes `planes` (one per level,
/// [`walk_list`](crate::gpu::layout::walk_list)) and its count, as `rules`
/// leaves them for hysteresis; in reverse raster order, since `rules`
/// appends in no particular order.
pub fn upload_walks(ctx: &GpuContext, b: &Buffers, planes: &[Plane<u8>]) {
    let mut walks: Vec<u32> = planes
        .iter()
        .enumerate()
        .flat_map(|(l, p)| crate::gpu::layout::walk_list(l as u32, p.width, p.height, &p.data))
        .collect();
    walks.reverse();
    if !walks.is_empty() {
        ctx.queue.write_buffer(&b.walks, 0, bytemuck::cast_slice(&walks));
    }
    let count = crate::gpu::buffers::counter::WALKS as u64 * 4;
    ctx.queue.write_buffer(&b.counters, count, bytemuck::bytes_of(&(walks.len() as u32)));
}

/// The walk list `rules` appended, sorted.
pub fn download_walks(ctx: &GpuContext, b: &Buffers) -> Result<Vec<u32>> {
    let n = download(ctx, &b.counters)?[crate::gpu::buffers::counter::WALKS] as usize;
    let mut walks = download(ctx, &b.walks)?;
    walks.truncate(n);
    walks.sort_unstable();
    Ok(walks)
}

/// Level `l` of the `ruled` plane as classes (0, 2, 4), one u32 per pixel, row-major.
pub fn download_ruled(ctx: &GpuContext, b: &Buffers, l: usize) -> Result<Vec<u32>> {
    let r = b.layout.tile_range(l);
    if r.is_empty() {
        return Ok(Vec::new());
    }
    let bytes = ctx.read_range(&b.ruled, r.start as u64 * 4, r.len() as u64 * 4)?;
    let (w, h) = b.layout.sizes[l];
    Ok(crate::gpu::layout::unpack_ruled(w, h, bytemuck::cast_slice(&bytes)).into_iter().map(u32::from).collect())
}

/// Level `l` of a column-packed buffer, unpacked: one u32 per pixel, row-major
/// (as [`download_level`] gives a per-pixel atlas).
pub fn download_packed(ctx: &GpuContext, b: &Buffers, buf: &wgpu::Buffer, l: usize) -> Result<Vec<u32>> {
    let r = b.layout.packed_range(l);
    if r.is_empty() {
        return Ok(Vec::new());
    }
    let bytes = ctx.read_range(buf, r.start as u64 * 4, r.len() as u64 * 4)?;
    let (w, h) = b.layout.sizes[l];
    Ok(crate::gpu::layout::unpack_level(w, h, bytemuck::cast_slice(&bytes)).into_iter().map(u32::from).collect())
}

/// Writes an i32 plane into level `l` (as its bits).
pub fn upload_plane_i32(ctx: &GpuContext, b: &Buffers, buf: &wgpu::Buffer, l: usize, p: &Plane<i32>) {
    let v: Vec<u32> = p.data.iter().map(|&x| x as u32).collect();
    upload_level(ctx, b, buf, l, &v);
}

/// Writes `data` at the start of a buffer.
pub fn upload(ctx: &GpuContext, buf: &wgpu::Buffer, data: &[u32]) {
    if !data.is_empty() {
        ctx.queue.write_buffer(buf, 0, bytemuck::cast_slice(data));
    }
}

/// A whole buffer as u32 words.
pub fn download(ctx: &GpuContext, buf: &wgpu::Buffer) -> Result<Vec<u32>> {
    Ok(bytemuck::cast_slice(&ctx.read_buffer(buf)?).to_vec())
}

/// Level `l` of an atlas buffer as u32 words.
pub fn download_level(ctx: &GpuContext, b: &Buffers, buf: &wgpu::Buffer, l: usize) -> Result<Vec<u32>> {
    let r = b.layout.level_range(l);
    if r.is_empty() {
        return Ok(Vec::new());
    }
    let bytes = ctx.read_range(buf, r.start as u64 * 4, r.len() as u64 * 4)?;
    Ok(bytemuck::cast_slice(&bytes).to_vec())
}

/// Runs one stage alone on the buffers as they are (bind, prepare, record,
/// submit, wait), capturing validation errors as [`Error::Gpu`].
pub fn run<P: Pass>(ctx: &GpuContext, pass: &P, b: &Buffers) -> Result<()> {
    let scope = ctx.device.push_error_scope(wgpu::ErrorFilter::Validation);
    let bound = pass.bind(&ctx.device, b)?;
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    pass.prepare(&mut enc, b);
    if let Some(buf) = pass.clear_before(b) {
        enc.clear_buffer(buf, 0, None);
    }
    {
        let mut cp =
            enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(P::NAME), timestamp_writes: None });
        pass.record(&mut cp, &bound, b);
    }
    ctx.queue.submit([enc.finish()]);
    if let Some(e) = pollster::block_on(scope.pop()) {
        return Err(Error::Gpu { reason: format!("{}: {e}", P::NAME) });
    }
    ctx.wait()
}

/// The CPU pyramid of `img` under `cfg` (the GPU tests' inputs per level).
pub fn cpu_levels(cfg: &crate::Config, img: &Plane<u8>) -> Vec<Plane<u8>> {
    crate::cpu::pyramid::pyramid(img, &cfg.level_sizes(img.width, img.height))
}

/// Uploads the CPU pyramid of `img` into `b.gray` and returns it.
pub fn upload_pyramid(ctx: &GpuContext, cfg: &crate::Config, b: &Buffers, img: &Plane<u8>) -> Vec<Plane<u8>> {
    let levels = cpu_levels(cfg, img);
    for (l, p) in levels.iter().enumerate() {
        upload_packed(ctx, b, &b.gray, l, p);
    }
    levels
}

/// A deterministic pseudo-random image with structure (blocks, ramps, noise),
/// so every stage has something to do.
pub fn test_image(w: u32, h: u32, seed: u32) -> Plane<u8> {
    let mut s = seed.wrapping_mul(2654435761).wrapping_add(12345);
    let mut next = move || {
        s ^= s << 13;
        s ^= s >> 17;
        s ^= s << 5;
        s
    };
    let mut p = Plane::<u8>::new(w, h);
    let blocks: Vec<(u32, u32, u32, u32, u8)> = (0..8)
        .map(|_| {
            (
                next() % w.max(1),
                next() % h.max(1),
                3 + next() % (w / 2 + 3),
                3 + next() % (h / 2 + 3),
                (next() % 256) as u8,
            )
        })
        .collect();
    for y in 0..h {
        for x in 0..w {
            let mut v = ((x * 255) / w.max(1)) as u8 / 2;
            for &(bx, by, bw, bh, c) in &blocks {
                if x >= bx && x < bx + bw && y >= by && y < by + bh {
                    v = c;
                }
            }
            if next() % 23 == 0 {
                v = (next() % 256) as u8;
            }
            p.data[(y * w + x) as usize] = v;
        }
    }
    p
}
