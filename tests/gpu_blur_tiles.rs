//! The blur pass smooths only the tiles a descriptor reads: the select pass
//! marks them in `blur_tiles` for every keypoint it places (every 16x16 tile
//! of the keypoint's level within `spec::pattern::descriptor_reach` of its
//! pixel, clamped into the level), and blur leaves the others as they were. Hand-checked marks, marks
//! against a host reference, and blur on a subset of marked tiles against
//! src/cpu/blur.rs. (That the whole pipeline's descriptors are unchanged is
//! tests/gpu_end_to_end.rs.)
mod common;

use lfast::Config;
use lfast::cpu::blur;
use lfast::gpu::blur::BlurPass;
use lfast::gpu::buffers::counter;
use lfast::gpu::select::SelectPass;
use lfast::gpu::{Buffers, GpuContext, GpuKeypoint, Pass};
use lfast::spec::pattern::descriptor_reach;
use lfast::testing as t;

/// A corner at (px, py) of `level`, its response `r` (select's order).
fn kp(level: u32, px: u32, py: u32) -> GpuKeypoint {
    GpuKeypoint { level, px, py, response: 1.0 + (px * 7 + py * 3) as f32, ..Default::default() }
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

/// Runs select alone on `corners` (stale marks in `blur_tiles` first: the
/// pass clears them); the marks and the keypoints it placed.
fn run_select(ctx: &GpuContext, b: &Buffers, corners: &[GpuKeypoint]) -> (Vec<u32>, Vec<GpuKeypoint>) {
    if !corners.is_empty() {
        ctx.queue.write_buffer(&b.corners, 0, bytemuck::cast_slice(corners));
    }
    let mut counters = [0u32; counter::LEN];
    counters[counter::CORNERS] = corners.len() as u32;
    t::upload(ctx, &b.counters, &counters);
    t::upload(ctx, &b.blur_tiles, &vec![1; b.layout.params.total_tiles as usize]);
    t::run(ctx, &SelectPass::new(&ctx.device), b).unwrap();
    let n = t::download(ctx, &b.counters).unwrap()[counter::KEYPOINTS] as usize;
    let words = t::download(ctx, &b.keypoints).unwrap();
    let placed = bytemuck::cast_slice::<u32, GpuKeypoint>(&words)[..n].to_vec();
    let marks = t::download(ctx, &b.blur_tiles).unwrap()[..b.layout.params.total_tiles as usize].to_vec();
    (marks, placed)
}

fn marked(m: &[u32]) -> Vec<usize> {
    m.iter().enumerate().filter(|(_, v)| **v != 0).map(|(i, _)| i).collect()
}

#[test]
fn the_reach_fits_four_tiles_a_side() {
    // select.wgsl marks at most 4 x 4 tiles, straight-line
    let r = descriptor_reach();
    assert!((2 * r + 1 + 15 + 15) / 16 <= 4, "reach {r}");
    assert!(r >= 19, "reach {r}: the ORB pattern's radius is 19");
}

#[test]
fn select_marks_the_tiles_by_hand() {
    let Some(ctx) = t::context() else { return };
    let reach = descriptor_reach();
    assert_eq!(reach, 20, "the literal cases below assume a reach of 20");
    let cfg = Config { n_levels: 1, ..Config::default() };
    // 100 x 70: tiles 7 x 5 (the last column and row partial)
    let b = Buffers::new(&ctx.device, &cfg, 100, 70).unwrap();
    // (0, 0): columns and rows 0 ..= 20, tiles 0 and 1 each way
    let (m, placed) = run_select(&ctx, &b, &[kp(0, 0, 0)]);
    assert_eq!(placed.len(), 1);
    assert_eq!(marked(&m), vec![tile(&b, 0, 0, 0), tile(&b, 0, 1, 0), tile(&b, 0, 0, 1), tile(&b, 0, 1, 1)]);
    // (50, 69): columns 30 ..= 70 (tiles 1 ..= 4), rows 49 ..= 69 (tiles 3, 4)
    let (m, _) = run_select(&ctx, &b, &[kp(0, 50, 69)]);
    let want: Vec<usize> =
        (3..=4).flat_map(|ty| (1..=4).map(move |tx| (tx, ty))).map(|(tx, ty)| tile(&b, 0, tx, ty)).collect();
    assert_eq!(marked(&m), want);
    // no corners: no marks (the stale ones cleared)
    assert!(run_select(&ctx, &b, &[]).0.iter().all(|&v| v == 0));
    // on level 1 of three (200 x 120: level 1 is 167 x 100): columns 40 ..= 80
    // (tiles 2 ..= 5), rows 20 ..= 60 (tiles 1 ..= 3), nothing on the other levels
    let cfg = Config { n_levels: 3, ..Config::default() };
    let b = Buffers::new(&ctx.device, &cfg, 200, 120).unwrap();
    let (m, _) = run_select(&ctx, &b, &[kp(1, 60, 40)]);
    let want: Vec<usize> =
        (1..=3).flat_map(|ty| (2..=5).map(move |tx| (tx, ty))).map(|(tx, ty)| tile(&b, 1, tx, ty)).collect();
    assert_eq!(marked(&m), want);
}

#[test]
fn select_marks_what_the_host_does_for_the_keypoints_it_places() {
    let Some(ctx) = t::context() else { return };
    let reach = descriptor_reach();
    for (w, h, levels, cap, seed) in [(130, 75, 4, 1000, 1u32), (257, 190, 6, 1000, 2), (640, 120, 8, 40, 3)] {
        let cfg = Config { n_levels: levels, n_features: cap, ..Config::default() };
        let b = Buffers::new(&ctx.device, &cfg, w, h).unwrap();
        // corners at the corners, edges and centre of every level and pseudo-random ones
        let mut corners = Vec::new();
        let mut r = common::TestRng::new(seed.into());
        for (l, &(lw, lh)) in b.layout.sizes.iter().enumerate() {
            for (x, y) in [(0, 0), (lw - 1, lh - 1), (lw - 1, 0), (0, lh - 1), (lw / 2, lh / 2)] {
                corners.push(kp(l as u32, x, y));
            }
            for _ in 0..20 {
                corners.push(kp(l as u32, r.below(lw), r.below(lh)));
            }
        }
        corners.truncate(b.layout.capacity as usize);
        assert!(corners.len() > 64, "more than one workgroup");
        let (m, placed) = run_select(&ctx, &b, &corners);
        assert!(!placed.is_empty());
        assert_eq!(m, marks(&b, &placed, reach), "{w}x{h}, cap {cap}");
        if cap < corners.len() as u32 {
            // the corners left out mark nothing
            assert!(marks(&b, &corners, reach) != m, "{w}x{h}: the cap left tiles unmarked");
        }
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
