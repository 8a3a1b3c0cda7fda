//! The blur pass smooths only the tiles a descriptor reads: the orientation
//! pass marks them in `blur_tiles` (every 16x16 tile of the keypoint's level
//! within `spec::pattern::descriptor_reach` of its pixel, clamped into the
//! level), and blur leaves the others as they were. Hand-checked marks, marks
//! against a host reference, and blur on a subset of marked tiles against
//! src/cpu/blur.rs. (That the whole pipeline's descriptors are unchanged is
//! tests/gpu_end_to_end.rs.)
mod common;

use lfast::Config;
use lfast::cpu::blur;
use lfast::gpu::blur::BlurPass;
use lfast::gpu::buffers::{counter, indirect};
use lfast::gpu::orientation::OrientationPass;
use lfast::gpu::{Buffers, GpuContext, GpuKeypoint, Pass};
use lfast::spec::pattern::descriptor_reach;
use lfast::testing as t;

/// Writes the keypoints, `counters[KEYPOINTS]` and the orientation pass's indirect args.
fn upload_keypoints(ctx: &GpuContext, b: &Buffers, kps: &[GpuKeypoint]) {
    ctx.queue.write_buffer(&b.keypoints, 0, bytemuck::cast_slice(kps));
    let mut counters = [0u32; counter::LEN];
    counters[counter::KEYPOINTS] = kps.len() as u32;
    t::upload(ctx, &b.counters, &counters);
    ctx.queue.write_buffer(
        &b.indirect,
        indirect::KEYPOINTS,
        bytemuck::cast_slice(&[(kps.len() as u32).div_ceil(64), 1, 1]),
    );
}

fn kp(level: u32, px: u32, py: u32) -> GpuKeypoint {
    GpuKeypoint { level, px, py, ..Default::default() }
}

/// Tile index (the tile list, common.wgsl tile_origin) of tile (tx, ty) of level l.
fn tile(b: &Buffers, l: usize, tx: u32, ty: u32) -> usize {
    let t = b.layout.params.tiles[l];
    (t[0] + ty * t[1] + tx) as usize
}

/// The host's marks: every tile of the keypoint's level holding a pixel within
/// `reach` of (px, py), the range clamped into the level.
fn marks(b: &Buffers, kps: &[GpuKeypoint], reach: i32) -> Vec<u32> {
    let mut m = vec![0u32; b.layout.params.total_tiles as usize];
    for k in kps {
        let l = k.level as usize;
        let (w, h) = b.layout.sizes[l];
        let span = |c: u32, len: u32| {
            let lo = (c as i32 - reach).clamp(0, len as i32 - 1) as u32 / 16;
            let hi = (c as i32 + reach).clamp(0, len as i32 - 1) as u32 / 16;
            lo..=hi
        };
        for ty in span(k.py, h) {
            for tx in span(k.px, w) {
                m[tile(b, l, tx, ty)] = 1;
            }
        }
    }
    m
}

fn run_orientation(ctx: &GpuContext, b: &Buffers, kps: &[GpuKeypoint]) -> Vec<u32> {
    upload_keypoints(ctx, b, kps);
    // stale marks of an earlier frame: the pass clears them first
    t::upload(ctx, &b.blur_tiles, &vec![1; b.layout.params.total_tiles as usize]);
    t::run(ctx, &OrientationPass::new(&ctx.device), b).unwrap();
    let got = t::download(ctx, &b.blur_tiles).unwrap();
    got[..b.layout.params.total_tiles as usize].to_vec()
}

#[test]
fn the_reach_fits_four_tiles_a_side() {
    // orientation.wgsl marks at most 4 x 4 tiles, straight-line
    let r = descriptor_reach();
    assert!((2 * r + 1 + 15 + 15) / 16 <= 4, "reach {r}");
    assert!(r >= 19, "reach {r}: the ORB pattern's radius is 19");
}

#[test]
fn orientation_marks_the_tiles_by_hand() {
    let Some(ctx) = t::context() else { return };
    let reach = descriptor_reach();
    assert_eq!(reach, 20, "the literal cases below assume a reach of 20");
    let cfg = Config { n_levels: 1, ..Config::default() };
    // 100 x 70: tiles 7 x 5 (the last column and row partial)
    let b = Buffers::new(&ctx.device, &cfg, 100, 70).unwrap();
    t::upload_packed(&ctx, &b, &b.gray, 0, &t::test_image(100, 70, 1));
    // (0, 0): columns and rows 0 ..= 20, tiles 0 and 1 each way
    let got = run_orientation(&ctx, &b, &[kp(0, 0, 0)]);
    let want: Vec<usize> = vec![tile(&b, 0, 0, 0), tile(&b, 0, 1, 0), tile(&b, 0, 0, 1), tile(&b, 0, 1, 1)];
    assert_eq!(got.iter().enumerate().filter(|(_, v)| **v != 0).map(|(i, _)| i).collect::<Vec<_>>(), want);
    // (50, 69): columns 30 ..= 70 (tiles 1 ..= 4), rows 49 ..= 69 (tiles 3, 4)
    let got = run_orientation(&ctx, &b, &[kp(0, 50, 69)]);
    let mut want = Vec::new();
    for ty in 3..=4 {
        for tx in 1..=4 {
            want.push(tile(&b, 0, tx, ty));
        }
    }
    assert_eq!(got.iter().enumerate().filter(|(_, v)| **v != 0).map(|(i, _)| i).collect::<Vec<_>>(), want);
    // no keypoints: no marks (the stale ones cleared)
    assert!(run_orientation(&ctx, &b, &[]).iter().all(|&v| v == 0));
}

