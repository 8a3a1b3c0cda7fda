//! GPU SPEC 9 stages (Harris response, corner NMS, select) against the CPU
//! reference: each stage fed the CPU output of the stage before it, then the
//! three chained.
mod common;

use common::TestRng as Rng;
use lfast::Config;
use lfast::cpu::lfast::{LfastParams, lfast};
use lfast::cpu::select::{Corner, order, select};
use lfast::cpu::{corner_nms, edge_map, response};
use lfast::gpu::buffers::{counter, indirect};
use lfast::gpu::cand_list::CandListPass;
use lfast::gpu::corner_nms::CornerNmsPass;
use lfast::gpu::response::ResponsePass;
use lfast::gpu::select::SelectPass;
use lfast::gpu::{Buffers, GpuContext, GpuKeypoint, Pass};
use lfast::image::load_gray;
use lfast::testing as t;
use lfast::{Error, Plane};

const IMAGES: [&str; 5] =
    ["astronaut_256.png", "camera_cc0_v0.18plus.png", "chessboard_GRAY.png", "coins.png", "text.png"];

fn data(name: &str) -> Plane<u8> {
    load_gray(common::data(name)).unwrap()
}

/// A candidate map (1 = candidate) of a level from a list of positions.
fn cand_map(w: u32, h: u32, cands: &[[u32; 2]]) -> Plane<u8> {
    let mut v = vec![0u8; (w * h) as usize];
    for &[x, y] in cands {
        v[(y * w + x) as usize] = 1;
    }
    Plane::from_vec(w, h, v).unwrap()
}

/// What the CPU gives per level: D, the L-FAST candidates and their responses.
struct CpuLevel {
    denoised: Plane<u8>,
    cands: Vec<[u32; 2]>,
    resp: Vec<f32>,
}

fn cpu_levels(cfg: &Config, img: &Plane<u8>) -> Vec<CpuLevel> {
    let params = LfastParams::from_config(cfg);
    t::cpu_levels(cfg, img)
        .iter()
        .map(|p| {
            let em = edge_map(p, cfg);
            let cands = lfast(&em.edges, None, &params);
            let resp = response::responses(&em.denoised, &cands);
            CpuLevel { denoised: em.denoised, cands, resp }
        })
        .collect()
}

/// Corners appended by corner NMS: the counter and the list.
fn download_corners(ctx: &GpuContext, b: &Buffers) -> Vec<GpuKeypoint> {
    let n = t::download(ctx, &b.counters).unwrap()[counter::CORNERS] as usize;
    assert!(n <= b.layout.capacity as usize, "{n} corners > capacity {}", b.layout.capacity);
    let words = t::download(ctx, &b.corners).unwrap();
    bytemuck::cast_slice::<u32, GpuKeypoint>(&words[..n * 12]).to_vec()
}

/// common.wgsl `list_args`: the workgroups of 64 over a list of n entries,
/// at most 65535 along x and the rest along y.
fn list_args(n: usize) -> [u32; 3] {
    let groups = n.div_ceil(64) as u32;
    [groups.min(65535), groups.div_ceil(65535), 1]
}

/// The final keypoints, after checking the counter and every indirect argument.
fn download_keypoints(ctx: &GpuContext, b: &Buffers, n_corners: usize) -> Vec<GpuKeypoint> {
    let counters = t::download(ctx, &b.counters).unwrap();
    let n = counters[counter::KEYPOINTS] as usize;
    let ind = t::download(ctx, &b.indirect).unwrap();
    let at = |o: u64| &ind[(o / 4) as usize..(o / 4) as usize + 4];
    assert_eq!(at(indirect::CORNERS)[..3], list_args(n_corners), "corner dispatch args");
    assert_eq!(at(indirect::KEYPOINTS)[..3], list_args(n), "keypoint dispatch args");
    assert_eq!(at(indirect::DRAW), [4, n as u32, 0, 0], "draw args");
    assert_eq!(
        at(indirect::KEYPOINT_GROUPS)[..3],
        [n.min(65535) as u32, n.div_ceil(65535) as u32, 1],
        "one-group-per-keypoint dispatch args"
    );
    let words = t::download(ctx, &b.keypoints).unwrap();
    bytemuck::cast_slice::<u32, GpuKeypoint>(&words[..n * 12]).to_vec()
}

