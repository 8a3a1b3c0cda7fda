//! GPU SPEC 2-6 (gradient, nms, histogram, their fusion gradient_nms, otsu,
//! local_threshold, classify) against the CPU reference, bit for bit: each
//! stage alone on the CPU output of the stage before it, on sizes that cross
//! the 16-pixel tiles and on several pyramid levels, then the pipeline's front
//! passes chained on the GPU from `denoised`.

mod common;
use common::TestRng as Rng;

use common::crop;
use lfast::cpu::classify::{NONE, STRONG};
use lfast::cpu::{self, EdgeMap};
use lfast::gpu::classify::ClassifyPass;
use lfast::gpu::gradient::GradientPass;
use lfast::gpu::gradient_nms::GradientNmsPass;
use lfast::gpu::histogram::HistogramPass;
use lfast::gpu::local_threshold::LocalThresholdPass;
use lfast::gpu::nms::NmsPass;
use lfast::gpu::otsu::OtsuPass;
use lfast::gpu::{Buffers, GpuContext, Pass, StagePlanes};
use lfast::testing as t;
use lfast::{Config, Plane};

/// (width, height, levels, seed, alpha_pct): crossing tile edges, 1-pixel
/// images and rows, several levels, several alphas.
const CASES: &[(u32, u32, u32, u32, u32)] = &[
    (37, 29, 3, 1, 35),
    (130, 75, 4, 5, 35),
    (17, 1, 1, 4, 35),
    (1, 1, 1, 3, 35),
    (1, 23, 2, 8, 35),
    (64, 48, 2, 2, 0),
    (33, 17, 3, 7, 99),
    (16, 16, 1, 6, 50),
    // widths 3 and 71 (quad passes: every remainder mod 4, quads past the edge)
    (3, 21, 2, 9, 35),
    (71, 19, 2, 10, 35),
];

/// One case: its config, buffers and the CPU edge map of every pyramid level.
struct Case {
    name: String,
    b: Buffers,
    cpu: Vec<EdgeMap>,
}

fn case(ctx: &GpuContext, &(w, h, levels, seed, alpha_pct): &(u32, u32, u32, u32, u32)) -> Case {
    let cfg = Config { n_levels: levels, alpha_pct, ..Config::default() };
    let img = t::test_image(w, h, seed);
    cases_from(ctx, cfg, &img, format!("{w}x{h} seed {seed} alpha {alpha_pct}"))
}

fn cases_from(ctx: &GpuContext, cfg: Config, img: &Plane<u8>, name: String) -> Case {
    let b = Buffers::with_stage_planes(&ctx.device, &cfg, img.width, img.height).unwrap();
    let cpu = t::cpu_levels(&cfg, img).iter().map(|p| cpu::edge_map(p, &cfg)).collect();
    Case { name, b, cpu }
}

/// The planes of the staged gradient and nms passes.
fn st(b: &Buffers) -> &StagePlanes {
    b.stage_planes().expect("made with Buffers::with_stage_planes")
}

/// A detector's buffers have no gx, gy and S planes (the pipeline's fused
/// pass needs none): binding the staged passes to them is an error that says
/// which constructor allocates them.
#[test]
fn staged_passes_need_the_stage_planes() {
    let Some(ctx) = t::context() else { return };
    let b = Buffers::new(&ctx.device, &Config::default(), 64, 48).unwrap();
    assert!(b.stage.is_none());
    let e = GradientPass::new(&ctx.device).bind(&ctx.device, &b).unwrap_err().to_string();
    assert!(e.contains("Buffers::with_stage_planes"), "{e}");
    assert!(NmsPass::new(&ctx.device).bind(&ctx.device, &b).is_err());
    GradientNmsPass::new(&ctx.device).bind(&ctx.device, &b).unwrap();
}

/// M8 = min(M, 255): what the GPU keeps of M (`Buffers::m`, column-packed).
fn m8(m: &Plane<u16>) -> Plane<u8> {
    Plane::from_vec(m.width, m.height, m.data.iter().map(|&v| v.min(255) as u8).collect()).unwrap()
}

/// A plane as the u32 words of an atlas level (signed values as their i32 bits).
fn words<T: Copy + Into<i64>>(p: &Plane<T>) -> Vec<u32> {
    p.data.iter().map(|&v| v.into() as i32 as u32).collect()
}

/// Fills a whole buffer with a non-zero pattern, so a pass that forgets to
/// write (or to clear) shows up.
fn poison(ctx: &GpuContext, buf: &lfast::wgpu::Buffer) {
    let n = (buf.size() / 4) as usize;
    t::upload(ctx, buf, &vec![0xdead_beef; n]);
}

