//! Suite 3 (paper Figs 9-10): for every frame of a KITTI-format folder, the
//! keypoint count and extraction time of FAST-9, ORB and the L-FAST variants,
//! and the time of the edge maps alone.

use super::format::{Csv, csv_f, num, table};
use super::output::{load_average, machine, write_section};
use super::plot::{Panel, Series, figure};
use super::{Detectors, LFAST_L0, Options, Result, Suite, Variant, colour_of, kitti_frames, label, mean, median, stem};
use crate::config::Config;
use crate::cpu::CpuDetector;
use crate::image::Plane;
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// The paper's published means on KITTI (Figs 9-10): feature points per frame
/// and extraction time per frame of FAST and L-FAST.
pub mod paper {
    /// FAST points per frame.
    pub const FAST_POINTS: f64 = 1763.0;
    /// L-FAST points per frame.
    pub const LFAST_POINTS: f64 = 205.0;
    /// FAST extraction time per frame, ms.
    pub const FAST_MS: f64 = 15.0;
    /// L-FAST extraction time per frame, ms.
    pub const LFAST_MS: f64 = 3.0;
}

/// Means of one detector on the KITTI frames.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct KittiMean {
    /// Stable key (`fast9`, `orb`, `lfast-branch-s4`, ...).
    pub key: String,
    /// Keypoints per frame.
    pub keypoints: f64,
    /// Keypoint detection per frame, ms (median of the repeats, then mean over frames).
    pub detect_ms: f64,
    /// Detection and descriptors per frame, ms.
    pub total_ms: f64,
}

/// What the KITTI suite leaves for the report.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct KittiSummary {
    /// The frames' folder.
    pub folder: String,
    /// Frames evaluated.
    pub frames: usize,
    /// Where it ran.
    pub machine: String,
    /// Per detector.
    pub means: Vec<KittiMean>,
    /// Improved Canny edge map (level 0), ms per frame.
    pub edge_ms: f64,
    /// Traditional Canny, ms per frame.
    pub canny_ms: f64,
}

/// Frames of a quick run.
pub const QUICK_FRAMES: usize = 3;

/// Runs `f` `repeats` times; its first result and the median time in ms.
fn timed<T>(repeats: usize, mut f: impl FnMut() -> Result<T>) -> Result<(T, f64)> {
    let mut times = Vec::with_capacity(repeats);
    let mut first = None;
    for _ in 0..repeats.max(1) {
        let t = Instant::now();
        let r = f()?;
        times.push(t.elapsed().as_secs_f64() * 1e3);
        first.get_or_insert(r);
    }
    let r = first.ok_or_else(|| super::EvalError::Mismatch("no timing run".into()))?;
    Ok((r, median(&mut times)))
}

/// One detector on one frame.
#[derive(Clone, Debug)]
struct Measure {
    key: String,
    keypoints: usize,
    detect_ms: f64,
    total_ms: f64,
}

struct Frame {
    name: String,
    detectors: Vec<Measure>,
    edge_ms: f64,
    canny_ms: f64,
    edge_pixels: usize,
    canny_pixels: usize,
}

/// Every detector on one frame.
fn measure(img: &Plane<u8>, det: &Detectors, l0: &CpuDetector, repeats: usize) -> Result<Vec<Measure>> {
    let v = img.view();
    let mut out = Vec::new();
    let (kps, detect_ms) = timed(repeats, || Ok(crate::baseline::fast::fast9(img, super::FAST_THRESHOLD, true)))?;
    let (_, total_ms) = timed(repeats, || det.fast9_described(img))?;
    out.push(Measure { key: "fast9".into(), keypoints: kps.len(), detect_ms, total_ms });
    let ((kps, _), ms) = timed(repeats, || Ok(det.orb.detect_and_compute(v)?))?;
    out.push(Measure { key: "orb".into(), keypoints: kps.len(), detect_ms: ms, total_ms: ms });
    let ((kps, _), ms) = timed(repeats, || Ok(det.orbslam.detect_and_compute(v)?))?;
    out.push(Measure { key: "orbslam".into(), keypoints: kps.len(), detect_ms: ms, total_ms: ms });
    let lfast = det.lfast.iter().map(|(var, d)| (var.key(), d)).chain(std::iter::once((LFAST_L0.to_string(), l0)));
    for (key, d) in lfast {
        let (kps, detect_ms) = timed(repeats, || Ok(d.detect(v, None)?))?;
        let (_, total_ms) = timed(repeats, || Ok(d.detect_and_compute(v, None)?))?;
        out.push(Measure { key, keypoints: kps.len(), detect_ms, total_ms });
    }
    Ok(out)
}

