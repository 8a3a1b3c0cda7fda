//! Per-stage CPU timings on one image: `cargo run --release --example stage_times -- IMAGE [REPEATS]`.
use ::lfast::cpu::{self as cpu, *};
use ::lfast::{Config, config::DELTA_DEN};
use std::time::Instant;

fn main() -> ::lfast::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let img = ::lfast::image::load_gray(&args[1])?;
    let reps: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(50);
    let cfg = Config::default();
    let mut t = std::collections::BTreeMap::<&str, f64>::new();
    let mut time = |name: &'static str, f: &mut dyn FnMut()| {
        let mut best = f64::MAX;
        for _ in 0..reps {
            let s = Instant::now();
            f();
            best = best.min(s.elapsed().as_secs_f64() * 1e3);
        }
        t.insert(name, best);
    };
    let d = median::median(&img, cfg.delta_num(), DELTA_DEN);
    let g = gradient::gradient(&d);
    let k = nms::nms(&g);
    let hist = histogram::histogram(&g.m);
    let grid = local_threshold::local_threshold(&g.m);
    let c = classify::classify(&g.m, &k, otsu::otsu(&hist).map(|k| k as u32 + 1), &grid, 35);
    let r = rules::rules(&c);
    let e = hysteresis::hysteresis(&r);
    let p = cpu::lfast::LfastParams::from_config(&cfg);
    time("1 median", &mut || {
        std::hint::black_box(median::median(&img, 1000, DELTA_DEN));
    });
    time("2 gradient", &mut || {
        std::hint::black_box(gradient::gradient(&d));
    });
    time("3 nms", &mut || {
        std::hint::black_box(nms::nms(&g));
    });
    time("4 histogram", &mut || {
        std::hint::black_box(histogram::histogram(&g.m));
    });
    time("5 local_threshold", &mut || {
        std::hint::black_box(local_threshold::local_threshold(&g.m));
    });
    time("6 classify", &mut || {
        std::hint::black_box(classify::classify(&g.m, &k, Some(20), &grid, 35));
    });
    time("7a rules", &mut || {
        std::hint::black_box(rules::rules(&c));
    });
    time("7b hysteresis", &mut || {
        std::hint::black_box(hysteresis::hysteresis(&r));
    });
    time("8 lfast", &mut || {
        std::hint::black_box(cpu::lfast::lfast(&e, None, &p));
    });
    time("fused edges", &mut || {
        std::hint::black_box(fused::edges_fused(&img, 1000, DELTA_DEN, 35));
    });
    time("edge_map total", &mut || {
        std::hint::black_box(edge_map(&img, &cfg));
    });
    let sizes = cfg.level_sizes(img.width, img.height);
    time("pyramid", &mut || {
        std::hint::black_box(pyramid::pyramid(&img, &sizes));
    });
    let det = CpuDetector::new(cfg.clone())?;
    time("detect", &mut || {
        std::hint::black_box(det.detect(img.view(), None).unwrap());
    });
    time("detect_and_compute", &mut || {
        std::hint::black_box(det.detect_and_compute(img.view(), None).unwrap());
    });
    for (k, v) in &t {
        println!("{k:20} {v:8.3} ms");
    }
    Ok(())
}
