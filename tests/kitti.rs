//! Keypoint counts on KITTI odometry sequence 01, frames 0-50 (image_0):
//! L-FAST Branch (default config), L-FAST Paper and FAST-9 (threshold 20, NMS).
//! L-FAST counts are over its 8-level pyramid, FAST-9's are at full resolution
//! only, so the table also gives Branch on level 0 alone (`n_levels = 1`).
//! Needs ../shared/data (skips with a message without it, fails in CI).
//!
//! Print the table with `cargo test --release --test kitti -- --nocapture`.

mod common;

use lfast::baseline::fast::fast9;
use lfast::cpu::CpuDetector;
use lfast::{Config, Mode};

const DIR: &str = "kitti/seq01_000000-000050/image_0";
const FRAMES: usize = 51;

#[derive(Clone, Copy, Debug)]
struct Row {
    branch: usize,
    branch_l0: usize,
    paper: usize,
    fast: usize,
}

fn mean(rows: &[Row], f: impl Fn(&Row) -> usize) -> f64 {
    rows.iter().map(|r| f(r) as f64).sum::<f64>() / rows.len() as f64
}

#[test]
fn keypoint_counts_on_seq01() {
    let Some(dir) = common::shared(DIR) else { return };
    // SPEC 8's two modes with the paper's support 4 and no snap (the counts SPEC quotes)
    let spec_branch = Config { mode: Mode::Branch, ..Config::paper() };
    let branch = CpuDetector::new(spec_branch.clone()).unwrap();
    let paper = CpuDetector::new(Config::paper()).unwrap();
    let branch_l0 = CpuDetector::new(Config { n_levels: 1, ..spec_branch }).unwrap();

    let mut rows = Vec::with_capacity(FRAMES);
    eprintln!("KITTI seq01 {DIR}: keypoints per frame");
    eprintln!("{:>6} {:>9} {:>9} {:>9} {:>9}", "frame", "branch", "paper", "fast9", "branch-L0");
    for i in 0..FRAMES {
        let path = dir.join(format!("{i:06}.png"));
        let img = lfast::image::load_gray(&path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!((img.width, img.height), (1241, 376), "{}", path.display());
        let (kb, db) = branch.detect_and_compute(img.view(), None).unwrap();
        assert_eq!(kb.len(), db.len());
        let kp = paper.detect(img.view(), None).unwrap();
        let row = Row {
            branch: kb.len(),
            branch_l0: branch_l0.detect(img.view(), None).unwrap().len(),
            paper: kp.len(),
            fast: fast9(&img, 20, true).len(),
        };
        eprintln!("{i:>6} {:>9} {:>9} {:>9} {:>9}", row.branch, row.paper, row.fast, row.branch_l0);
        rows.push(row);
    }
    let (mb, mp, mf) = (mean(&rows, |r| r.branch), mean(&rows, |r| r.paper), mean(&rows, |r| r.fast));
    let ml0 = mean(&rows, |r| r.branch_l0);
    eprintln!("{:>6} {mb:>9.1} {mp:>9.1} {mf:>9.1} {ml0:>9.1}", "mean");
    let min = |f: fn(&Row) -> usize| rows.iter().map(f).min().unwrap();
    let max = |f: fn(&Row) -> usize| rows.iter().map(f).max().unwrap();
    let (b, p, f, l) = (|r: &Row| r.branch, |r: &Row| r.paper, |r: &Row| r.fast, |r: &Row| r.branch_l0);
    eprintln!("{:>6} {:>9} {:>9} {:>9} {:>9}", "min", min(b), min(p), min(f), min(l));
    eprintln!("{:>6} {:>9} {:>9} {:>9} {:>9}", "max", max(b), max(p), max(f), max(l));

    // FAST-9 on frames 0 and 20 is pinned by tests/fast_opencv.rs (OpenCV's counts)
    assert_eq!(rows[0].fast, 3716);
    assert_eq!(rows[20].fast, 1885);
    // SPEC 9: Branch, corner NMS r = 3, level 0 of frame 20
    assert_eq!(rows[20].branch_l0, 369);

    for (i, r) in rows.iter().enumerate() {
        assert!(r.branch > 0 && r.paper > 0 && r.fast > 0, "frame {i}: {r:?}");
        // Branch judges straightness on whole branches, so it never finds more
        // corners than the literal Paper mode on these frames
        assert!(r.branch <= r.paper, "frame {i}: {r:?}");
        assert!(r.branch_l0 > 0 && r.branch_l0 < r.branch, "frame {i}: {r:?}");
    }
    // L-FAST is the sparser detector: fewer points than FAST-9 on average and
    // on every frame (SPEC 8/9: frame 20 gives 369 Branch corners at level 0
    // against FAST-9's 1885 at full resolution)
    assert!(mb < mf, "mean Branch {mb} >= mean FAST-9 {mf}");
    assert!(rows.iter().all(|r| r.branch < r.fast), "{rows:?}");
    assert!(ml0 * 3.0 < mf, "level-0 Branch {ml0} vs FAST-9 {mf}");
    assert!(mb < mp, "mean Branch {mb} >= mean Paper {mp}");
    // loose bounds around the measured means, to catch a gross regression
    assert!((300.0..3000.0).contains(&mb), "mean Branch {mb}");
    assert!((mb..6000.0).contains(&mp), "mean Paper {mp}");
}