/// T1 as the GPU stores it: k + 1, or 0 for no edges.
fn t1_word(em: &EdgeMap) -> u32 {
    em.t1().unwrap_or(0)
}

/// The CPU windows as the GPU stores them: min, max, median, V3.
fn window_words(em: &EdgeMap) -> Vec<u32> {
    em.windows.stats.iter().flat_map(|s| [s.min as u32, s.max as u32, s.median as u32, s.v3()]).collect()
}

#[test]
fn gradient_matches_cpu() {
    let Some(ctx) = t::context() else { return };
    let pass = GradientPass::new(&ctx.device);
    for c in CASES {
        let Case { name, b, cpu, .. } = case(&ctx, c);
        for buf in [&st(&b).gx, &st(&b).gy, &st(&b).s, &b.m] {
            poison(&ctx, buf);
        }
        for (l, em) in cpu.iter().enumerate() {
            t::upload_packed(&ctx, &b, &b.denoised, l, &em.denoised);
        }
        t::run(&ctx, &pass, &b).unwrap();
        for (l, em) in cpu.iter().enumerate() {
            let g = &em.gradient;
            let got = |buf| t::download_level(&ctx, &b, buf, l).unwrap();
            assert_eq!(got(&st(&b).gx), words(&g.gx2), "gx2 {name} level {l}");
            assert_eq!(got(&st(&b).gy), words(&g.gy2), "gy2 {name} level {l}");
            assert_eq!(got(&st(&b).s), words(&g.s), "S {name} level {l}");
            let m = t::download_packed(&ctx, &b, &b.m, l).unwrap();
            assert_eq!(m, words(&m8(&g.m)), "M8 {name} level {l}");
        }
    }
}

/// The extremes of SPEC 2 on 2x2 literals: gx2 = ±510, S = 2 * 255^2, M = 360 at most.
#[test]
fn gradient_extremes() {
    let Some(ctx) = t::context() else { return };
    let pass = GradientPass::new(&ctx.device);
    let cfg = Config { n_levels: 1, ..Config::default() };
    for d in [[0u8, 255, 0, 255], [255, 0, 255, 0], [0, 0, 0, 255], [0, 255, 255, 255], [255, 0, 0, 255], [7, 7, 7, 7]]
    {
        let d = Plane::from_vec(2, 2, d.to_vec()).unwrap();
        let b = Buffers::with_stage_planes(&ctx.device, &cfg, 2, 2).unwrap();
        t::upload_packed(&ctx, &b, &b.denoised, 0, &d);
        t::run(&ctx, &pass, &b).unwrap();
        let g = cpu::gradient::gradient(&d);
        assert_eq!(t::download_level(&ctx, &b, &st(&b).gx, 0).unwrap(), words(&g.gx2), "{:?}", d.data);
        assert_eq!(t::download_level(&ctx, &b, &st(&b).gy, 0).unwrap(), words(&g.gy2), "{:?}", d.data);
        assert_eq!(t::download_packed(&ctx, &b, &b.m, 0).unwrap(), words(&m8(&g.m)), "{:?}", d.data);
    }
}

/// M = isqrt(S) >> 1 over pure noise, where gx2 and gy2 spread over their
/// whole range [-510, 510] (and S over [0, 2 * 510^2]).
#[test]
fn gradient_matches_cpu_on_noise() {
    let Some(ctx) = t::context() else { return };
    let pass = GradientPass::new(&ctx.device);
    let cfg = Config { n_levels: 1, ..Config::default() };
    let (w, h) = (200u32, 150u32);
    let mut r = Rng::new(3);
    // Mostly 0 / 255 so the extremes are frequent, the rest uniform.
    let d = Plane::<u8>::from_vec(
        w,
        h,
        (0..w * h)
            .map(|_| match r.below_u64(3) {
                0 => 0,
                1 => 255,
                _ => r.below_u64(256) as u8,
            })
            .collect(),
    )
    .unwrap();
    let b = Buffers::with_stage_planes(&ctx.device, &cfg, w, h).unwrap();
    t::upload_packed(&ctx, &b, &b.denoised, 0, &d);
    t::run(&ctx, &pass, &b).unwrap();
    let g = cpu::gradient::gradient(&d);
    for v in [-510, 510] {
        assert!(g.gx2.data.contains(&v) && g.gy2.data.contains(&v));
    }
    assert_eq!(t::download_level(&ctx, &b, &st(&b).gx, 0).unwrap(), words(&g.gx2));
    assert_eq!(t::download_level(&ctx, &b, &st(&b).gy, 0).unwrap(), words(&g.gy2));
    assert_eq!(t::download_level(&ctx, &b, &st(&b).s, 0).unwrap(), words(&g.s));
    assert_eq!(t::download_packed(&ctx, &b, &b.m, 0).unwrap(), words(&m8(&g.m)));
}

