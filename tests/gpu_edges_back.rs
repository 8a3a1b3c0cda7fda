//! GPU rules, hysteresis and L-FAST (SPEC 7-8) against the CPU reference,
//! bit for bit: each GPU stage alone, fed the CPU output of the stage before.

mod common;
use common::TestRng as XorRng;

use common::crop;
use lfast::cpu::classify::{EDGE, NONE, STRONG, WEAK, WEAK_STRONG, WEAK_WEAK};
use lfast::cpu::lfast::{LfastParams, lfast as cpu_lfast};
use lfast::cpu::{edge_map, hysteresis::hysteresis, rules::rules};
use lfast::gpu::buffers::{counter, indirect};
use lfast::gpu::hysteresis::HysteresisPass;
use lfast::gpu::lfast::LfastPass;
use lfast::gpu::rules::RulesPass;
use lfast::gpu::{Buffers, GpuContext, Pass};
use lfast::image::load_gray;
use lfast::testing as t;
use lfast::{Config, Mode, Plane};

// ---------------------------------------------------------------- helpers

fn plane(w: u32, h: u32, data: Vec<u8>) -> Plane<u8> {
    Plane::from_vec(w, h, data).expect("plane size")
}

/// Fills the whole of `buf` with `v`, so a pass that skips a pixel shows
/// (its size, not an atlas: the packed planes are smaller).
fn poison(ctx: &GpuContext, buf: &wgpu::Buffer, v: u32) {
    t::upload(ctx, buf, &vec![v; (buf.size() / 4) as usize]);
}

fn to_u32(p: &Plane<u8>) -> Vec<u32> {
    p.data.iter().map(|&v| v as u32).collect()
}

/// Crops of at most ~200x150 of every test image (lavapipe is slow).
fn real_images() -> Vec<(String, Plane<u8>)> {
    let mut out = Vec::new();
    for name in ["astronaut_256", "camera_cc0_v0.18plus", "chessboard_GRAY", "coins", "text"] {
        let img = load_gray(format!("tests/data/{name}.png")).expect("test image");
        let (w, h) = (img.width.min(200), img.height.min(150));
        out.push((name.to_string(), crop(&img, (img.width - w) / 2, (img.height - h) / 2, w, h)));
    }
    out
}

/// Random classes 0..=4 in blobs and lines: WEAK_STRONG / WEAK_WEAK pairs and
/// isolated ones both occur.
fn random_classes(w: u32, h: u32, rng: &mut XorRng) -> Plane<u8> {
    let mut p = Plane::<u8>::new(w, h);
    let density = 1 + rng.below(6); // of 8
    for v in p.data.iter_mut() {
        if rng.below(8) < density {
            *v = rng.below(5) as u8;
        }
    }
    p
}

/// Random ruled planes (NONE, WEAK, STRONG) with `active` of 100 pixels
/// active and 1 of `strong_in` of those STRONG.
fn random_ruled(w: u32, h: u32, active: u32, strong_in: u32, rng: &mut XorRng) -> Plane<u8> {
    let data = (0..w * h)
        .map(|_| {
            if rng.below(100) >= active {
                NONE
            } else if rng.below(strong_in) == 0 {
                STRONG
            } else {
                WEAK
            }
        })
        .collect();
    plane(w, h, data)
}

/// A 1-pixel-wide rectangular spiral of WEAK pixels from (0, 0) inwards, arms
/// one pixel apart (never 8-adjacent), covering the whole plane. Returns the
/// plane and the path in order.
fn spiral(w: u32, h: u32) -> (Plane<u8>, Vec<(u32, u32)>) {
    let mut p = Plane::<u8>::new(w, h);
    let (mut x, mut y) = (0i64, 0i64);
    let mut path = vec![(0u32, 0u32)];
    let dirs = [(1i64, 0i64), (0, 1), (-1, 0), (0, -1)];
    // arms right w-1, down h-1, left w-1, up h-3, right w-3, down h-5, left w-5, ...
    for k in 0usize.. {
        let (dx, dy) = dirs[k % 4];
        let side = if k % 2 == 0 { w } else { h } as i64;
        let len = if k == 0 { side - 1 } else { side - 1 - 2 * ((k as i64 - 1) / 2) };
        if len <= 0 {
            break;
        }
        for _ in 0..len {
            x += dx;
            y += dy;
            path.push((x as u32, y as u32));
        }
    }
    for &(x, y) in &path {
        p.data[(y * w + x) as usize] = WEAK;
    }
    (p, path)
}