/// The keypoint corner NMS writes for a survivor.
fn corner_kp(cfg: &Config, c: &Corner) -> GpuKeypoint {
    let s = cfg.level_scale(c.level) as f32;
    GpuKeypoint {
        x: (c.x as f32 + 0.5) * s,
        y: (c.y as f32 + 0.5) * s,
        size: (31.0 * cfg.level_scale(c.level)) as f32,
        response: c.response,
        level: c.level,
        px: c.x,
        py: c.y,
        ..Default::default()
    }
}

fn bits(k: &GpuKeypoint) -> [u32; 12] {
    bytemuck::cast(*k)
}

#[test]
fn harris_constants_are_the_cpus() {
    // response.wgsl writes scale^4 and k as bit patterns; they must be the CPU's.
    let scale = 1.0f32 / ((1 << 2) as f32 * response::BLOCK as f32 * 255.0);
    let scale_sq_sq = scale * scale * scale * scale;
    let src = lfast::gpu::response::SOURCE;
    assert!(src.contains(&format!("SCALE_SQ_SQ_BITS: u32 = {:#010x}u;", scale_sq_sq.to_bits())), "scale^4");
    assert!(src.contains(&format!("HARRIS_K_BITS: u32 = {:#010x}u;", response::HARRIS_K.to_bits())), "k");
}

#[test]
fn response_matches_cpu_on_real_candidates() {
    let Some(ctx) = t::context() else { return };
    let pass = ResponsePass::new(&ctx.device);
    // both run over the candidate list
    let list = CandListPass::new(&ctx.device);
    let mut checked = 0;
    for name in IMAGES {
        let img = data(name);
        let cfg = Config { n_levels: 4, ..Config::default() };
        let b = Buffers::new(&ctx.device, &cfg, img.width, img.height).unwrap();
        let levels = cpu_levels(&cfg, &img);
        for (l, lv) in levels.iter().enumerate() {
            t::upload_packed(&ctx, &b, &b.denoised, l, &lv.denoised);
            t::upload_packed(&ctx, &b, &b.cand, l, &cand_map(lv.denoised.width, lv.denoised.height, &lv.cands));
        }
        // stale words (what labels and edge_list, the same memory, leave): the pass
        // writes every candidate's word and no other
        const STALE: u32 = 0xdead_beef;
        t::upload(&ctx, &b.resp, &vec![STALE; (b.resp.size() / 4) as usize]);
        t::run(&ctx, &list, &b).unwrap();
        t::run(&ctx, &pass, &b).unwrap();
        for (l, lv) in levels.iter().enumerate() {
            let w = lv.denoised.width;
            let mut want = vec![STALE; lv.denoised.len()];
            for (&[x, y], r) in lv.cands.iter().zip(&lv.resp) {
                want[(y * w + x) as usize] = r.to_bits();
            }
            let got = t::download_level(&ctx, &b, &b.resp, l).unwrap();
            for (i, (g, w_)) in got.iter().zip(&want).enumerate() {
                assert_eq!(g, w_, "{name} level {l} pixel {i}: {} vs {}", f32::from_bits(*g), f32::from_bits(*w_));
            }
            checked += lv.cands.len();
        }
    }
    assert!(checked > 2000, "only {checked} candidates");
}