#[test]
fn nms_matches_cpu() {
    let Some(ctx) = t::context() else { return };
    let pass = NmsPass::new(&ctx.device);
    for c in CASES {
        let Case { name, b, cpu, .. } = case(&ctx, c);
        poison(&ctx, &b.nms);
        for (l, em) in cpu.iter().enumerate() {
            let g = &em.gradient;
            t::upload_level(&ctx, &b, &st(&b).gx, l, &words(&g.gx2));
            t::upload_level(&ctx, &b, &st(&b).gy, l, &words(&g.gy2));
            t::upload_plane(&ctx, &b, &st(&b).s, l, &g.s);
        }
        t::run(&ctx, &pass, &b).unwrap();
        for (l, em) in cpu.iter().enumerate() {
            assert_eq!(t::download_packed(&ctx, &b, &b.nms, l).unwrap(), words(&em.nms), "{name} level {l}");
        }
    }
}

/// NMS on gradients drawn from the sector boundaries of SPEC 3 (and zeros,
/// both signs), with S from a small range so that equal neighbours (the
/// `>` against `>=` asymmetry) are frequent.
#[test]
fn nms_sector_boundaries_and_ties() {
    let Some(ctx) = t::context() else { return };
    let pass = NmsPass::new(&ctx.device);
    let cfg = Config { n_levels: 1, ..Config::default() };
    let (w, h) = (45u32, 35u32);
    let pairs = [(1000, 414), (1000, 415), (415, 1000), (414, 1000), (5, 5), (0, 0), (0, 7), (7, 0), (510, 0), (1, 1)];
    let mut r = Rng::new(11);
    let mut gx = Vec::new();
    let mut gy = Vec::new();
    for _ in 0..w * h {
        let (a, b) = pairs[r.below_u64(pairs.len() as u64) as usize];
        gx.push(if r.below_u64(2) == 0 { a } else { -a });
        gy.push(if r.below_u64(2) == 0 { b } else { -b });
    }
    let s: Vec<u32> = (0..w * h).map(|_| r.below_u64(4) as u32).collect();
    let g = cpu::gradient::Gradient {
        gx2: Plane::from_vec(w, h, gx).unwrap(),
        gy2: Plane::from_vec(w, h, gy).unwrap(),
        s: Plane::from_vec(w, h, s).unwrap(),
        m: Plane::new(w, h),
    };
    let b = Buffers::with_stage_planes(&ctx.device, &cfg, w, h).unwrap();
    t::upload_level(&ctx, &b, &st(&b).gx, 0, &words(&g.gx2));
    t::upload_level(&ctx, &b, &st(&b).gy, 0, &words(&g.gy2));
    t::upload_plane(&ctx, &b, &st(&b).s, 0, &g.s);
    t::run(&ctx, &pass, &b).unwrap();
    let want = cpu::nms::nms(&g);
    assert!(want.data.contains(&1));
    assert_eq!(t::download_packed(&ctx, &b, &b.nms, 0).unwrap(), words(&want));
}

#[test]
fn histogram_matches_cpu() {
    let Some(ctx) = t::context() else { return };
    let pass = HistogramPass::new(&ctx.device);
    for c in CASES {
        let Case { name, b, cpu, .. } = case(&ctx, c);
        poison(&ctx, &b.hist); // `prepare` must clear it
        for (l, em) in cpu.iter().enumerate() {
            t::upload_packed(&ctx, &b, &b.m, l, &m8(&em.gradient.m));
        }
        t::run(&ctx, &pass, &b).unwrap();
        let hist = t::download(&ctx, &b.hist).unwrap();
        for (l, em) in cpu.iter().enumerate() {
            assert_eq!(&hist[l * 256..][..256], &em.histogram[..], "{name} level {l}");
        }
        // Running twice gives the same bins (cleared, not accumulated).
        t::run(&ctx, &pass, &b).unwrap();
        assert_eq!(t::download(&ctx, &b.hist).unwrap(), hist, "{name} second run");
    }
}

