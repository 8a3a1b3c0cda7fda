//! GPU stages SPEC 0 (luma), 10 (pyramid) and 11 (blur, orientation, ORB)
//! against the CPU reference: bit for bit, except the f32 rotation of
//! `orientation_bins = 0` (a few bits per descriptor) and the f32 angle.
mod common;

use lfast::cpu::orb::{Pattern, RotatedPatterns, describe, describe_continuous, describe_fine};
use lfast::cpu::orientation::{AngleBins, angle_deg, moments};
use lfast::cpu::{blur, pyramid};
use lfast::gpu::blur::BlurPass;
use lfast::gpu::buffers::{KP_WORDS, counter, indirect};
use lfast::gpu::luma::LumaPass;
use lfast::gpu::orb::OrbPass;
use lfast::gpu::orientation::OrientationPass;
use lfast::gpu::pyramid::PyramidPass;
use lfast::gpu::{Buffers, GpuContext, GpuKeypoint, Pass};
use lfast::image::luma_bt601;
use lfast::testing as t;
use lfast::{Config, Descriptor, Error, Plane, hamming};

/// Random bytes (the tests' one generator, tests/common).
fn random_bytes(n: usize, seed: u32) -> Vec<u8> {
    common::random_bytes(n, seed.into())
}

fn level0(ctx: &GpuContext, b: &Buffers) -> Vec<u8> {
    t::download_packed(ctx, b, &b.gray, 0).unwrap().iter().map(|&v| u8::try_from(v).unwrap()).collect()
}

#[test]
fn luma_from_bytes() {
    let Some(ctx) = t::context() else { return };
    let pass = LumaPass::new(&ctx.device);
    // every width mod 4 (rows starting at every byte of a word; a quad's last
    // columns), widths below four, the last row's bytes ending a word or not
    let sizes = [
        (37, 29, 1),
        (130, 75, 2),
        (17, 1, 3),
        (1, 1, 4),
        (5, 3, 5),
        (16, 16, 6),
        (2, 7, 7),
        (3, 5, 8),
        (71, 18, 9),
        (6, 1, 10),
    ];
    for (w, h, seed) in sizes {
        let b = Buffers::new(&ctx.device, &Config::default(), w, h).unwrap();
        let img = random_bytes((w * h) as usize, seed);
        // the host writes the bytes as they are; the buffer is padded to whole words
        let mut padded = img.clone();
        padded.resize(padded.len().next_multiple_of(4), 0xAB);
        ctx.queue.write_buffer(&b.input, 0, &padded);
        t::run(&ctx, &pass, &b).unwrap();
        assert_eq!(level0(&ctx, &b), img, "{w}x{h}");
    }
}

fn texture(
    ctx: &GpuContext,
    format: wgpu::TextureFormat,
    w: u32,
    h: u32,
    texels: &[u8],
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    let size = wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 };
    let tex = ctx.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("luma test input"),
        size,
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    });
    let bpp = format.block_copy_size(None).unwrap();
    if usage.contains(wgpu::TextureUsages::COPY_DST) {
        ctx.queue.write_texture(
            tex.as_image_copy(),
            texels,
            wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(bpp * w), rows_per_image: Some(h) },
            size,
        );
    }
    tex
}

fn run_texture(
    ctx: &GpuContext,
    pass: &LumaPass,
    b: &Buffers,
    view: &wgpu::TextureView,
    format: wgpu::TextureFormat,
) -> lfast::Result<()> {
    let scope = ctx.device.push_error_scope(wgpu::ErrorFilter::Validation);
    let bound = pass.bind_texture(&ctx.device, b, view, format)?;
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    {
        let mut cp = enc
            .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("luma texture"), timestamp_writes: None });
        pass.record_texture(&mut cp, &bound, b);
    }
    ctx.queue.submit([enc.finish()]);
    if let Some(e) = pollster::block_on(scope.pop()) {
        return Err(Error::Gpu { reason: format!("luma texture: {e}") });
    }
    ctx.wait()
}