/// A serpentine (boustrophedon) WEAK path on every other row, joined at
/// alternating ends, starting at (0, 0).
fn snake(w: u32, h: u32) -> (Plane<u8>, Vec<(u32, u32)>) {
    let mut path = Vec::new();
    for y in (0..h).step_by(2) {
        let row: Vec<u32> = if (y / 2) % 2 == 0 { (0..w).collect() } else { (0..w).rev().collect() };
        path.extend(row.iter().map(|&x| (x, y)));
        if y + 1 < h {
            path.push((if (y / 2) % 2 == 0 { w - 1 } else { 0 }, y + 1));
        }
    }
    let mut p = Plane::<u8>::new(w, h);
    for &(x, y) in &path {
        p.data[(y * w + x) as usize] = WEAK;
    }
    (p, path)
}

/// Runs hysteresis on the given ruled planes (one per level of `b`) and
/// compares every level with the CPU.
fn check_hysteresis(ctx: &GpuContext, pass: &HysteresisPass, b: &Buffers, planes: &[Plane<u8>], what: &str) {
    poison(ctx, &b.labels, 0xdead_beef);
    poison(ctx, &b.flags, 1);
    poison(ctx, &b.edges, 7);
    for (l, p) in planes.iter().enumerate() {
        t::upload_ruled(ctx, b, l, p);
    }
    t::upload_walks(ctx, b, planes);
    poison(ctx, &b.edge_bits, u32::MAX);
    t::run(ctx, pass, b).unwrap();
    let tiles = t::download(ctx, &b.edge_bits).unwrap();
    for (l, p) in planes.iter().enumerate() {
        let edges = hysteresis(p);
        // Paper mode: each tile column's edge rows for L-FAST, every word
        // written or cleared
        if b.layout.params.mode == 0 {
            let want = lfast::gpu::layout::pack_edge_tiles(p.width, p.height, &edges.data);
            assert_eq!(tiles[b.layout.tile_range(l)], want[..], "{what} level {l}: edge_bits");
        }
        let want = to_u32(&edges);
        let got = t::download_packed(ctx, b, &b.edges, l).unwrap();
        if got != want {
            let bad = got.iter().zip(&want).position(|(g, w)| g != w).unwrap_or(0);
            panic!(
                "{what} level {l} ({}x{}): first difference at ({}, {}): gpu {} cpu {}",
                p.width,
                p.height,
                bad as u32 % p.width,
                bad as u32 / p.width,
                got[bad],
                want[bad]
            );
        }
    }
}

/// The buffers of a `w x h` frame, the mask plane allocated (`check_lfast` uploads masks).
fn mask_buffers(ctx: &GpuContext, cfg: &Config, w: u32, h: u32) -> lfast::Result<Buffers> {
    let mut b = Buffers::new(&ctx.device, cfg, w, h)?;
    b.allocate_mask(&ctx.device);
    Ok(b)
}

/// The candidates of level `l` of `cand`, in raster order.
fn gpu_candidates(ctx: &GpuContext, b: &Buffers, l: usize) -> Vec<[u32; 2]> {
    let (w, _) = b.layout.sizes[l];
    let v = t::download_packed(ctx, b, &b.cand, l).unwrap();
    assert!(v.iter().all(|&c| c <= 1), "level {l}: cand holds values other than 0/1");
    v.iter().enumerate().filter(|(_, c)| **c == 1).map(|(i, _)| [i as u32 % w, i as u32 / w]).collect()
}