#[test]
fn response_matches_cpu_at_every_pixel() {
    // Every pixel a candidate: border pixels (clamped reads) and, on the
    // binary-noise image, sums of up to 49 * 1020^2, where the i32 -> f32
    // conversions and the products round.
    let Some(ctx) = t::context() else { return };
    let pass = ResponsePass::new(&ctx.device);
    // both run over the candidate list
    let list = CandListPass::new(&ctx.device);
    let noise = |w: u32, h: u32, seed: u32| {
        let mut r = Rng::new(seed.into());
        Plane::from_vec(w, h, (0..w * h).map(|_| if r.below(2) == 0 { 0 } else { 255 }).collect()).unwrap()
    };
    let mut cases: Vec<(Plane<u8>, u32)> = vec![
        (t::test_image(37, 29, 1), 3),
        (t::test_image(130, 75, 2), 4),
        (t::test_image(17, 1, 3), 1),
        (t::test_image(1, 1, 4), 1),
        (noise(64, 48, 5), 3),
        (noise(150, 110, 6), 2),
    ];
    cases.push((data("chessboard_GRAY.png"), 3));
    let mut values = std::collections::HashSet::new();
    for (img, levels) in &cases {
        let cfg = Config { n_levels: *levels, ..Config::default() };
        let b = Buffers::new(&ctx.device, &cfg, img.width, img.height).unwrap();
        let lv = t::cpu_levels(&cfg, img);
        for (l, p) in lv.iter().enumerate() {
            t::upload_packed(&ctx, &b, &b.denoised, l, p);
            t::upload_packed(&ctx, &b, &b.cand, l, &Plane::from_vec(p.width, p.height, vec![1; p.len()]).unwrap());
        }
        t::run(&ctx, &list, &b).unwrap();
        t::run(&ctx, &pass, &b).unwrap();
        for (l, p) in lv.iter().enumerate() {
            let got = t::download_level(&ctx, &b, &b.resp, l).unwrap();
            for y in 0..p.height {
                for x in 0..p.width {
                    let want = response::harris(p, x, y);
                    let g = got[(y * p.width + x) as usize];
                    values.insert(g);
                    assert_eq!(
                        g,
                        want.to_bits(),
                        "{}x{} level {l} ({x}, {y}): {} vs {want}",
                        img.width,
                        img.height,
                        f32::from_bits(g)
                    );
                }
            }
        }
    }
    assert!(values.len() > 10_000, "only {} distinct responses", values.len());
}

#[test]
fn corner_nms_matches_cpu_on_real_images() {
    let Some(ctx) = t::context() else { return };
    let pass = CornerNmsPass::new(&ctx.device);
    // both run over the candidate list
    let list = CandListPass::new(&ctx.device);
    for name in IMAGES {
        let img = data(name);
        // reject_edges both ways: the shader's early return == survivors()
        for (r, reject_edges) in [(0, true), (1, false), (3, false), (3, true)] {
            let cfg = Config { n_levels: 4, nms_radius: r, reject_edges, ..Config::default() };
            let b = Buffers::new(&ctx.device, &cfg, img.width, img.height).unwrap();
            let levels = cpu_levels(&cfg, &img);
            let mut want = Vec::new();
            for (l, lv) in levels.iter().enumerate() {
                let (w, h) = (lv.denoised.width, lv.denoised.height);
                t::upload_packed(&ctx, &b, &b.cand, l, &cand_map(w, h, &lv.cands));
                let mut resp = vec![0u32; (w * h) as usize];
                for (&[x, y], v) in lv.cands.iter().zip(&lv.resp) {
                    resp[(y * w + x) as usize] = v.to_bits();
                }
                t::upload_level(&ctx, &b, &b.resp, l, &resp);
                for i in corner_nms::survivors(&lv.cands, &lv.resp, r, cfg.reject_edges) {
                    let c = Corner {
                        level: l as u32,
                        x: lv.cands[i][0],
                        y: lv.cands[i][1],
                        response: lv.resp[i],
                        sub: [0, 0],
                        fill: false,
                    };
                    want.push(bits(&corner_kp(&cfg, &c)));
                }
            }
            // stale counters must not matter: prepare clears them
            t::upload(&ctx, &b.counters, &[7, 7, 7, 7]);
            t::run(&ctx, &list, &b).unwrap();
            t::run(&ctx, &pass, &b).unwrap();
            let mut got: Vec<[u32; 12]> = download_corners(&ctx, &b).iter().map(bits).collect();
            got.sort();
            want.sort();
            assert_eq!(got.len(), want.len(), "{name} r={r} reject_edges={reject_edges}");
            assert_eq!(got, want, "{name} r={r} reject_edges={reject_edges}");
            assert!(!want.is_empty(), "{name}");
        }
    }
}