#[test]
fn luma_from_textures() {
    use wgpu::TextureFormat as F;
    let Some(ctx) = t::context() else { return };
    let pass = LumaPass::new(&ctx.device);
    let usage = wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST;
    for (w, h, seed) in [(37, 29, 1), (130, 75, 2), (17, 1, 3), (1, 1, 4)] {
        let b = Buffers::new(&ctx.device, &Config::default(), w, h).unwrap();
        let n = (w * h) as usize;
        for format in [F::Rgba8Unorm, F::Bgra8Unorm, F::R8Unorm] {
            let channels = if format == F::R8Unorm { 1 } else { 4 };
            let mut texels = random_bytes(n * channels, seed * 7 + channels as u32);
            if channels == 4 && n >= 4 {
                // the extremes: black, white, pure red, pure blue (alpha varies)
                texels[..16].copy_from_slice(&[0, 0, 0, 0, 255, 255, 255, 7, 255, 0, 0, 255, 0, 0, 255, 128]);
            }
            let want: Vec<u8> = match format {
                F::Rgba8Unorm => texels.chunks(4).map(|p| luma_bt601(p[0], p[1], p[2])).collect(),
                F::Bgra8Unorm => texels.chunks(4).map(|p| luma_bt601(p[2], p[1], p[0])).collect(),
                _ => texels.clone(),
            };
            let tex = texture(&ctx, format, w, h, &texels, usage);
            run_texture(&ctx, &pass, &b, &tex.create_view(&Default::default()), format).unwrap();
            assert_eq!(level0(&ctx, &b), want, "{w}x{h} {format:?}");
        }
    }
    // every byte value through every channel (256 x 1 texture)
    let b = Buffers::new(&ctx.device, &Config::default(), 256, 1).unwrap();
    for (format, texel) in [
        (F::R8Unorm, (|v: u8| vec![v]) as fn(u8) -> Vec<u8>),
        (F::Rgba8Unorm, |v| vec![v, 0, 0, 0]),
        (F::Rgba8Unorm, |v| vec![0, v, 0, 0]),
        (F::Bgra8Unorm, |v| vec![v, 0, 0, 0]),
        (F::Rgba8Unorm, |v| vec![v, v, v, v]),
    ] {
        let texels: Vec<u8> = (0..=255u8).flat_map(texel).collect();
        let want: Vec<u8> = match format {
            F::R8Unorm => (0..=255u8).collect(),
            F::Bgra8Unorm => texels.chunks(4).map(|p| luma_bt601(p[2], p[1], p[0])).collect(),
            _ => texels.chunks(4).map(|p| luma_bt601(p[0], p[1], p[2])).collect(),
        };
        let tex = texture(&ctx, format, 256, 1, &texels, usage);
        run_texture(&ctx, &pass, &b, &tex.create_view(&Default::default()), format).unwrap();
        assert_eq!(level0(&ctx, &b), want, "{format:?} ramp");
    }
}

#[test]
fn luma_rejects_bad_textures() {
    use wgpu::TextureFormat as F;
    let Some(ctx) = t::context() else { return };
    let pass = LumaPass::new(&ctx.device);
    let b = Buffers::new(&ctx.device, &Config::default(), 8, 4).unwrap();
    let usage = wgpu::TextureUsages::TEXTURE_BINDING;
    for format in [F::Rgba8UnormSrgb, F::Bgra8UnormSrgb, F::Rgba16Float, F::R32Float, F::Rg8Unorm] {
        let tex = texture(&ctx, format, 8, 4, &[], usage);
        let e = pass.bind_texture(&ctx.device, &b, &tex.create_view(&Default::default()), format).unwrap_err();
        assert!(matches!(e, Error::Unsupported { .. }), "{format:?}: {e}");
        assert!(e.to_string().contains(&format!("{format:?}")), "{e}");
    }
    let tex = texture(&ctx, F::Rgba8Unorm, 9, 4, &[], usage);
    let e = pass.bind_texture(&ctx.device, &b, &tex.create_view(&Default::default()), F::Rgba8Unorm).unwrap_err();
    assert!(e.to_string().contains("8x4"), "{e}");
    let tex = texture(&ctx, F::Rgba8Unorm, 8, 4, &[], wgpu::TextureUsages::COPY_DST);
    assert!(pass.bind_texture(&ctx.device, &b, &tex.create_view(&Default::default()), F::Rgba8Unorm).is_err());
}