/// Uploads edge maps (and masks) per level, sets `use_mask`, runs L-FAST
/// and compares each level's candidates with the CPU's.
fn check_lfast(
    ctx: &GpuContext,
    pass: &LfastPass,
    cfg: &Config,
    b: &Buffers,
    edges: &[Plane<u8>],
    masks: Option<&[Plane<u8>]>,
    what: &str,
) -> usize {
    let mut p = b.layout.params;
    p.use_mask = masks.is_some() as u32;
    ctx.queue.write_buffer(&b.params, 0, bytemuck::bytes_of(&p));
    // every byte 1 (what `classes` leaves in the same memory): a word the
    // pass does not clear shows as candidates
    poison(ctx, &b.cand, 0x0101_0101);
    // every bit an edge: a window the `windows` dispatch leaves unwritten
    // shows as edges around the pixels that read it
    poison(ctx, &b.edge_bits, u32::MAX);
    poison(ctx, &b.mask, 0);
    for (l, e) in edges.iter().enumerate() {
        // Branch mode reads `edges`, Paper mode the tile words hysteresis leaves
        t::upload_packed(ctx, b, &b.edges, l, e);
        t::upload_edge_tiles(ctx, b, l, e);
        if let Some(m) = masks {
            t::upload_plane(ctx, b, &b.mask, l, &m[l]);
        }
    }
    // stale cursors must not matter: the pass's prepare clears them
    t::upload(ctx, &b.counters, &[9; counter::LEN]);
    t::run(ctx, pass, b).unwrap();
    let lp = LfastParams::from_config(cfg);
    let mut total = 0;
    let mut all = Vec::new();
    for (l, e) in edges.iter().enumerate() {
        let want = cpu_lfast(e, masks.map(|m| &m[l]), &lp);
        let got = gpu_candidates(ctx, b, l);
        assert_eq!(got, want, "{what} level {l} ({}x{}) {lp:?} mask {}", e.width, e.height, masks.is_some());
        let o = b.layout.level_range(l).start as u32;
        all.extend(want.iter().map(|&[x, y]| o + y * e.width + x));
        total += want.len();
    }
    // the candidate list the pass appends (any order): every candidate once,
    // and the indirect args over it
    let counters = t::download(ctx, &b.counters).unwrap();
    let n = counters[counter::CANDS] as usize;
    let mut list = t::download(ctx, &b.cand_list).unwrap()[..n].to_vec();
    list.sort_unstable();
    all.sort_unstable();
    assert_eq!(list, all, "{what}: the candidate list");
    let args = t::download(ctx, &b.indirect).unwrap();
    let at = (indirect::CANDS / 4) as usize;
    let groups = n.div_ceil(64) as u32;
    assert_eq!(args[at..at + 3], [groups.min(65535), groups.div_ceil(65535), 1], "{what}: the list's dispatch args");
    total
}

/// Random masks: blocks of on / off with some noise, values 0..=255.
fn random_mask(w: u32, h: u32, rng: &mut XorRng) -> Plane<u8> {
    let (bx, by) = (1 + rng.below(9), 1 + rng.below(9));
    let (mut cells, cw) = (Vec::new(), w / bx + 1);
    for _ in 0..cw * (h / by + 1) {
        cells.push(rng.below(3) != 0);
    }
    let data = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let on = cells[((y / by) * cw + x / bx) as usize] ^ (rng.below(10) == 0);
            if on { 1 + rng.below(255) as u8 } else { 0 }
        })
        .collect();
    plane(w, h, data)
}

/// Random edge maps: random straight segments of width 1-2 (corners, junctions
/// and thick lines) plus scattered edge pixels.
fn random_edges(w: u32, h: u32, rng: &mut XorRng) -> Plane<u8> {
    let mut p = Plane::<u8>::new(w, h);
    let n_seg = 3 + (w * h) / 120;
    for _ in 0..n_seg {
        let (mut x, mut y) = (rng.below(w) as i64, rng.below(h) as i64);
        let (dx, dy) = (rng.below(3) as i64 - 1, rng.below(3) as i64 - 1);
        let thick = rng.below(4) == 0;
        for _ in 0..3 + rng.below(20) {
            if x < 0 || y < 0 || x >= w as i64 || y >= h as i64 {
                break;
            }
            p.data[(y as u32 * w + x as u32) as usize] = EDGE;
            if thick && x + 1 < w as i64 {
                p.data[(y as u32 * w + x as u32 + 1) as usize] = EDGE;
            }
            x += dx;
            y += dy;
        }
    }
    for _ in 0..(w * h) / 30 {
        p.data[(rng.below(h) * w + rng.below(w)) as usize] = EDGE;
    }
    p
}