#[test]
fn corner_nms_breaks_ties_by_position() {
    // Dense random candidates with few distinct responses (and -0.0 against
    // 0.0, equal under `beats`): exactly one of each tied group survives.
    let Some(ctx) = t::context() else { return };
    let pass = CornerNmsPass::new(&ctx.device);
    // both run over the candidate list
    let list = CandListPass::new(&ctx.device);
    let pool = [1.0f32, 2.0, -1.0, 0.0, -0.0, 2.0];
    for (w, h, levels, seed) in [(40, 40, 1, 1), (48, 40, 3, 2), (37, 29, 2, 3), (17, 1, 1, 4), (1, 1, 1, 5)] {
        for r in [0, 1, 2, 4] {
            // -0.0, 0.0 and -1.0 are edges under reject_edges: alternate it
            let reject_edges = (seed + r) % 2 == 0;
            let cfg = Config { n_levels: levels, nms_radius: r, border: 7, reject_edges, ..Config::default() };
            let b = Buffers::new(&ctx.device, &cfg, w, h).unwrap();
            let mut rng = Rng::new((seed * 1000 + r + 1).into());
            let mut want = Vec::new();
            for (l, &(lw, lh)) in cfg.level_sizes(w, h).iter().enumerate() {
                let mut cands = Vec::new();
                let mut resp = Vec::new();
                let mut rmap = vec![0u32; (lw * lh) as usize];
                // candidates lie inside the border, as L-FAST's (the capacity bound needs it)
                for y in 7..lh.saturating_sub(7) {
                    for x in 7..lw.saturating_sub(7) {
                        if rng.below(3) == 0 {
                            let v = pool[rng.below(pool.len() as u32) as usize];
                            cands.push([x, y]);
                            resp.push(v);
                            rmap[(y * lw + x) as usize] = v.to_bits();
                        }
                    }
                }
                t::upload_packed(&ctx, &b, &b.cand, l, &cand_map(lw, lh, &cands));
                t::upload_level(&ctx, &b, &b.resp, l, &rmap);
                for i in corner_nms::survivors(&cands, &resp, r, cfg.reject_edges) {
                    let c = Corner {
                        level: l as u32,
                        x: cands[i][0],
                        y: cands[i][1],
                        response: resp[i],
                        sub: [0, 0],
                        fill: false,
                    };
                    want.push(bits(&corner_kp(&cfg, &c)));
                }
            }
            t::run(&ctx, &list, &b).unwrap();
            t::run(&ctx, &pass, &b).unwrap();
            let mut got: Vec<[u32; 12]> = download_corners(&ctx, &b).iter().map(bits).collect();
            got.sort();
            want.sort();
            assert_eq!(got, want, "{w}x{h} levels {levels} r={r} reject_edges={reject_edges}");
        }
    }
}