#[test]
fn orientation_marks_what_the_host_does() {
    let Some(ctx) = t::context() else { return };
    let reach = descriptor_reach();
    for (w, h, levels, seed) in [(130, 75, 4, 1u32), (257, 190, 6, 2), (640, 120, 8, 3)] {
        let cfg = Config { n_levels: levels, ..Config::default() };
        let b = Buffers::new(&ctx.device, &cfg, w, h).unwrap();
        t::upload_pyramid(&ctx, &cfg, &b, &t::test_image(w, h, seed));
        // keypoints at the corners and edges of every level and pseudo-random ones
        let mut kps = Vec::new();
        let mut r = common::TestRng::new(seed.into());
        for (l, &(lw, lh)) in b.layout.sizes.iter().enumerate() {
            for (x, y) in [(0, 0), (lw - 1, lh - 1), (lw - 1, 0), (0, lh - 1), (lw / 2, lh / 2)] {
                kps.push(kp(l as u32, x, y));
            }
            for _ in 0..20 {
                kps.push(kp(l as u32, r.below(lw), r.below(lh)));
            }
        }
        kps.truncate(b.layout.capacity as usize);
        assert!(kps.len() > 64, "more than one workgroup");
        let got = run_orientation(&ctx, &b, &kps);
        assert_eq!(got, marks(&b, &kps, reach), "{w}x{h}");
        // a few keypoints mark a part of the tiles only
        let few = &kps[..3];
        let got = run_orientation(&ctx, &b, few);
        let want = marks(&b, few, reach);
        assert_eq!(got, want, "{w}x{h}, three keypoints");
        assert!(want.contains(&0), "{w}x{h}: some tiles unmarked");
    }
}

#[test]
fn blur_smooths_the_marked_tiles_only() {
    let Some(ctx) = t::context() else { return };
    let pass = BlurPass::new(&ctx.device);
    for (w, h, levels, seed) in [(130, 75, 4, 1u32), (37, 29, 3, 2), (71, 19, 2, 3)] {
        let cfg = Config { n_levels: levels, ..Config::default() };
        let b = Buffers::new(&ctx.device, &cfg, w, h).unwrap();
        let lv = t::upload_pyramid(&ctx, &cfg, &b, &t::test_image(w, h, seed));
        // about half the tiles marked, the rest of `smooth` a sentinel
        let mut r = common::TestRng::new(seed.into());
        let n = b.layout.params.total_tiles as usize;
        let marked: Vec<u32> = (0..n).map(|_| r.below(2)).collect();
        t::upload(&ctx, &b.blur_tiles, &marked);
        const SENTINEL: u32 = 0xa5;
        t::upload(&ctx, &b.smooth, &vec![SENTINEL * 0x0101_0101; (b.smooth.size() / 4) as usize]);
        t::run(&ctx, &pass, &b).unwrap();
        for (l, p) in lv.iter().enumerate() {
            let smooth = blur::gaussian_blur(p, &blur::ORB_KERNEL);
            let got = t::download_packed(&ctx, &b, &b.smooth, l).unwrap();
            for y in 0..p.height {
                for x in 0..p.width {
                    let i = (y * p.width + x) as usize;
                    let want = if marked[tile(&b, l, x / 16, y / 16)] != 0 { smooth.data[i] as u32 } else { SENTINEL };
                    assert_eq!(got[i], want, "{w}x{h} level {l} ({x}, {y})");
                }
            }
        }
    }
}

/// The CPU's smoothed level equals the GPU's on every tile the whole
/// pipeline marked: checked through the descriptors in
/// tests/gpu_end_to_end.rs; here a plane with one keypoint per level.
#[test]
fn a_keypoint_per_level_marks_its_neighbourhood_on_its_level_only() {
    let Some(ctx) = t::context() else { return };
    let cfg = Config { n_levels: 3, ..Config::default() };
    let b = Buffers::new(&ctx.device, &cfg, 200, 120).unwrap();
    t::upload_pyramid(&ctx, &cfg, &b, &t::test_image(200, 120, 5));
    let kps = [kp(1, 60, 40)];
    let got = run_orientation(&ctx, &b, &kps);
    for (i, &v) in got.iter().enumerate() {
        let in_level_1 = (b.layout.params.tiles[1][0] as usize..b.layout.params.tiles[2][0] as usize).contains(&i);
        assert!(v == 0 || in_level_1, "tile {i} marked outside level 1");
    }
    // columns 40 ..= 80 (tiles 2 ..= 5), rows 20 ..= 60 (tiles 1 ..= 3)
    assert_eq!(got.iter().filter(|&&v| v != 0).count(), 4 * 3);
}