// ---------------------------------------------------------------- shaders

/// The three shaders validate with naga and declare exactly the pass structs'
/// bindings (as tests/gpu_shaders.rs does for every stage, here only these).
#[test]
fn shaders_validate_and_bindings_match() {
    use lfast::gpu::kernel::{Slot, full_source};
    use naga::{AddressSpace, StorageAccess};
    for s in lfast::gpu::SHADERS.iter().filter(|s| ["rules", "hysteresis", "lfast"].contains(&s.name)) {
        let src = full_source(s.source);
        let m = naga::front::wgsl::parse_str(&src)
            .unwrap_or_else(|e| panic!("{}.wgsl: {}", s.name, e.emit_to_string(&src)));
        naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::empty())
            .validate(&m)
            .unwrap_or_else(|e| panic!("{}.wgsl does not validate: {e:?}", s.name));
        let mut found: Vec<(u32, String, Slot)> = m
            .global_variables
            .iter()
            .filter_map(|(_, g)| {
                let rb = g.binding.as_ref()?;
                let slot = match g.space {
                    AddressSpace::Uniform => Slot::Uniform,
                    AddressSpace::Storage { access } if access.contains(StorageAccess::STORE) => Slot::ReadWrite,
                    AddressSpace::Storage { .. } => Slot::Read,
                    _ => Slot::Texture,
                };
                Some((rb.binding, g.name.clone().unwrap_or_default(), slot))
            })
            .collect();
        found.sort_by_key(|f| f.0);
        let declared: Vec<(u32, String, Slot)> =
            s.bindings.iter().map(|b| (b.binding, b.name.to_string(), b.slot)).collect();
        assert_eq!(found, declared, "{}", s.name);
    }
}

// ---------------------------------------------------------------- rules

#[test]
fn rules_literal_case() {
    let Some(ctx) = t::context() else { return };
    let pass = RulesPass::new(&ctx.device);
    let cfg = Config { n_levels: 1, ..Config::default() };
    // the CPU module's doc and unit cases side by side, in one 6x3 image
    #[rustfmt::skip]
    let c = plane(6, 3, vec![
        WEAK_STRONG, 0, WEAK_WEAK, WEAK_WEAK, WEAK_WEAK, STRONG,
        0, WEAK_STRONG, 0, 0, 0, WEAK_STRONG,
        WEAK_WEAK, 0, WEAK, WEAK_STRONG, WEAK_WEAK, 0,
    ]);
    let b = mask_buffers(&ctx, &cfg, 6, 3).unwrap();
    poison(&ctx, &b.ruled, 9);
    t::upload_packed(&ctx, &b, &b.classes, 0, &c);
    t::run(&ctx, &pass, &b).unwrap();
    #[rustfmt::skip]
    let want = vec![
        STRONG, 0, NONE, NONE, NONE, STRONG,
        0, STRONG, 0, 0, 0, WEAK,
        WEAK, 0, WEAK, WEAK, WEAK, 0,
    ];
    assert_eq!(rules(&c).data, want);
    assert_eq!(t::download_ruled(&ctx, &b, 0).unwrap(), want.iter().map(|&v| v as u32).collect::<Vec<_>>());
}