#[test]
fn corner_nms_literal() {
    let Some(ctx) = t::context() else { return };
    let pass = CornerNmsPass::new(&ctx.device);
    // both run over the candidate list
    let list = CandListPass::new(&ctx.device);
    let cfg = Config { n_levels: 1, nms_radius: 1, border: 7, ..Config::default() };
    let b = Buffers::new(&ctx.device, &cfg, 20, 20).unwrap();
    // a tied 2x2 group keeps its first in (y, x) order; (9, 9) beats nothing
    // at distance 2 from (7, 7); (12, 12) loses to (13, 13)
    let pts = [
        ([5, 5], 1.0f32),
        ([6, 5], 1.0),
        ([5, 6], 1.0),
        ([6, 6], 1.0),
        ([9, 9], 0.5),
        ([12, 12], 3.0),
        ([13, 13], 4.0),
    ];
    let mut cand = vec![0u8; 400];
    let mut resp = vec![0u32; 400];
    for ([x, y], r) in pts {
        cand[y * 20 + x] = 1;
        resp[y * 20 + x] = r.to_bits();
    }
    t::upload_packed(&ctx, &b, &b.cand, 0, &Plane::from_vec(20, 20, cand).unwrap());
    t::upload_level(&ctx, &b, &b.resp, 0, &resp);
    t::run(&ctx, &list, &b).unwrap();
    t::run(&ctx, &pass, &b).unwrap();
    let mut got: Vec<(u32, u32)> = download_corners(&ctx, &b).iter().map(|k| (k.px, k.py)).collect();
    got.sort();
    assert_eq!(got, vec![(5, 5), (9, 9), (13, 13)]);
    let k = download_corners(&ctx, &b).into_iter().find(|k| k.px == 9).unwrap();
    assert_eq!((k.x, k.y, k.size, k.angle, k.response, k.level), (9.5, 9.5, 31.0, 0.0, 0.5, 0));
}

/// Random corners of every level of `cfg` at `w x h`: unique positions,
/// responses from a pool with ties, negatives, 0.0 and -0.0, and random ones.
fn random_corners(cfg: &Config, w: u32, h: u32, n: usize, seed: u32) -> Vec<Corner> {
    let mut rng = Rng::new(seed.into());
    let sizes = cfg.level_sizes(w, h);
    let pool = [0.0f32, -0.0, 1.0, -1.0, 2.5e-7, -3.0e-9, 1.0e-3, f32::MIN_POSITIVE, -f32::MIN_POSITIVE];
    let mut seen = std::collections::HashSet::new();
    let mut out = Vec::new();
    // some levels get nothing: skew the level choice toward the first ones
    let used = 1 + rng.below(sizes.len() as u32);
    while out.len() < n {
        let l = rng.below(used).min(rng.below(used));
        let (lw, lh) = sizes[l as usize];
        let (x, y) = (rng.below(lw), rng.below(lh));
        if !seen.insert((l, x, y)) {
            continue;
        }
        let response = match rng.below(3) {
            0 => pool[rng.below(pool.len() as u32) as usize],
            1 => (rng.below(2000) as f32 - 1000.0) * 1.0e-6,
            _ => f32::from_bits(rng.next_u32() & 0xbfff_ffff), // finite, any sign and scale
        };
        out.push(Corner { level: l, x, y, response, sub: [0, 0], fill: false });
    }
    out
}

/// Uploads `corners` as the unordered list (with distinct payloads in the
/// fields select only copies) and the count, runs select, and checks the
/// result against `cpu::select::select`.
fn check_select(ctx: &GpuContext, pass: &SelectPass, cfg: &Config, w: u32, h: u32, corners: &[Corner], what: &str) {
    let b = Buffers::new(&ctx.device, cfg, w, h).unwrap();
    assert!(corners.len() <= b.layout.capacity as usize, "{what}: test needs capacity");
    let kp = |c: &Corner| GpuKeypoint {
        angle: c.x as f32 * 0.25,
        m10: c.y as i32 - 1000,
        m01: -(c.x as i32),
        bin: c.level * 7,
        sub: 0xdead,
        ..corner_kp(cfg, c)
    };
    let list: Vec<GpuKeypoint> = corners.iter().map(kp).collect();
    if !list.is_empty() {
        ctx.queue.write_buffer(&b.corners, 0, bytemuck::cast_slice(&list));
    }
    // KEYPOINTS and TAKEN hold junk from an earlier frame
    t::upload(ctx, &b.counters, &[corners.len() as u32, 12345, 999, 0]);
    t::upload(ctx, &b.indirect, &[77; 12]);
    t::run(ctx, pass, &b).unwrap();
    let sizes = cfg.level_sizes(w, h);
    let mut per_level = vec![Vec::new(); sizes.len()];
    for c in corners {
        per_level[c.level as usize].push(*c);
    }
    let want: Vec<[u32; 12]> = select(per_level, &sizes, cfg.n_features, false).iter().map(|c| bits(&kp(c))).collect();
    let got: Vec<[u32; 12]> = download_keypoints(ctx, &b, corners.len()).iter().map(bits).collect();
    assert_eq!(got.len(), want.len(), "{what}: count");
    for (i, (g, w_)) in got.iter().zip(&want).enumerate() {
        assert_eq!(g, w_, "{what}: keypoint {i}");
    }
}