/// The fused pass (the pipeline's) gives the staged passes' M and NMS flags:
/// on the cases, and on low-contrast noise (D in 0..4, so equal neighbours and
/// every sector are frequent) at sizes crossing the tiles.
#[test]
fn gradient_nms_matches_cpu() {
    let Some(ctx) = t::context() else { return };
    let pass = GradientNmsPass::new(&ctx.device);
    // per case: its name, buffers and per level (D, M, NMS flags) from the CPU
    type Want = (Plane<u8>, Plane<u16>, Plane<u8>);
    let mut cases: Vec<(String, Buffers, Vec<Want>)> = CASES
        .iter()
        .map(|c| {
            let Case { name, b, cpu } = case(&ctx, c);
            let want = cpu.into_iter().map(|em| (em.denoised, em.gradient.m, em.nms)).collect();
            (name, b, want)
        })
        .collect();
    let mut r = Rng::new(29);
    // every width mod 4 (a quad walk's last columns), quads narrower than seven columns
    for (w, h) in [(47u32, 33u32), (16, 2), (2, 19), (1, 1), (3, 21), (6, 5), (71, 18)] {
        let d = Plane::from_vec(w, h, (0..w * h).map(|_| r.below_u64(4) as u8).collect()).unwrap();
        let g = cpu::gradient::gradient(&d);
        let nms = cpu::nms::nms(&g);
        let b = Buffers::new(&ctx.device, &Config { n_levels: 1, ..Config::default() }, w, h).unwrap();
        cases.push((format!("{w}x{h} noise"), b, vec![(d, g.m, nms)]));
    }
    for (name, b, want) in cases {
        for buf in [&b.m, &b.nms] {
            poison(&ctx, buf);
        }
        for (l, (d, ..)) in want.iter().enumerate() {
            t::upload_packed(&ctx, &b, &b.denoised, l, d);
        }
        t::run(&ctx, &pass, &b).unwrap();
        for (l, (_, m, nms)) in want.iter().enumerate() {
            assert_eq!(t::download_packed(&ctx, &b, &b.m, l).unwrap(), words(&m8(m)), "M8 {name} level {l}");
            assert_eq!(t::download_packed(&ctx, &b, &b.nms, l).unwrap(), words(nms), "nms {name} level {l}");
        }
    }
}

/// Magnitudes above 255 land in bin 255 (the CPU histogram of M, which clips
/// itself, equals the GPU's of the M8 it keeps), large flat runs count exactly.
#[test]
fn histogram_clips_and_counts_runs() {
    let Some(ctx) = t::context() else { return };
    let pass = HistogramPass::new(&ctx.device);
    let cfg = Config { n_levels: 1, ..Config::default() };
    let (w, h) = (45u32, 38u32);
    let m =
        Plane::<u16>::from_vec(w, h, (0..w * h).map(|i| if i % 7 == 0 { 255 + (i % 106) as u16 } else { 3 }).collect())
            .unwrap();
    let b = Buffers::new(&ctx.device, &cfg, w, h).unwrap();
    t::upload_packed(&ctx, &b, &b.m, 0, &m8(&m));
    t::run(&ctx, &pass, &b).unwrap();
    let hist = t::download(&ctx, &b.hist).unwrap();
    assert_eq!(&hist[..256], &cpu::histogram::histogram(&m)[..]);
}

#[test]
fn otsu_matches_cpu_on_images() {
    let Some(ctx) = t::context() else { return };
    let pass = OtsuPass::new(&ctx.device);
    for c in CASES {
        let Case { name, b, cpu, .. } = case(&ctx, c);
        poison(&ctx, &b.otsu);
        let hist: Vec<u32> = cpu.iter().flat_map(|em| em.histogram).collect();
        t::upload(&ctx, &b.hist, &hist);
        t::run(&ctx, &pass, &b).unwrap();
        let got = t::download(&ctx, &b.otsu).unwrap();
        for (l, em) in cpu.iter().enumerate() {
            assert_eq!(got[l], t1_word(em), "{name} level {l}");
        }
    }
}

/// Largest image of docs/algorithm.md: 16384 x 16384 = 2^28 pixels.
const MAX_PX: u64 = 1 << 28;