#[test]
fn rules_match_cpu_on_random_classes() {
    let Some(ctx) = t::context() else { return };
    let pass = RulesPass::new(&ctx.device);
    let mut rng = XorRng::new(7);
    // every width mod 4 (a quad walk's last columns), quads narrower than six columns
    let sizes = [
        (37, 29, 3),
        (130, 75, 4),
        (17, 1, 1),
        (1, 1, 1),
        (1, 19, 2),
        (16, 16, 2),
        (64, 33, 5),
        (2, 7, 1),
        (3, 40, 1),
        (6, 18, 2),
        (71, 9, 1),
    ];
    for (w, h, levels) in sizes {
        let cfg = Config { n_levels: levels, ..Config::default() };
        let b = mask_buffers(&ctx, &cfg, w, h).unwrap();
        poison(&ctx, &b.ruled, 9);
        let planes: Vec<Plane<u8>> = b.layout.sizes.iter().map(|&(lw, lh)| random_classes(lw, lh, &mut rng)).collect();
        for (l, p) in planes.iter().enumerate() {
            t::upload_packed(&ctx, &b, &b.classes, l, p);
        }
        t::run(&ctx, &pass, &b).unwrap();
        let mut want_walks = Vec::new();
        for (l, p) in planes.iter().enumerate() {
            let r = rules(p);
            assert_eq!(t::download_ruled(&ctx, &b, l).unwrap(), to_u32(&r), "{w}x{h} level {l}");
            want_walks.extend(lfast::gpu::layout::walk_list(l as u32, r.width, r.height, &r.data));
        }
        want_walks.sort_unstable();
        assert_eq!(t::download_walks(&ctx, &b).unwrap(), want_walks, "{w}x{h} walk list");
    }
}

/// Rules then hysteresis on the classes the CPU computes for real images
/// (each CPU pyramid level): both GPU stages against `cpu::edge_map`.
#[test]
fn rules_and_hysteresis_match_cpu_on_real_images() {
    let Some(ctx) = t::context() else { return };
    let rp = RulesPass::new(&ctx.device);
    let hp = HysteresisPass::new(&ctx.device);
    let cfg = Config { n_levels: 3, ..Config::default() };
    for (name, img) in real_images() {
        let b = mask_buffers(&ctx, &cfg, img.width, img.height).unwrap();
        let levels = t::cpu_levels(&cfg, &img);
        let ems: Vec<_> = levels.iter().map(|p| edge_map(p, &cfg)).collect();
        for (l, em) in ems.iter().enumerate() {
            t::upload_packed(&ctx, &b, &b.classes, l, &em.classes);
        }
        t::run(&ctx, &rp, &b).unwrap();
        for (l, em) in ems.iter().enumerate() {
            assert_eq!(t::download_ruled(&ctx, &b, l).unwrap(), to_u32(&em.ruled), "{name} rules level {l}");
        }
        let ruled: Vec<Plane<u8>> = ems.iter().map(|em| em.ruled.clone()).collect();
        check_hysteresis(&ctx, &hp, &b, &ruled, &name);
        for (l, em) in ems.iter().enumerate() {
            assert_eq!(t::download_packed(&ctx, &b, &b.edges, l).unwrap(), to_u32(&em.edges), "{name} edges level {l}");
        }
        assert!(ems[0].edges.data.contains(&EDGE), "{name}: the test needs edges");
    }
}

// ---------------------------------------------------------------- hysteresis

#[test]
fn hysteresis_literal_case() {
    let Some(ctx) = t::context() else { return };
    let pass = HysteresisPass::new(&ctx.device);
    let cfg = Config { n_levels: 1, ..Config::default() };
    let b = mask_buffers(&ctx, &cfg, 5, 3).unwrap();
    // the doc example on row 0; a diagonal WEAK chain reaching STRONG on rows
    // 1-2; an isolated WEAK and an isolated STRONG
    #[rustfmt::skip]
    let c = plane(5, 3, vec![
        STRONG, WEAK, WEAK, NONE, WEAK,
        NONE, NONE, NONE, WEAK, NONE,
        WEAK, NONE, WEAK, NONE, STRONG,
    ]);
    check_hysteresis(&ctx, &pass, &b, std::slice::from_ref(&c), "literal");
    #[rustfmt::skip]
    let want = vec![
        255, 255, 255, 0, 255,
        0, 0, 0, 255, 0,
        0, 0, 255, 0, 255,
    ];
    assert_eq!(t::download_packed(&ctx, &b, &b.edges, 0).unwrap(), want);
}