#[test]
fn select_matches_cpu_on_random_corners() {
    let Some(ctx) = t::context() else { return };
    let pass = SelectPass::new(&ctx.device);
    // nms_radius 0 and border 7: a capacity far above the corner counts
    for (n, levels, seed) in
        [(0, 3, 1), (1, 1, 2), (5, 2, 3), (63, 4, 4), (64, 3, 5), (65, 8, 6), (700, 5, 7), (2500, 6, 8)]
    {
        for cap in [0, 1, 3, 10, 64, 100, 1000, 5000] {
            let cfg = Config { n_levels: levels, nms_radius: 0, border: 7, n_features: cap, ..Config::default() };
            let corners = random_corners(&cfg, 200, 150, n, seed * 31 + cap);
            check_select(&ctx, &pass, &cfg, 200, 150, &corners, &format!("{n} corners, {levels} levels, cap {cap}"));
        }
    }
}

/// Many corners per bucket of select's key buckets: responses within a few
/// ulps of 1.0, ~500 corners on each value, so even buckets as narrow as one
/// value hold hundreds; place compares within the bucket only, so this is
/// its worst case, and the ties go by position.
#[test]
fn select_with_every_corner_in_one_bucket() {
    let Some(ctx) = t::context() else { return };
    let pass = SelectPass::new(&ctx.device);
    for cap in [0, 10, 1000, 3000] {
        let cfg = Config { n_levels: 4, nms_radius: 0, border: 7, n_features: cap, ..Config::default() };
        let mut corners = random_corners(&cfg, 200, 150, 2500, 99 + cap);
        for (k, c) in corners.iter_mut().enumerate() {
            c.response = f32::from_bits(1.0f32.to_bits() + (k as u32 * 7) % 5);
        }
        check_select(&ctx, &pass, &cfg, 200, 150, &corners, &format!("one bucket, cap {cap}"));
    }
}

#[test]
fn select_orders_signed_zeros_and_ties() {
    let Some(ctx) = t::context() else { return };
    let pass = SelectPass::new(&ctx.device);
    let c = |level, x, y, response| Corner { level, x, y, response, sub: [0, 0], fill: false };
    let corners = vec![
        c(0, 30, 20, -0.0),
        c(0, 20, 20, 0.0),
        c(1, 10, 10, 0.0),
        c(0, 25, 21, -1.0),
        c(0, 10, 22, 1.0),
        c(1, 11, 10, 1.0),
        c(0, 40, 20, -0.0),
        c(1, 5, 5, f32::from_bits(1)), // smallest subnormal: above +0.0
        c(1, 6, 5, -f32::from_bits(1)),
    ];
    for cap in [0, 1, 2, 5, 9, 20] {
        let cfg = Config { n_levels: 2, border: 7, n_features: cap, ..Config::default() };
        check_select(&ctx, &pass, &cfg, 64, 48, &corners, &format!("cap {cap}"));
    }
    // the order itself, spelled out (cap 0)
    let mut sorted = corners.clone();
    sorted.sort_by(order);
    let at: Vec<(u32, u32, u32)> = sorted.iter().map(|c| (c.level, c.x, c.y)).collect();
    assert_eq!(
        at,
        vec![
            (0, 10, 22),
            (1, 11, 10),
            (1, 5, 5),
            (0, 20, 20),
            (1, 10, 10),
            (0, 30, 20),
            (0, 40, 20),
            (1, 6, 5),
            (0, 25, 21)
        ]
    );
}