#[test]
fn pyramid_matches_cpu() {
    let Some(ctx) = t::context() else { return };
    let pass = PyramidPass::new(&ctx.device);
    for (w, h, levels, seed) in
        [(37, 29, 5, 1), (130, 75, 8, 2), (17, 1, 4, 3), (1, 1, 4, 4), (3, 2, 8, 5), (200, 150, 6, 6), (61, 47, 7, 7)]
    {
        let cfg = Config { n_levels: levels, ..Config::default() };
        let img = t::test_image(w, h, seed);
        let b = Buffers::new(&ctx.device, &cfg, w, h).unwrap();
        // stale data in the upper levels must not matter
        for l in 1..levels as usize {
            let (lw, lh) = b.layout.sizes[l];
            t::upload_packed(&ctx, &b, &b.gray, l, &Plane::from_vec(lw, lh, vec![77; (lw * lh) as usize]).unwrap());
        }
        t::upload_packed(&ctx, &b, &b.gray, 0, &img);
        t::run(&ctx, &pass, &b).unwrap();
        let want = pyramid::pyramid(&img, &cfg.level_sizes(w, h));
        assert_eq!(want.len(), levels as usize);
        for (l, p) in want.iter().enumerate() {
            let got = t::download_packed(&ctx, &b, &b.gray, l).unwrap();
            let want: Vec<u32> = p.data.iter().map(|&v| v as u32).collect();
            assert_eq!(got, want, "{w}x{h} level {l} ({}x{})", p.width, p.height);
        }
    }
}

#[test]
fn pyramid_with_other_scale_factors() {
    let Some(ctx) = t::context() else { return };
    let pass = PyramidPass::new(&ctx.device);
    for (w, h, levels, scale) in [(97, 61, 4, 2.0), (130, 75, 5, 1.05), (45, 33, 3, 3.7)] {
        let cfg = Config { n_levels: levels, scale_factor: scale, ..Config::default() };
        let img = t::test_image(w, h, levels);
        let b = Buffers::new(&ctx.device, &cfg, w, h).unwrap();
        t::upload_packed(&ctx, &b, &b.gray, 0, &img);
        t::run(&ctx, &pass, &b).unwrap();
        for (l, p) in t::cpu_levels(&cfg, &img).iter().enumerate() {
            let want: Vec<u32> = p.data.iter().map(|&v| v as u32).collect();
            assert_eq!(t::download_packed(&ctx, &b, &b.gray, l).unwrap(), want, "{w}x{h} scale {scale} level {l}");
        }
    }
}

#[test]
fn blur_matches_cpu_on_every_level() {
    let Some(ctx) = t::context() else { return };
    let pass = BlurPass::new(&ctx.device);
    // heights 1..3 and 16k + 1..3 (a last tile of 1-3 rows, whose reflected
    // rows come from the tile above), widths of every remainder mod 4
    let sizes = [
        (37, 29, 3, 1),
        (130, 75, 5, 2),
        (17, 1, 2, 3),
        (1, 1, 1, 4),
        (2, 5, 3, 5),
        (7, 4, 8, 6),
        (3, 17, 1, 7),
        (6, 18, 1, 8),
        (71, 19, 2, 9),
        (5, 2, 1, 10),
        (4, 3, 1, 11),
        (33, 33, 1, 12),
        (20, 35, 1, 13),
    ];
    for (w, h, levels, seed) in sizes {
        let cfg = Config { n_levels: levels, ..Config::default() };
        let img = t::test_image(w, h, seed);
        let b = Buffers::new(&ctx.device, &cfg, w, h).unwrap();
        let lv = t::upload_pyramid(&ctx, &cfg, &b, &img);
        mark_every_tile(&ctx, &b);
        t::run(&ctx, &pass, &b).unwrap();
        for (l, p) in lv.iter().enumerate() {
            let want: Vec<u32> = blur::gaussian_blur(p, &blur::ORB_KERNEL).data.iter().map(|&v| v as u32).collect();
            assert_eq!(t::download_packed(&ctx, &b, &b.smooth, l).unwrap(), want, "{w}x{h} level {l}");
        }
    }
    // a hand-checked case: an impulse spreads as the outer product of the kernel
    let cfg = Config { n_levels: 1, ..Config::default() };
    let b = Buffers::new(&ctx.device, &cfg, 9, 9).unwrap();
    let mut img = vec![0u8; 81];
    img[4 * 9 + 4] = 255;
    t::upload_packed(&ctx, &b, &b.gray, 0, &Plane::from_vec(9, 9, img).unwrap());
    mark_every_tile(&ctx, &b);
    t::run(&ctx, &pass, &b).unwrap();
    let got = t::download_packed(&ctx, &b, &b.smooth, 0).unwrap();
    let k = blur::ORB_KERNEL;
    for y in 0..9 {
        for x in 0..9 {
            let kx = if (1..8).contains(&x) { k[x - 1] } else { 0 };
            let ky = if (1..8).contains(&y) { k[y - 1] } else { 0 };
            assert_eq!(got[y * 9 + x], (ky * kx * 255 + (1 << 15)) >> 16, "({x}, {y})");
        }
    }
}