#[test]
fn hysteresis_matches_cpu_on_random_planes() {
    let Some(ctx) = t::context() else { return };
    let pass = HysteresisPass::new(&ctx.device);
    let mut rng = XorRng::new(11);
    for (w, h, levels) in [(37, 29, 3), (130, 75, 4), (17, 1, 1), (1, 1, 1), (1, 40, 2), (200, 150, 3)] {
        let cfg = Config { n_levels: levels, ..Config::default() };
        let b = mask_buffers(&ctx, &cfg, w, h).unwrap();
        // from sparse to above the percolation threshold (one giant component)
        for (active, strong_in) in [(20, 10), (45, 40), (60, 300), (75, 2000), (100, 5000)] {
            let planes: Vec<Plane<u8>> =
                b.layout.sizes.iter().map(|&(lw, lh)| random_ruled(lw, lh, active, strong_in, &mut rng)).collect();
            check_hysteresis(&ctx, &pass, &b, &planes, &format!("{w}x{h} active {active}% strong 1/{strong_in}"));
        }
    }
}

/// Long contours that cross many 16x16 tiles, with the one STRONG pixel at the
/// far end: a propagation scheme with an iteration cap would stop part way.
#[test]
fn hysteresis_long_snakes_and_spirals() {
    let Some(ctx) = t::context() else { return };
    let pass = HysteresisPass::new(&ctx.device);

    // A 1-pixel-wide spiral covering a 128x128 image, seeded at its inner end
    // (8000+ pixels), and the same seeded at the outer end.
    let cfg = Config { n_levels: 1, ..Config::default() };
    let b = mask_buffers(&ctx, &cfg, 128, 128).unwrap();
    let (sp, path) = spiral(128, 128);
    assert!(path.len() > 8000, "{}", path.len());
    assert_eq!(sp.data.iter().filter(|&&v| v == WEAK).count(), path.len(), "the spiral never crosses itself");
    for end in [path[path.len() - 1], path[0]] {
        let mut c = sp.clone();
        c.data[(end.1 * 128 + end.0) as usize] = STRONG;
        check_hysteresis(&ctx, &pass, &b, std::slice::from_ref(&c), &format!("spiral seeded at {end:?}"));
        let e = t::download_packed(&ctx, &b, &b.edges, 0).unwrap();
        assert_eq!(e.iter().filter(|&&v| v == 255).count(), path.len(), "the whole spiral is one edge");
    }
    // unseeded: nothing
    check_hysteresis(&ctx, &pass, &b, std::slice::from_ref(&sp), "unseeded spiral");

    // A WEAK chain thousands long ending at one STRONG pixel: a serpentine on
    // level 0 (~15000 pixels), spirals on the other levels (seeded inside),
    // one of them cut in two so only the seeded half is edge.
    let cfg = Config { n_levels: 4, ..Config::default() };
    let b = mask_buffers(&ctx, &cfg, 200, 150).unwrap();
    let mut planes = Vec::new();
    for (l, &(w, h)) in b.layout.sizes.iter().enumerate() {
        let (mut p, path) = if l == 0 { snake(w, h) } else { spiral(w, h) };
        let last = *path.last().unwrap();
        p.data[(last.1 * w + last.0) as usize] = STRONG;
        if l == 2 {
            let cut = path[path.len() / 2];
            p.data[(cut.1 * w + cut.0) as usize] = NONE;
        }
        planes.push(p);
    }
    check_hysteresis(&ctx, &pass, &b, &planes, "snake and spirals");
    let e0 = t::download_packed(&ctx, &b, &b.edges, 0).unwrap();
    assert!(e0.iter().filter(|&&v| v == 255).count() > 14_000);

    // Two interleaved combs (one seeded, one not) whose teeth run across every
    // tile row: the components are long and never touch.
    let (w, h) = (150u32, 100u32);
    let cfg = Config { n_levels: 2, ..Config::default() };
    let b = mask_buffers(&ctx, &cfg, w, h).unwrap();
    let mut planes = Vec::new();
    for &(lw, lh) in &b.layout.sizes {
        let mut p = Plane::<u8>::new(lw, lh);
        for x in 0..lw {
            p.data[x as usize] = WEAK; // spine of comb A on row 0
            p.data[((lh - 1) * lw + x) as usize] = WEAK; // spine of comb B on the last row
        }
        // teeth of A on columns 4k, rows 1..=lh-3; of B on columns 4k+2, rows
        // 2..=lh-2: every gap is two pixels, so the combs never touch
        for x in (0..lw).step_by(4) {
            for y in 1..lh - 2 {
                p.data[(y * lw + x) as usize] = WEAK;
            }
        }
        for x in (2..lw).step_by(4) {
            for y in 2..lh - 1 {
                p.data[(y * lw + x) as usize] = WEAK;
            }
        }
        // seed comb B at the tip of its last tooth
        let tip = (2..lw).step_by(4).next_back().unwrap();
        p.data[(2 * lw + tip) as usize] = STRONG;
        planes.push(p);
    }
    check_hysteresis(&ctx, &pass, &b, &planes, "combs");
    let e0 = t::download_packed(&ctx, &b, &b.edges, 0).unwrap();
    assert_eq!(e0[0], 0, "comb A is not seeded");
    assert_eq!(e0[((h - 1) * w) as usize], 255, "comb B is");
}