/// A histogram of kind `kind`, with at most `MAX_PX` pixels in all.
fn random_histogram(r: &mut Rng, kind: u64) -> [u32; 256] {
    let mut h = [0u32; 256];
    match kind {
        // empty
        0 => {}
        // one bin, any count up to the largest image
        1 => h[r.below_u64(256) as usize] = 1 + r.below_u64(MAX_PX) as u32,
        // two bins anywhere, counts of any size
        2 => {
            let a = r.below_u64(256) as usize;
            let b = r.below_u64(256) as usize;
            h[a] = 1 + r.below_u64(MAX_PX / 2) as u32;
            h[b] += 1 + r.below_u64(MAX_PX / 2) as u32;
        }
        // two adjacent bins, very unequal
        3 => {
            let a = r.below_u64(255) as usize;
            h[a] = 1 + r.below_u64(MAX_PX - 1) as u32;
            h[a + 1] = (1 + r.below_u64(1000) as u32).min((MAX_PX - h[a] as u64) as u32);
        }
        // a few bins with huge counts
        4 => {
            let mut left = MAX_PX;
            for _ in 0..1 + r.below_u64(6) {
                let c = r.below_u64(left / 2 + 1);
                h[r.below_u64(256) as usize] += c as u32;
                left -= c;
            }
        }
        // dense small counts
        5 => h.iter_mut().for_each(|c| *c = r.below_u64(5000) as u32),
        // dense counts filling (nearly) the largest image
        6 => h.iter_mut().for_each(|c| *c = r.below_u64(MAX_PX / 256) as u32),
        // symmetric around 127.5: the split at k and at 254 - k tie exactly
        7 => {
            for i in 0..128 {
                let c = if r.below_u64(3) == 0 { 0 } else { r.below_u64(1 << 20) as u32 };
                h[i] = c;
                h[255 - i] = c;
            }
        }
        // symmetric small clusters: ties among few candidates
        8 => {
            let c = 1 + r.below_u64(100) as u32;
            let lo = r.below_u64(120) as usize;
            let gap = 1 + r.below_u64(10) as usize;
            h[lo] = c;
            h[lo + gap] = 1 + r.below_u64(50) as u32;
            h[lo + 2 * gap] = c;
        }
        // a gradient-magnitude-like histogram: a big spike at 0 and a long tail
        _ => {
            h[0] = r.below_u64(MAX_PX / 2) as u32;
            let mut c = r.below_u64(1 << 22) + 1;
            for v in h.iter_mut().skip(1) {
                *v = c as u32;
                c = c * (900 + r.below_u64(100)) / 1000;
            }
        }
    }
    h
}

/// Otsu on hundreds of random histograms, degenerate and huge ones included,
/// uploaded straight into `hist` (32 levels = 32 histograms per dispatch).
#[test]
fn otsu_matches_cpu_on_random_histograms() {
    let Some(ctx) = t::context() else { return };
    let pass = OtsuPass::new(&ctx.device);
    let cfg = Config { n_levels: 32, ..Config::default() };
    let b = Buffers::new(&ctx.device, &cfg, 8, 8).unwrap();
    let mut r = Rng::new(0x5eed);
    let mut fixed: Vec<[u32; 256]> = Vec::new();
    // The literal cases of src/cpu/otsu.rs and the extremes of the bound.
    let mut h = [0u32; 256];
    h[10] = 50;
    h[200] = 50;
    fixed.push(h);
    let mut h = [0u32; 256];
    h[0] = 1 << 27;
    h[255] = 1 << 27;
    fixed.push(h);
    h[128] = 12345;
    h[0] -= 12345;
    fixed.push(h);
    let mut h = [0u32; 256];
    h[0] = (1 << 28) - 1;
    h[255] = 1;
    fixed.push(h);
    let mut h = [0u32; 256];
    h[254] = 1;
    h[255] = (1 << 28) - 1;
    fixed.push(h);
    let mut h = [0u32; 256];
    h[255] = u32::MAX; // one bin: no edges whatever the count
    fixed.push(h);
    fixed.push([(1 << 28) / 256; 256]); // flat, the most pixels
    fixed.push([1; 256]);
    let mut h = [0u32; 256];
    h[0] = 1000;
    h[1] = 1;
    fixed.push(h);
    let mut all = fixed;
    for i in 0..700u64 {
        all.push(random_histogram(&mut r, i % 10));
    }
    let mut seen_none = false;
    for chunk in all.chunks(32) {
        let mut words: Vec<u32> = chunk.iter().flatten().copied().collect();
        words.resize(32 * 256, 0);
        t::upload(&ctx, &b.hist, &words);
        poison(&ctx, &b.otsu);
        t::run(&ctx, &pass, &b).unwrap();
        let got = t::download(&ctx, &b.otsu).unwrap();
        for (i, h) in chunk.iter().enumerate() {
            let want = cpu::otsu::otsu(h).map_or(0, |k| k as u32 + 1);
            seen_none |= want == 0;
            assert_eq!(
                got[i],
                want,
                "histogram {:?}",
                h.iter().enumerate().filter(|(_, c)| **c > 0).collect::<Vec<_>>()
            );
        }
        // Levels past the chunk saw empty histograms: no edges.
        assert!(got[chunk.len()..32].iter().all(|&v| v == 0));
    }
    assert!(seen_none);
}