/// Marks every tile for the blur pass (the select pass marks those the
/// descriptors read; tests/gpu_blur_tiles.rs tests the marks).
fn mark_every_tile(ctx: &GpuContext, b: &Buffers) {
    t::upload(ctx, &b.blur_tiles, &vec![1; b.layout.params.total_tiles as usize]);
}

/// Keypoints on every level: the four corners, points 1-3 pixels from each
/// border (clamped reads), the centre, and pseudo-random ones, at most `cap`.
fn keypoints(levels: &[Plane<u8>], cap: usize, seed: u32) -> Vec<GpuKeypoint> {
    let mut r = random_bytes(4096, seed).into_iter();
    let mut kps = Vec::new();
    for (l, p) in levels.iter().enumerate() {
        let (w, h) = (p.width, p.height);
        let mut pts = vec![(0, 0), (w - 1, 0), (0, h - 1), (w - 1, h - 1), (w / 2, h / 2)];
        pts.extend([
            (1, h / 3),
            (w.saturating_sub(2), h / 2),
            (w / 3, 2),
            (w / 2, h.saturating_sub(3)),
            (15, 15),
            (w.saturating_sub(16), 22),
        ]);
        for _ in 0..12 {
            let x = r.next().unwrap() as u32 * w / 256;
            let y = r.next().unwrap() as u32 * h / 256;
            pts.push((x, y));
        }
        for (px, py) in pts {
            let (px, py) = (px.min(w - 1), py.min(h - 1));
            kps.push(GpuKeypoint {
                x: px as f32 + 0.25,
                y: py as f32 + 0.75,
                size: 31.0 + l as f32,
                angle: -1.0,
                response: (px * 1000 + py) as f32,
                level: l as u32,
                px,
                py,
                m10: 12345,
                m01: -777,
                bin: 99,
                sub: 0,
            });
        }
    }
    kps.truncate(cap);
    kps
}

/// Writes the keypoints, `counters[KEYPOINTS]` and the indirect dispatch args.
fn upload_keypoints(ctx: &GpuContext, b: &Buffers, kps: &[GpuKeypoint]) {
    assert!(kps.len() <= b.layout.capacity as usize, "{} keypoints, capacity {}", kps.len(), b.layout.capacity);
    ctx.queue.write_buffer(&b.keypoints, 0, bytemuck::cast_slice(kps));
    let mut counters = [0u32; counter::LEN];
    counters[counter::KEYPOINTS] = kps.len() as u32;
    t::upload(ctx, &b.counters, &counters);
    ctx.queue.write_buffer(
        &b.indirect,
        indirect::KEYPOINTS,
        bytemuck::cast_slice(&[(kps.len() as u32).div_ceil(64), 1, 1]),
    );
    // as select's `finish` writes them: one workgroup per keypoint
    let n = kps.len() as u32;
    ctx.queue.write_buffer(
        &b.indirect,
        indirect::KEYPOINT_GROUPS,
        bytemuck::cast_slice(&[n.min(65535), n.div_ceil(65535), 1]),
    );
}

fn download_keypoints(ctx: &GpuContext, b: &Buffers) -> Vec<GpuKeypoint> {
    let words = t::download(ctx, &b.keypoints).unwrap();
    bytemuck::cast_slice::<u32, GpuKeypoint>(&words[..(b.layout.capacity as u64 * KP_WORDS) as usize]).to_vec()
}