mod prop {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]
        #[test]
        fn hysteresis_matches_cpu(w in 1u32..90, h in 1u32..70, levels in 1u32..4,
                                  active in 10u32..90, strong_in in 1u32..200, seed in any::<u64>()) {
            let Some(ctx) = t::context() else { return Ok(()) };
            let pass = HysteresisPass::new(&ctx.device);
            let cfg = Config { n_levels: levels, ..Config::default() };
            let b = mask_buffers(&ctx, &cfg, w, h).unwrap();
            let mut rng = XorRng::new(seed);
            let planes: Vec<Plane<u8>> =
                b.layout.sizes.iter().map(|&(lw, lh)| random_ruled(lw, lh, active, strong_in, &mut rng)).collect();
            check_hysteresis(&ctx, &pass, &b, &planes, "proptest");
        }
    }
}

// ---------------------------------------------------------------- lfast

/// Parameter sets: both modes, several support / straight_tol / border values.
fn lfast_configs() -> Vec<Config> {
    let mut out = Vec::new();
    for mode in [Mode::Branch, Mode::Paper] {
        for (support, straight_tol, border) in [(4, 1, 16), (4, 1, 7), (1, 0, 7), (3, 3, 9), (8, 7, 7), (6, 2, 12)] {
            out.push(Config { mode, support, straight_tol, border, ..Config::default() });
        }
    }
    out
}

#[test]
fn lfast_literal_l_corner() {
    let Some(ctx) = t::context() else { return };
    let pass = LfastPass::new(&ctx.device);
    // the CPU module's L: arms right and down from (15, 15) in a 31x31 map
    let mut e = Plane::<u8>::new(31, 31);
    for i in 0..12 {
        e.data[(15 * 31 + 15 + i) as usize] = EDGE;
        e.data[((15 + i) * 31 + 15) as usize] = EDGE;
    }
    for mode in [Mode::Paper, Mode::Branch] {
        // support 4 (SPEC 8's): the hand-computed answer is the corner alone
        let cfg = Config { mode, support: 4, border: 7, n_levels: 1, ..Config::default() };
        let b = mask_buffers(&ctx, &cfg, 31, 31).unwrap();
        let n = check_lfast(&ctx, &pass, &cfg, &b, std::slice::from_ref(&e), None, "L");
        assert_eq!(gpu_candidates(&ctx, &b, 0), vec![[15, 15]], "{mode:?}");
        assert_eq!(n, 1);
        // border 16 leaves no pixel of a 31x31 level
        let cfg = Config { border: 16, ..cfg };
        let b = mask_buffers(&ctx, &cfg, 31, 31).unwrap();
        assert_eq!(check_lfast(&ctx, &pass, &cfg, &b, std::slice::from_ref(&e), None, "L border 16"), 0);
    }
}