#[test]
fn local_threshold_matches_cpu() {
    let Some(ctx) = t::context() else { return };
    let pass = LocalThresholdPass::new(&ctx.device);
    for c in CASES {
        let Case { name, b, cpu, .. } = case(&ctx, c);
        poison(&ctx, &b.windows);
        poison(&ctx, &b.hist); // `prepare` must clear it
        for (l, em) in cpu.iter().enumerate() {
            t::upload_packed(&ctx, &b, &b.m, l, &m8(&em.gradient.m));
            // one definition (lfast::spec::WindowLayout) on both paths
            assert_eq!(b.layout.grids[l], em.windows.layout, "{name} level {l}: grid layout");
        }
        t::run(&ctx, &pass, &b).unwrap();
        let got = t::download(&ctx, &b.windows).unwrap();
        // the cells' counts are SPEC 4's histogram too: the CPU's, and the
        // staged histogram pass's
        let hist = t::download(&ctx, &b.hist).unwrap();
        t::run(&ctx, &HistogramPass::new(&ctx.device), &b).unwrap();
        assert_eq!(t::download(&ctx, &b.hist).unwrap(), hist, "{name}: hist of the cells != the histogram pass's");
        for (l, em) in cpu.iter().enumerate() {
            let o = b.layout.window_offsets[l] as usize * 4;
            let want = window_words(em);
            assert_eq!(&got[o..o + want.len()], &want[..], "{name} level {l}");
            assert_eq!(&hist[l * 256..][..256], &em.histogram[..], "hist {name} level {l}");
        }
    }
}

/// Windows holding magnitudes above 255 (clipped to 255) and even-sized windows
/// (the lower median), on an image whose windows are large multiples of the tile.
#[test]
fn local_threshold_clips_and_takes_lower_median() {
    let Some(ctx) = t::context() else { return };
    let pass = LocalThresholdPass::new(&ctx.device);
    let cfg = Config { n_levels: 2, ..Config::default() };
    let (w, h) = (170u32, 90u32);
    let mut r = Rng::new(77);
    let m0 = Plane::<u16>::from_vec(
        w,
        h,
        (0..w * h)
            .map(|i| match r.below_u64(4) {
                0 => 200 + r.below_u64(161) as u16,
                1 => 0,
                _ => ((i % w) / 3) as u16,
            })
            .collect(),
    )
    .unwrap();
    let b = Buffers::new(&ctx.device, &cfg, w, h).unwrap();
    let mut want = Vec::new();
    for (l, &(lw, lh)) in b.layout.sizes.iter().enumerate() {
        let m = Plane::<u16>::from_vec(lw, lh, (0..lw * lh).map(|i| m0.data[(i * 7 % (w * h)) as usize]).collect())
            .unwrap();
        t::upload_packed(&ctx, &b, &b.m, l, &m8(&m));
        let g = cpu::local_threshold::local_threshold(&m);
        want.extend(g.stats.iter().flat_map(|s| [s.min as u32, s.max as u32, s.median as u32, s.v3()]));
    }
    t::run(&ctx, &pass, &b).unwrap();
    assert_eq!(&t::download(&ctx, &b.windows).unwrap()[..want.len()], &want[..]);
}

/// Cells of many more pixels than an invocation's 8-bit register counters
/// hold (shaders/local_threshold.wgsl flushes them every 252 pixels): a
/// 1600x1200 level has 160x120 cells, 600 pixels per invocation, most of them
/// one small value (counted in registers), some large (counted by atomics).
#[test]
fn local_threshold_counts_large_cells() {
    let Some(ctx) = t::context() else { return };
    let pass = LocalThresholdPass::new(&ctx.device);
    let cfg = Config { n_levels: 1, ..Config::default() };
    let (w, h) = (1600u32, 1200u32);
    let mut r = Rng::new(91);
    let m = Plane::<u16>::from_vec(
        w,
        h,
        (0..w * h)
            .map(|_| match r.below_u64(10) {
                0 => 32 + r.below_u64(300) as u16,
                1 => r.below_u64(32) as u16,
                // mostly one value: ~480 of an invocation's pixels, past any 8-bit counter
                _ => 3,
            })
            .collect(),
    )
    .unwrap();
    let b = Buffers::new(&ctx.device, &cfg, w, h).unwrap();
    t::upload_packed(&ctx, &b, &b.m, 0, &m8(&m));
    t::run(&ctx, &pass, &b).unwrap();
    let g = cpu::local_threshold::local_threshold(&m);
    let want: Vec<u32> = g.stats.iter().flat_map(|s| [s.min as u32, s.max as u32, s.median as u32, s.v3()]).collect();
    assert_eq!(&t::download(&ctx, &b.windows).unwrap()[..want.len()], &want[..], "window statistics");
    assert_eq!(&t::download(&ctx, &b.hist).unwrap()[..256], &cpu::histogram::histogram(&m)[..], "level histogram");
}