fn download_descriptors(ctx: &GpuContext, b: &Buffers, n: usize) -> Vec<Descriptor> {
    let words = t::download(ctx, &b.descriptors).unwrap();
    let bytes: &[u8] = bytemuck::cast_slice(&words);
    bytes.chunks(32).take(n).map(|c| c.try_into().unwrap()).collect()
}

fn circular_diff(a: f32, b: f32) -> f32 {
    let d = (a - b).abs() % 360.0;
    d.min(360.0 - d)
}

#[test]
fn orientation_matches_cpu() {
    let Some(ctx) = t::context() else { return };
    let pass = OrientationPass::new(&ctx.device);
    for (w, h, levels, bins, seed) in
        [(130, 75, 4, 30, 1), (160, 120, 5, 8, 2), (130, 75, 3, 0, 3), (200, 150, 6, 1, 4)]
    {
        let cfg = Config { n_levels: levels, orientation_bins: bins, ..Config::default() };
        let img = t::test_image(w, h, seed);
        let b = Buffers::new(&ctx.device, &cfg, w, h).unwrap();
        let lv = t::upload_pyramid(&ctx, &cfg, &b, &img);
        let kps = keypoints(&lv, b.layout.capacity as usize, seed);
        assert!(kps.len() > 64, "{} keypoints: cover more than one workgroup", kps.len());
        upload_keypoints(&ctx, &b, &kps);
        // a slot past the count must stay untouched
        let sentinel = GpuKeypoint { level: 0, m10: 4242, bin: 4242, ..Default::default() };
        if kps.len() < b.layout.capacity as usize {
            ctx.queue.write_buffer(&b.keypoints, (kps.len() as u64) * KP_WORDS * 4, bytemuck::bytes_of(&sentinel));
        }
        t::run(&ctx, &pass, &b).unwrap();
        let got = download_keypoints(&ctx, &b);
        let angle_bins = AngleBins::new(bins.max(1));
        let mut bins_seen = std::collections::BTreeSet::new();
        for (i, (k, g)) in kps.iter().zip(&got).enumerate() {
            let (m10, m01) = moments(&lv[k.level as usize], k.px, k.py);
            let bin = angle_bins.bin_of(m10, m01);
            bins_seen.insert(bin);
            let want = GpuKeypoint { m10, m01, bin, angle: g.angle, ..*k };
            assert_eq!(*g, want, "{w}x{h} bins {bins} keypoint {i}");
            let a = angle_deg(m10, m01);
            assert!((0.0..360.0).contains(&g.angle), "angle {} out of range", g.angle);
            assert!(circular_diff(g.angle, a) < 0.01, "{w}x{h} keypoint {i}: angle {} vs {a}", g.angle);
        }
        if kps.len() < b.layout.capacity as usize {
            assert_eq!(got[kps.len()], sentinel, "slot past the count");
        }
        if bins > 1 {
            assert!(bins_seen.len() > 3, "bins {bins}: only {bins_seen:?} seen");
        }
    }
}

#[test]
fn orientation_of_literal_directions() {
    // Ramps in the four axis directions and a flat patch: bins and angles by hand.
    let Some(ctx) = t::context() else { return };
    let pass = OrientationPass::new(&ctx.device);
    let cfg = Config { n_levels: 1, orientation_bins: 30, ..Config::default() };
    let b = Buffers::new(&ctx.device, &cfg, 64, 64).unwrap();
    type Pattern = fn(u32, u32) -> u8;
    let cases: [(Pattern, u32, f32); 5] = [
        (|x, _| (x * 3) as u8, 0, 0.0),
        (|_, y| (y * 3) as u8, 8, 90.0), // on the 7|8 boundary: the upper bin
        (|x, _| (255 - x * 3) as u8, 15, 180.0),
        (|_, y| (255 - y * 3) as u8, 23, 270.0), // on the 22|23 boundary
        (|_, _| 0, 0, 0.0),
    ];
    for (f, bin, angle) in cases {
        let img = Plane::from_vec(64, 64, (0..64 * 64).map(|i| f(i % 64, i / 64)).collect()).unwrap();
        t::upload_packed(&ctx, &b, &b.gray, 0, &img);
        let kp = GpuKeypoint { px: 32, py: 32, ..Default::default() };
        upload_keypoints(&ctx, &b, &[kp]);
        t::run(&ctx, &pass, &b).unwrap();
        let g = download_keypoints(&ctx, &b)[0];
        assert_eq!((g.m10, g.m01), moments(&img, 32, 32));
        assert_eq!(g.bin, bin, "angle {angle}");
        assert!(circular_diff(g.angle, angle) < 1e-3, "{} vs {angle}", g.angle);
    }
}

