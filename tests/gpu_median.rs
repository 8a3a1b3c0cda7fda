//! GPU median (SPEC 1) against the CPU reference, bit for bit.
use lfast::Config;
use lfast::cpu::median;
use lfast::gpu::median::MedianPass;
use lfast::gpu::{Buffers, Pass};
use lfast::testing as t;

#[test]
fn median_matches_cpu_on_every_level() {
    let Some(ctx) = t::context() else { return };
    let pass = MedianPass::new(&ctx.device);
    // widths of every remainder mod 4 (a quad walk's last columns) and below
    // the six columns of a quad (2, 3), heights across words and tiles
    let sizes = [
        (37, 29, 3, 1),
        (64, 48, 2, 2),
        (1, 1, 1, 3),
        (17, 1, 1, 4),
        (130, 75, 4, 5),
        (2, 35, 1, 6),
        (3, 17, 1, 7),
        (71, 6, 1, 8),
    ];
    for (w, h, levels, seed) in sizes {
        let cfg = Config { n_levels: levels, ..Config::default() };
        let img = t::test_image(w, h, seed);
        let b = Buffers::new(&ctx.device, &cfg, w, h).unwrap();
        let lv = t::upload_pyramid(&ctx, &cfg, &b, &img);
        t::run(&ctx, &pass, &b).unwrap();
        for (l, p) in lv.iter().enumerate() {
            let want: Vec<u32> = median::median(p, cfg.delta_num(), 10_000).data.iter().map(|&v| v as u32).collect();
            assert_eq!(t::download_packed(&ctx, &b, &b.denoised, l).unwrap(), want, "{w}x{h} level {l}");
        }
    }
}