/// `cell_hist` holds two 16-bit counts a word where no cell can pass 65535
/// pixels (gpu::layout::cell_bin_words), else a count a word: a 2540x2540
/// level (cells of up to 254x254 = 64516 pixels, 16-bit, whose windows' sums
/// pass 65535) and a 2600x2600 one (260x260 = 67600, 32-bit), each almost
/// all one value, so one bin of a cell nearly fills or passes 16 bits.
#[test]
fn local_threshold_counts_cells_near_and_past_16_bits() {
    let Some(ctx) = t::context() else { return };
    let pass = LocalThresholdPass::new(&ctx.device);
    let cfg = Config { n_levels: 1, ..Config::default() };
    for (side, words) in [(2540u32, 128u32), (2600, 256)] {
        assert_eq!(lfast::gpu::layout::cell_bin_words(side, side), words);
        let mut r = Rng::new(side as u64);
        let m = Plane::<u16>::from_vec(
            side,
            side,
            (0..side * side).map(|_| if r.below_u64(100) == 0 { r.below_u64(400) as u16 } else { 5 }).collect(),
        )
        .unwrap();
        let b = Buffers::new(&ctx.device, &cfg, side, side).unwrap();
        t::upload_packed(&ctx, &b, &b.m, 0, &m8(&m));
        t::run(&ctx, &pass, &b).unwrap();
        let g = cpu::local_threshold::local_threshold(&m);
        let want: Vec<u32> =
            g.stats.iter().flat_map(|s| [s.min as u32, s.max as u32, s.median as u32, s.v3()]).collect();
        assert_eq!(&t::download(&ctx, &b.windows).unwrap()[..want.len()], &want[..], "{side}: window statistics");
        assert_eq!(
            &t::download(&ctx, &b.hist).unwrap()[..256],
            &cpu::histogram::histogram(&m)[..],
            "{side}: histogram"
        );
    }
}

#[test]
fn classify_matches_cpu() {
    let Some(ctx) = t::context() else { return };
    let pass = ClassifyPass::new(&ctx.device);
    for c in CASES {
        let Case { name, b, cpu, .. } = case(&ctx, c);
        poison(&ctx, &b.classes);
        let mut windows = Vec::new();
        let mut otsu = Vec::new();
        for (l, em) in cpu.iter().enumerate() {
            t::upload_packed(&ctx, &b, &b.m, l, &m8(&em.gradient.m));
            t::upload_packed(&ctx, &b, &b.nms, l, &em.nms);
            otsu.push(t1_word(em));
            windows.extend(window_words(em));
        }
        t::upload(&ctx, &b.otsu, &otsu);
        t::upload(&ctx, &b.windows, &windows);
        t::run(&ctx, &pass, &b).unwrap();
        for (l, em) in cpu.iter().enumerate() {
            assert_eq!(t::download_packed(&ctx, &b, &b.classes, l).unwrap(), words(&em.classes), "{name} level {l}");
        }
    }
}

/// Every class boundary of SPEC 6 on literal magnitudes: one 1-window image,
/// M = 0..=360 along a row (the GPU is given M8 = min(M, 255), as the pipeline
/// keeps it, and must answer as the CPU does for M), all NMS survivors, fixed T1
/// and V3 (the window's statistics are uploaded directly), several alphas;
/// also T1 = 0 (no edges). T1 = k + 1 <= 255: Otsu's k is at most 254.
#[test]
fn classify_boundaries() {
    let Some(ctx) = t::context() else { return };
    let pass = ClassifyPass::new(&ctx.device);
    let (w, h) = (361u32, 4u32);
    for alpha_pct in [0, 35, 99] {
        let cfg = Config { n_levels: 1, alpha_pct, ..Config::default() };
        let b = Buffers::new(&ctx.device, &cfg, w, h).unwrap();
        let m = Plane::<u16>::from_vec(w, h, (0..w * h).map(|i| (i % w) as u16).collect()).unwrap();
        let keep = Plane::<u8>::from_vec(w, h, (0..w * h).map(|i| (i % 5 != 4) as u8).collect()).unwrap();
        t::upload_packed(&ctx, &b, &b.m, 0, &m8(&m));
        t::upload_packed(&ctx, &b, &b.nms, 0, &keep);
        let n_windows = b.layout.total_windows as usize;
        for (t1, v3) in [(41u32, 100u32), (31, 60), (255, 765), (1, 0), (255, 3), (128, 700), (0, 100)] {
            // The pass reads only V3 of a window: write it directly (min, max
            // and median could not give every V3 with min = max = median).
            let win: Vec<u32> = (0..n_windows).flat_map(|_| [0, 0, 0, v3]).collect();
            t::upload(&ctx, &b.windows, &win);
            t::upload(&ctx, &b.otsu, &[t1]);
            t::run(&ctx, &pass, &b).unwrap();
            let got = t::download_packed(&ctx, &b, &b.classes, 0).unwrap();
            for (i, (&mv, &k)) in m.data.iter().zip(&keep.data).enumerate() {
                let want = if t1 == 0 || k == 0 { NONE } else { cpu::classify::class_of(mv as u32, t1, v3, alpha_pct) };
                assert_eq!(got[i], want as u32, "M {mv} T1 {t1} V3 {v3} alpha {alpha_pct}");
            }
            if t1 != 0 {
                assert!(got.contains(&(STRONG as u32)));
            }
        }
    }
}