/// The CPU smoothed levels, uploaded into `smooth`.
fn upload_smooth(ctx: &GpuContext, b: &Buffers, levels: &[Plane<u8>]) -> Vec<Plane<u8>> {
    let smooth: Vec<Plane<u8>> = levels.iter().map(|p| blur::gaussian_blur(p, &blur::ORB_KERNEL)).collect();
    for (l, p) in smooth.iter().enumerate() {
        t::upload_packed(ctx, b, &b.smooth, l, p);
    }
    smooth
}

/// Keypoint `i`'s test offset in 1/16 px: every value of -7..=7 on both axes.
fn test_sub(i: usize) -> [i8; 2] {
    [(i % 15) as i8 - 7, ((i / 3) % 15) as i8 - 7]
}

#[test]
fn orb_matches_cpu_with_bins() {
    // without a snap the descriptor at the pixel (SPEC 11); with one, at the
    // keypoint's sub-pixel position, bilinear (orb.wgsl fine_word = orb::describe_fine)
    let Some(ctx) = t::context() else { return };
    let pass = OrbPass::new(&ctx.device);
    for (w, h, levels, bins, seed, snap_radius) in [
        (130, 75, 4, 30, 1, 0),
        (160, 120, 5, 8, 2, 0),
        (97, 150, 3, 1, 3, 0),
        (130, 75, 4, 180, 4, 2),
        (97, 150, 3, 8, 5, 1),
    ] {
        let cfg = Config { n_levels: levels, orientation_bins: bins, snap_radius, ..Config::default() };
        let img = t::test_image(w, h, seed);
        let b = Buffers::new(&ctx.device, &cfg, w, h).unwrap();
        let lv = t::cpu_levels(&cfg, &img);
        let smooth = upload_smooth(&ctx, &b, &lv);
        let tables = RotatedPatterns::new(Pattern::orb(), bins);
        let mut kps = keypoints(&lv, b.layout.capacity as usize, seed);
        for (i, k) in kps.iter_mut().enumerate() {
            // the CPU's bin half the time, any bin otherwise: each table must be exact
            let (m10, m01) = moments(&lv[k.level as usize], k.px, k.py);
            k.bin = if i % 2 == 0 { tables.bins.bin_of(m10, m01) } else { (i as u32 * 7) % bins };
            let [sx, sy] = test_sub(i);
            k.sub = (sx as u8 as u32) | (sy as u8 as u32) << 8;
        }
        assert!(kps.len() > 64);
        upload_keypoints(&ctx, &b, &kps);
        t::run(&ctx, &pass, &b).unwrap();
        let got = download_descriptors(&ctx, &b, kps.len() + 1);
        for (i, k) in kps.iter().enumerate() {
            let sm = &smooth[k.level as usize];
            let want = if snap_radius > 0 {
                describe_fine(sm, k.px, k.py, test_sub(i), &tables.fine[k.bin as usize])
            } else {
                describe(sm, k.px, k.py, &tables.tables[k.bin as usize])
            };
            assert_eq!(got[i], want, "{w}x{h} bins {bins} keypoint {i} ({}, {}) level {}", k.px, k.py, k.level);
        }
        if kps.len() < b.layout.capacity as usize {
            assert_eq!(got[kps.len()], [0u8; 32], "slot past the count");
        }
    }
}