/// Runs the suite: `kitti.csv` (per frame and detector), `kitti_edges.csv`,
/// `kitti_counts.png`, `kitti_times.png`, the section.
pub fn run(opts: &Options) -> Result<()> {
    let mut files = kitti_frames(&opts.kitti)?;
    if opts.quick {
        files.truncate(QUICK_FRAMES);
    }
    let det = Detectors::new()?;
    let l0 = CpuDetector::new(Config { n_levels: 1, ..Config::default() })?;
    let edges = CpuDetector::new(Config::default())?;
    let repeats = opts.timing_repeats();
    let load = load_average();
    let mut frames = Vec::with_capacity(files.len());
    for (i, path) in files.iter().enumerate() {
        let img = crate::image::load_gray(path)?;
        if i == 0 {
            // warm-up: page in the code and fill the detectors' buffer pools
            measure(&img, &det, &l0, 1)?;
        }
        let detectors = measure(&img, &det, &l0, repeats)?;
        let (e, edge_ms) = timed(repeats, || Ok(edges.edge_image(img.view())?))?;
        let (c, canny_ms) = timed(repeats, || Ok(super::continuity::traditional(&img)))?;
        frames.push(Frame {
            name: stem(path),
            detectors,
            edge_ms,
            canny_ms,
            edge_pixels: e.data.iter().filter(|&&v| v != 0).count(),
            canny_pixels: c.data.iter().filter(|&&v| v != 0).count(),
        });
    }
    let keys: Vec<String> =
        frames.first().map(|f| f.detectors.iter().map(|m| m.key.clone()).collect()).unwrap_or_default();

    let mut csv = Csv::new(&["frame", "detector", "keypoints", "detect_ms", "detect_and_describe_ms"]);
    let mut ecsv =
        Csv::new(&["frame", "improved_canny_ms", "canny_ms", "improved_canny_edge_pixels", "canny_edge_pixels"]);
    for f in &frames {
        for m in &f.detectors {
            csv.row(vec![
                f.name.clone(),
                m.key.clone(),
                m.keypoints.to_string(),
                csv_f(m.detect_ms),
                csv_f(m.total_ms),
            ]);
        }
        ecsv.row(vec![
            f.name.clone(),
            csv_f(f.edge_ms),
            csv_f(f.canny_ms),
            f.edge_pixels.to_string(),
            f.canny_pixels.to_string(),
        ]);
    }
    csv.write(&opts.out.join("kitti.csv"))?;
    ecsv.write(&opts.out.join("kitti_edges.csv"))?;

    let per_frame = |key: &str, f: fn(&Measure) -> f64| -> Vec<(f64, f64)> {
        frames
            .iter()
            .enumerate()
            .filter_map(|(i, fr)| fr.detectors.iter().find(|m| m.key == key).map(|m| (i as f64, f(m))))
            .collect()
    };
    let series = |f: fn(&Measure) -> f64| -> Vec<Series> {
        keys.iter().map(|k| Series { name: label(k), colour: colour_of(k), points: per_frame(k, f) }).collect()
    };
    figure(
        &opts.out.join("kitti_counts.png"),
        (1100, 520),
        (1, 1),
        &[Panel::Line {
            title: "Keypoints per frame (paper Fig 9)".into(),
            x_desc: "frame".into(),
            y_desc: "keypoints".into(),
            series: series(|m| m.keypoints as f64),
        }],
    )?;
    let mut detect = series(|m| m.detect_ms);
    detect.push(Series {
        name: "improved Canny edge map".into(),
        colour: 7,
        points: frames.iter().enumerate().map(|(i, f)| (i as f64, f.edge_ms)).collect(),
    });
    detect.push(Series {
        name: "traditional Canny".into(),
        colour: 5,
        points: frames.iter().enumerate().map(|(i, f)| (i as f64, f.canny_ms)).collect(),
    });
    figure(
        &opts.out.join("kitti_times.png"),
        (1100, 1000),
        (2, 1),
        &[
            Panel::Line {
                title: "Detection time per frame (paper Fig 10; ORB includes descriptors)".into(),
                x_desc: "frame".into(),
                y_desc: "ms".into(),
                series: detect,
            },
            Panel::Line {
                title: "Detection + descriptors per frame".into(),
                x_desc: "frame".into(),
                y_desc: "ms".into(),
                series: series(|m| m.total_ms),
            },
        ],
    )?;

    let means: Vec<KittiMean> = keys
        .iter()
        .map(|k| {
            let ms: Vec<&Measure> = frames.iter().filter_map(|f| f.detectors.iter().find(|m| &m.key == k)).collect();
            KittiMean {
                key: k.clone(),
                keypoints: mean(ms.iter().map(|m| m.keypoints as f64)),
                detect_ms: mean(ms.iter().map(|m| m.detect_ms)),
                total_ms: mean(ms.iter().map(|m| m.total_ms)),
            }
        })
        .collect();
    let edge_ms = mean(frames.iter().map(|f| f.edge_ms));
    let canny_ms = mean(frames.iter().map(|f| f.canny_ms));
    let size = files
        .first()
        .map(crate::image::load_gray)
        .transpose()?
        .map(|p| format!("{}x{}", p.width, p.height))
        .unwrap_or_default();
    let current = Variant::current().key();
    let trow: Vec<Vec<String>> = means
        .iter()
        .map(|m| {
            let paper_pts = match m.key.as_str() {
                "fast9" => paper::FAST_POINTS.to_string(),
                k if k == current || k == LFAST_L0 => paper::LFAST_POINTS.to_string(),
                _ => String::new(),
            };
            let paper_ms = match m.key.as_str() {
                "fast9" => paper::FAST_MS.to_string(),
                k if k == current || k == LFAST_L0 => paper::LFAST_MS.to_string(),
                _ => String::new(),
            };
            vec![label(&m.key), num(m.keypoints, 1), paper_pts, num(m.detect_ms, 2), num(m.total_ms, 2), paper_ms]
        })
        .collect();
    let machine = machine();
    let md = format!(
        "## 3. KITTI: keypoints and time per frame (paper Figs 9-10)\n\n\
         {} frame(s) ({size}) of `{}`. Times: median of {repeats} run(s) per frame, mean over frames, measured \
         with `std::time::Instant` on {machine}, CPU path{}. \"detect\" = keypoints with orientation (FAST-9: \
         `fast9` alone; ORB has no detection-only entry point, so both its columns include descriptors). \
         L-FAST runs on the 8-level pyramid; \"level 0\" is the default L-FAST on the full-resolution image \
         only, like FAST-9. Files: `kitti.csv`, `kitti_edges.csv`, `kitti_counts.png`, `kitti_times.png`.\n\n{}\n\
         Edge maps alone: improved Canny (level 0) {} ms/frame, traditional Canny {} ms/frame.\n\n\
         Paper (Figs 9-10, means over its KITTI frames): FAST {} points and {} ms per frame, L-FAST {} points \
         and {} ms per frame (its machine and code, not comparable in absolute time). Here FAST-9 finds {} and \
         {} (the current default) {} points per frame: a ratio of {} (paper {}); on level 0 alone L-FAST finds {}.\n\n\
         ![counts](kitti_counts.png)\n\n![times](kitti_times.png)\n",
        frames.len(),
        opts.kitti.display(),
        load.map_or(String::new(), |l| format!(
            "; the 1-minute load average was {l:.1} when the suite started (other processes shared the machine, \
             so times are upper bounds)"
        )),
        table(&["detector", "keypoints/frame", "paper", "detect ms", "detect + describe ms", "paper ms"], &trow),
        num(edge_ms, 2),
        num(canny_ms, 2),
        paper::FAST_POINTS,
        paper::FAST_MS,
        paper::LFAST_POINTS,
        paper::LFAST_MS,
        num(means.iter().find(|m| m.key == "fast9").map_or(f64::NAN, |m| m.keypoints), 0),
        label(&current),
        num(means.iter().find(|m| m.key == current).map_or(f64::NAN, |m| m.keypoints), 0),
        num(
            means.iter().find(|m| m.key == "fast9").map_or(f64::NAN, |m| m.keypoints)
                / means.iter().find(|m| m.key == current).map_or(f64::NAN, |m| m.keypoints),
            1
        ),
        num(paper::FAST_POINTS / paper::LFAST_POINTS, 1),
        num(means.iter().find(|m| m.key == LFAST_L0).map_or(f64::NAN, |m| m.keypoints), 0),
    );
    let summary = KittiSummary {
        folder: opts.kitti.display().to_string(),
        frames: frames.len(),
        machine,
        means,
        edge_ms,
        canny_ms,
    };
    write_section(&opts.out, Suite::Kitti, &md, &summary)
}