/// Records the front passes the way the pipeline driver does, in its order:
/// every `prepare` on the encoder, then one compute pass with the dispatches.
fn run_front(ctx: &GpuContext, b: &Buffers) {
    let dev = &ctx.device;
    let (g, lt, o, c) =
        (GradientNmsPass::new(dev), LocalThresholdPass::new(dev), OtsuPass::new(dev), ClassifyPass::new(dev));
    let scope = dev.push_error_scope(lfast::wgpu::ErrorFilter::Validation);
    let bound = (g.bind(dev, b).unwrap(), lt.bind(dev, b).unwrap(), o.bind(dev, b).unwrap(), c.bind(dev, b).unwrap());
    let mut enc = dev.create_command_encoder(&Default::default());
    g.prepare(&mut enc, b);
    lt.prepare(&mut enc, b);
    o.prepare(&mut enc, b);
    c.prepare(&mut enc, b);
    {
        let mut cp = enc.begin_compute_pass(&lfast::wgpu::ComputePassDescriptor {
            label: Some("edges front"),
            timestamp_writes: None,
        });
        g.record(&mut cp, &bound.0, b);
        lt.record(&mut cp, &bound.1, b);
        o.record(&mut cp, &bound.2, b);
        c.record(&mut cp, &bound.3, b);
    }
    ctx.queue.submit([enc.finish()]);
    assert!(pollster::block_on(scope.pop()).is_none(), "validation error");
    ctx.wait().unwrap();
}

/// The front passes (fused gradient + NMS, local thresholds + histogram, Otsu, classify) chained on the GPU from an uploaded `denoised`, on a
/// 3-level pyramid of real images: classes (and the stage outputs on the way)
/// equal the CPU's.
#[test]
fn chained_front_matches_cpu_on_real_images() {
    let Some(ctx) = t::context() else { return };
    let coins = lfast::image::load_gray(common::data("coins.png")).unwrap();
    let camera = lfast::image::load_gray(common::data("camera_cc0_v0.18plus.png")).unwrap();
    let chess = lfast::image::load_gray(common::data("chessboard_GRAY.png")).unwrap();
    let imgs = [
        ("coins crop", crop(&coins, 120, 80, 190, 150)),
        ("camera crop", crop(&camera, 150, 60, 161, 133)),
        ("chessboard", chess),
    ];
    for (name, img) in imgs {
        let cfg = Config { n_levels: 3, ..Config::default() };
        let Case { b, cpu, .. } = cases_from(&ctx, cfg, &img, name.to_string());
        for buf in [&b.m, &b.nms, &b.hist, &b.otsu, &b.windows, &b.classes] {
            poison(&ctx, buf);
        }
        for (l, em) in cpu.iter().enumerate() {
            t::upload_packed(&ctx, &b, &b.denoised, l, &em.denoised);
        }
        run_front(&ctx, &b);
        let otsu = t::download(&ctx, &b.otsu).unwrap();
        let windows = t::download(&ctx, &b.windows).unwrap();
        let hist = t::download(&ctx, &b.hist).unwrap();
        let mut strong = 0;
        for (l, em) in cpu.iter().enumerate() {
            assert_eq!(t::download_packed(&ctx, &b, &b.nms, l).unwrap(), words(&em.nms), "{name} level {l}: nms");
            assert_eq!(&hist[l * 256..][..256], &em.histogram[..], "{name} level {l}: hist");
            assert_eq!(otsu[l], t1_word(em), "{name} level {l}: T1");
            let o = b.layout.window_offsets[l] as usize * 4;
            let want = window_words(em);
            assert_eq!(&windows[o..o + want.len()], &want[..], "{name} level {l}: windows");
            let classes = t::download_packed(&ctx, &b, &b.classes, l).unwrap();
            assert_eq!(classes, words(&em.classes), "{name} level {l}: classes");
            strong += classes.iter().filter(|&&c| c == STRONG as u32).count();
        }
        assert!(strong > 0, "{name}: the test image has strong edges");
    }
}

#[test]
fn the_case_configs_are_valid() {
    for &(w, h, levels, _, alpha_pct) in CASES {
        Config { n_levels: levels, alpha_pct, ..Config::default() }.validate().unwrap();
        assert!(w * h <= 200 * 150);
    }
}