#[test]
fn orb_one_bit_by_hand() {
    // Pair 0 of the unrotated pattern is (8,-3) vs (9,5): bit 0 of byte 0.
    let Some(ctx) = t::context() else { return };
    let pass = OrbPass::new(&ctx.device);
    let cfg = Config { n_levels: 1, orientation_bins: 4, ..Config::default() };
    let b = Buffers::new(&ctx.device, &cfg, 41, 41).unwrap();
    let kp = GpuKeypoint { px: 20, py: 20, bin: 0, ..Default::default() };
    upload_keypoints(&ctx, &b, &[kp]);
    let mut img = vec![100u8; 41 * 41];
    img[25 * 41 + 29] = 101;
    t::upload_packed(&ctx, &b, &b.smooth, 0, &Plane::from_vec(41, 41, img).unwrap());
    t::run(&ctx, &pass, &b).unwrap();
    let d = download_descriptors(&ctx, &b, 1)[0];
    assert_eq!(d[0], 1);
    assert!(d[1..].iter().all(|&v| v == 0));
}

#[test]
fn orb_continuous_within_a_few_bits() {
    let Some(ctx) = t::context() else { return };
    let pass = OrbPass::new(&ctx.device);
    let (mut total_bits, mut total_kps) = (0u32, 0usize);
    for (w, h, levels, seed) in [(130, 75, 4, 1), (160, 120, 5, 2)] {
        let cfg = Config { n_levels: levels, orientation_bins: 0, ..Config::default() };
        let img = t::test_image(w, h, seed);
        let b = Buffers::new(&ctx.device, &cfg, w, h).unwrap();
        let lv = t::cpu_levels(&cfg, &img);
        let smooth = upload_smooth(&ctx, &b, &lv);
        let mut kps = keypoints(&lv, b.layout.capacity as usize, seed);
        let exact = [0.0f32, 90.0, 180.0, 270.0, 45.0, 12.0, 359.9];
        for (i, k) in kps.iter_mut().enumerate() {
            let (m10, m01) = moments(&lv[k.level as usize], k.px, k.py);
            k.angle = if i % 4 == 3 { exact[i / 4 % exact.len()] } else { angle_deg(m10, m01) };
        }
        upload_keypoints(&ctx, &b, &kps);
        t::run(&ctx, &pass, &b).unwrap();
        let got = download_descriptors(&ctx, &b, kps.len());
        for (i, k) in kps.iter().enumerate() {
            let want = describe_continuous(&smooth[k.level as usize], k.px, k.py, k.angle, Pattern::orb());
            let d = hamming(&got[i], &want);
            assert!(d <= 4, "{w}x{h} keypoint {i} angle {}: {d} bits differ", k.angle);
            total_bits += d;
        }
        total_kps += kps.len();
    }
    // differences only where a rotated offset lands on a rounding tie
    assert!(total_bits as usize <= total_kps / 4 + 4, "{total_bits} bits differ over {total_kps} keypoints");
}

#[test]
fn orientation_then_orb_match_the_cpu_detector_path() {
    // The two passes chained on the GPU, as the pipeline runs them: the bin the
    // orientation pass writes selects the table the ORB pass reads.
    let Some(ctx) = t::context() else { return };
    let (orientation, orb) = (OrientationPass::new(&ctx.device), OrbPass::new(&ctx.device));
    // no snap: the keypoints carry no sub-pixel offset (orb_matches_cpu_with_bins covers it)
    let cfg = Config { n_levels: 4, snap_radius: 0, ..Config::default() };
    let (w, h) = (130, 75);
    let img = t::test_image(w, h, 9);
    let b = Buffers::new(&ctx.device, &cfg, w, h).unwrap();
    let lv = t::upload_pyramid(&ctx, &cfg, &b, &img);
    let smooth = upload_smooth(&ctx, &b, &lv);
    let kps = keypoints(&lv, b.layout.capacity as usize, 9);
    upload_keypoints(&ctx, &b, &kps);
    t::run(&ctx, &orientation, &b).unwrap();
    t::run(&ctx, &orb, &b).unwrap();
    let tables = RotatedPatterns::new(Pattern::orb(), cfg.orientation_bins);
    let got = download_descriptors(&ctx, &b, kps.len());
    for (i, k) in kps.iter().enumerate() {
        let (m10, m01) = moments(&lv[k.level as usize], k.px, k.py);
        let want =
            describe(&smooth[k.level as usize], k.px, k.py, &tables.tables[tables.bins.bin_of(m10, m01) as usize]);
        assert_eq!(got[i], want, "keypoint {i}");
    }
}