#[test]
fn select_handles_an_empty_list() {
    let Some(ctx) = t::context() else { return };
    let pass = SelectPass::new(&ctx.device);
    for cap in [0, 10] {
        let cfg = Config { n_levels: 3, n_features: cap, ..Config::default() };
        check_select(&ctx, &pass, &cfg, 100, 80, &[], &format!("empty, cap {cap}"));
    }
}

/// SPEC 9 on the GPU, all three passes in turn, from the CPU's D and
/// candidates, against the CPU's corners (as `CpuDetector` selects them).
#[test]
fn response_nms_select_chain_matches_cpu() {
    let Some(ctx) = t::context() else { return };
    let (list, resp, nms, sel) = (
        CandListPass::new(&ctx.device),
        ResponsePass::new(&ctx.device),
        CornerNmsPass::new(&ctx.device),
        SelectPass::new(&ctx.device),
    );
    for name in ["coins.png", "text.png", "astronaut_256.png"] {
        let img = data(name);
        for cap in [0, 50, 500] {
            let cfg = Config { n_levels: 5, n_features: cap, ..Config::default() };
            let b = Buffers::new(&ctx.device, &cfg, img.width, img.height).unwrap();
            let levels = cpu_levels(&cfg, &img);
            let mut per_level = Vec::new();
            for (l, lv) in levels.iter().enumerate() {
                let (w, h) = (lv.denoised.width, lv.denoised.height);
                t::upload_packed(&ctx, &b, &b.denoised, l, &lv.denoised);
                t::upload_packed(&ctx, &b, &b.cand, l, &cand_map(w, h, &lv.cands));
                let keep = corner_nms::survivors(&lv.cands, &lv.resp, cfg.nms_radius, cfg.reject_edges);
                per_level.push(
                    keep.iter()
                        .map(|&i| Corner {
                            level: l as u32,
                            x: lv.cands[i][0],
                            y: lv.cands[i][1],
                            response: lv.resp[i],
                            sub: [0, 0],
                            fill: false,
                        })
                        .collect::<Vec<_>>(),
                );
            }
            let n_corners = per_level.iter().map(Vec::len).sum::<usize>();
            let want: Vec<[u32; 12]> =
                select(per_level, &b.layout.sizes, cap, false).iter().map(|c| bits(&corner_kp(&cfg, c))).collect();
            let run = |r: Result<(), Error>| r.unwrap_or_else(|e| panic!("{name}: {e}"));
            run(t::run(&ctx, &list, &b));
            run(t::run(&ctx, &resp, &b));
            run(t::run(&ctx, &nms, &b));
            run(t::run(&ctx, &sel, &b));
            // the candidate list: every candidate once, and its dispatch args
            let n_cands = levels.iter().map(|lv| lv.cands.len()).sum::<usize>();
            assert_eq!(t::download(&ctx, &b.counters).unwrap()[counter::CANDS] as usize, n_cands, "{name} candidates");
            let g = n_cands.div_ceil(64) as u32;
            let ind = t::download(&ctx, &b.indirect).unwrap();
            let at = (indirect::CANDS / 4) as usize;
            assert_eq!(ind[at..at + 3], [g.min(65535), g.div_ceil(65535), 1], "{name} candidate dispatch args");
            let got: Vec<[u32; 12]> = download_keypoints(&ctx, &b, n_corners).iter().map(bits).collect();
            assert_eq!(got, want, "{name} cap {cap}");
            assert!(!want.is_empty());
        }
    }
}