#[test]
fn lfast_matches_cpu_on_real_edge_maps() {
    let Some(ctx) = t::context() else { return };
    let pass = LfastPass::new(&ctx.device);
    let mut rng = XorRng::new(5);
    let imgs = real_images();
    let mut total = 0;
    for (name, img) in &imgs {
        // edges of each CPU pyramid level (levels too small for the border
        // have an edge map too: they must give no candidate)
        let lcfg = Config { n_levels: 4, ..Config::default() };
        let edges: Vec<Plane<u8>> = t::cpu_levels(&lcfg, img).iter().map(|p| edge_map(p, &lcfg).edges).collect();
        let masks: Vec<Plane<u8>> = edges.iter().map(|e| random_mask(e.width, e.height, &mut rng)).collect();
        for cfg in lfast_configs() {
            let cfg = Config { n_levels: 4, ..cfg };
            let b = mask_buffers(&ctx, &cfg, img.width, img.height).unwrap();
            total += check_lfast(&ctx, &pass, &cfg, &b, &edges, None, name);
            check_lfast(&ctx, &pass, &cfg, &b, &edges, Some(&masks), name);
        }
    }
    assert!(total > 100, "the real images give candidates ({total})");
}

#[test]
fn lfast_matches_cpu_on_random_edge_maps() {
    let Some(ctx) = t::context() else { return };
    let pass = LfastPass::new(&ctx.device);
    let mut rng = XorRng::new(99);
    let mut total = 0;
    for (w, h, levels) in [(37, 29, 3), (130, 75, 4), (17, 1, 1), (1, 1, 1), (15, 15, 1), (16, 40, 2), (64, 64, 3)] {
        for cfg in lfast_configs() {
            let cfg = Config { n_levels: levels, ..cfg };
            let b = mask_buffers(&ctx, &cfg, w, h).unwrap();
            let edges: Vec<Plane<u8>> = b.layout.sizes.iter().map(|&(lw, lh)| random_edges(lw, lh, &mut rng)).collect();
            let masks: Vec<Plane<u8>> = b.layout.sizes.iter().map(|&(lw, lh)| random_mask(lw, lh, &mut rng)).collect();
            total += check_lfast(&ctx, &pass, &cfg, &b, &edges, None, &format!("random {w}x{h}"));
            check_lfast(&ctx, &pass, &cfg, &b, &edges, Some(&masks), &format!("random {w}x{h}"));
        }
    }
    assert!(total > 100, "random maps give candidates ({total})");
}

/// Every 16-bit circle pattern around one centre pixel, with random
/// surroundings for Step 4: exercises branch splitting (wrap-around runs,
/// eight branches, all-16) in both modes.
#[test]
fn lfast_matches_cpu_on_every_circle_mask() {
    let Some(ctx) = t::context() else { return };
    let pass = LfastPass::new(&ctx.device);
    use lfast::cpu::lfast::CIRCLE;
    // 16 x 8 cells of 16x16 pixels per image, one pattern per cell, centre at
    // (8, 8) of the cell; 64 images cover 65536 patterns.
    let (cols, rows) = (16u32, 8u32);
    let (w, h) = (cols * 16, rows * 16);
    let mut rng = XorRng::new(3);
    for mode in [Mode::Branch, Mode::Paper] {
        let cfg = Config { mode, border: 7, n_levels: 1, support: 2 + rng.below(4), ..Config::default() };
        let b = mask_buffers(&ctx, &cfg, w, h).unwrap();
        for batch in 0..(65536 / (cols * rows)) {
            let mut e = Plane::<u8>::new(w, h);
            for v in e.data.iter_mut() {
                if rng.below(5) == 0 {
                    *v = EDGE;
                }
            }
            for cell in 0..cols * rows {
                let m = batch * cols * rows + cell;
                let (cx, cy) = ((cell % cols) * 16 + 8, (cell / cols) * 16 + 8);
                e.data[(cy * w + cx) as usize] = EDGE;
                for (i, (dx, dy)) in CIRCLE.iter().enumerate() {
                    let v = if m >> i & 1 == 1 { EDGE } else { 0 };
                    e.data[((cy as i32 + dy) as u32 * w + (cx as i32 + dx) as u32) as usize] = v;
                }
            }
            check_lfast(&ctx, &pass, &cfg, &b, std::slice::from_ref(&e), None, &format!("masks batch {batch}"));
        }
    }
}