/// The args the select and snap passes write for their dispatches over the
/// corners and keypoints stay within the 65535 workgroups a dimension that
/// every device allows, and cover the list exactly, whatever its length:
/// past the limit wgpu's check of indirect args zeroes a dispatch (the frame
/// would lose its keypoints), and a device without the check may do
/// anything. Each args entry point runs alone on a forged count (the
/// capacity forged too, so nothing clamps it).
#[test]
fn dispatch_args_stay_within_the_workgroup_limit() {
    use lfast::gpu::kernel::{Kernel, compile};
    use lfast::gpu::{select as sel, snap};
    let Some(ctx) = t::context() else { return };
    let cfg = Config { n_features: 0, ..Config::default() };
    let b = Buffers::new(&ctx.device, &cfg, 64, 48).unwrap();
    let mut p = b.layout.params;
    p.capacity = u32::MAX;
    ctx.queue.write_buffer(&b.params, 0, bytemuck::bytes_of(&p));
    let buffers = [
        ("P", &b.params),
        ("corners", &b.corners),
        ("counters", &b.counters),
        ("ranks", &b.ranks),
        ("keypoints", &b.keypoints),
        ("indirect", &b.indirect),
        ("buckets", &b.sel_buckets),
        ("members", &b.sel_members),
        ("blur_tiles", &b.blur_tiles),
        ("cand_list", &b.cand_list),
        ("denoised", &b.denoised),
        ("resp", &b.resp),
        ("mask", &b.mask),
    ];
    let select_module = compile(&ctx.device, "select", sel::SOURCE);
    let snap_module = compile(&ctx.device, "snap", snap::SOURCE);
    // (name, kernel, the args it writes: a byte offset into `indirect`)
    let kernel = |m: &wgpu::ShaderModule, name: &str, entry: &str, bindings| {
        Kernel::from_module(&ctx.device, name, m, entry, bindings)
    };
    let kernels = [
        ("select::args", kernel(&select_module, "select::args", "args", sel::BINDINGS), indirect::CORNERS),
        ("select::finish", kernel(&select_module, "select::finish", "finish", sel::BINDINGS), indirect::KEYPOINTS),
        ("snap::snap_args", kernel(&snap_module, "snap::snap_args", "snap_args", snap::BINDINGS), indirect::CORNERS),
    ];
    let limit = 65535u64;
    for n in [0u32, 1, 63, 64, 65, 64 * 65535, 64 * 65535 + 1, 5_000_000, 64 * 65535 * 3 + 7, u32::MAX / 64 * 63] {
        for (name, k, at) in &kernels {
            // CORNERS = TAKEN = n: select's finish counts the taken corners (no cap)
            t::upload(&ctx, &b.counters, &[n, 0, n, 0]);
            t::upload(&ctx, &b.indirect, &[0; 16]);
            let group = k.bind_from(&ctx.device, &buffers).unwrap();
            let mut enc = ctx.device.create_command_encoder(&Default::default());
            {
                let mut pass = enc.begin_compute_pass(&Default::default());
                k.dispatch(&mut pass, &group, [1, 1, 1]);
            }
            ctx.queue.submit([enc.finish()]);
            let words = t::download(&ctx, &b.indirect).unwrap();
            let a = &words[*at as usize / 4..*at as usize / 4 + 3];
            let (x, y, z) = (a[0] as u64, a[1] as u64, a[2] as u64);
            let what = format!("{name} at {n}: ({x}, {y}, {z})");
            assert!(x <= limit && y <= limit && z == 1, "{what}");
            // list_index (common.wgsl): entry (y' 65535 + x') 64 + lane
            let (groups, need) = (x * y, (n as u64).div_ceil(64));
            assert!(groups >= need && (y == 0 || (y - 1) * limit < need), "{what}: covers {groups} groups of 64");
            assert_eq!(x, need.min(limit), "{what}");
        }
    }
}
