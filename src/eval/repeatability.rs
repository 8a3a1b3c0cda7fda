//! Suite 4 (beyond the paper): repeatability and matching score on
//! Oxford-format scenes (Mikolajczyk et al. 2005): image 1 against images
//! 2..N through the given homographies, for L-FAST, FAST-9 and ORB, with
//! every keypoint and at equal budgets: each detector with its own cap of N
//! (L-FAST `n_features = N`, SPEC 9's per-level quotas; ORB and ORB-SLAM
//! `nfeatures = N`), FAST-9, which has no cap, by its top N scores.

use super::format::{Csv, csv_f, pct, table};
use super::metrics::{PairScore, read_homography, score_pair};
use super::output::write_section;
use super::plot::{Panel, Series, figure};
use super::{Detectors, EvalError, Options, Result, Suite, colour_of, image_files, label, mean, stem};
use crate::config::Config;
use crate::cpu::CpuDetector;
use crate::image::Plane;
use crate::keypoint::{Descriptor, KeyPoint};
use nalgebra::Matrix3;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Mean repeatability and matching score of one detector at one budget.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RepeatMean {
    /// Detector key.
    pub key: String,
    /// Top-N budget, `None` = every keypoint.
    pub budget: Option<u32>,
    /// Mean over every pair of every scene.
    pub repeatability: f64,
    /// Mean over every pair of every scene.
    pub matching_score: f64,
    /// Mean keypoints in image 1 of the pairs.
    pub keypoints: f64,
}

/// What the repeatability suite leaves for the report.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RepeatSummary {
    /// Scene names.
    pub scenes: Vec<String>,
    /// Pairs per scene.
    pub pairs: usize,
    /// Budgets evaluated besides "all".
    pub budgets: Vec<u32>,
    /// Per detector and budget.
    pub means: Vec<RepeatMean>,
}

/// Tolerance of a correspondence, pixels (in image n).
pub const EPS: f64 = 2.5;
/// The equal budgets: each detector capped at N by its own rule (FAST-9, single-scale and
/// uncapped, by its top N scores).
pub const BUDGETS: [u32; 2] = [500, 1000];

/// One Oxford-format scene: `img1..imgN` and `H1to2p..H1toNp`.
#[derive(Clone, Debug)]
pub struct Scene {
    /// Folder name.
    pub name: String,
    /// Image 1.
    pub reference: PathBuf,
    /// (n, image n, H from image 1 to image n) for n = 2.., sorted.
    pub pairs: Vec<(u32, PathBuf, Matrix3<f64>)>,
}

/// `img<k>.<ext>` in `dir`, any image extension.
fn numbered_image(files: &[PathBuf], k: u32) -> Option<PathBuf> {
    files.iter().find(|p| stem(p) == format!("img{k}")).cloned()
}

/// The scene in `dir` (`None` when it has no `img1`).
pub fn scene(dir: &Path) -> Result<Option<Scene>> {
    let Ok(files) = image_files(dir) else { return Ok(None) };
    let Some(reference) = numbered_image(&files, 1) else { return Ok(None) };
    let mut pairs = Vec::new();
    for k in 2..=99 {
        let (img, h) = (numbered_image(&files, k), dir.join(format!("H1to{k}p")));
        match (img, h.is_file()) {
            (Some(img), true) => pairs.push((k, img, read_homography(&h)?)),
            (Some(_), false) => {
                return Err(EvalError::Data { path: h, reason: format!("img{k} has no homography file") });
            }
            (None, _) => break,
        }
    }
    if pairs.is_empty() {
        return Err(EvalError::Data { path: dir.to_path_buf(), reason: "img1 but no img2 + H1to2p".into() });
    }
    Ok(Some(Scene {
        name: dir.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(),
        reference,
        pairs,
    }))
}

/// The scenes of `dir`: the folder itself, or its sub-folders (sorted) that are scenes.
pub fn scenes(dir: &Path) -> Result<Vec<Scene>> {
    if let Some(s) = scene(dir)? {
        return Ok(vec![s]);
    }
    let rd = std::fs::read_dir(dir).map_err(|e| EvalError::Data { path: dir.to_path_buf(), reason: e.to_string() })?;
    let mut subs: Vec<PathBuf> = rd.filter_map(|e| e.ok().map(|e| e.path())).filter(|p| p.is_dir()).collect();
    subs.sort();
    let mut out = Vec::new();
    for s in subs {
        if let Some(sc) = scene(&s)? {
            out.push(sc);
        }
    }
    if out.is_empty() {
        return Err(EvalError::Data {
            path: dir.to_path_buf(),
            reason: "no scene (a folder with img1..imgN and H1to2p..)".into(),
        });
    }
    Ok(out)
}

/// Keypoints and descriptors of one detector at one budget.
#[derive(Clone, Debug, Default)]
struct Features {
    points: Vec<[f64; 2]>,
    desc: Vec<Descriptor>,
}

fn features(kps: &[KeyPoint], desc: &[Descriptor], n: usize) -> Features {
    Features {
        points: kps.iter().take(n).map(|k| [k.pt.x as f64, k.pt.y as f64]).collect(),
        desc: desc.iter().take(n).copied().collect(),
    }
}

/// (detector key, budget) → features of one image.
type ImageFeatures = BTreeMap<(String, Option<u32>), Features>;

/// The L-FAST variants capped at each of [`BUDGETS`]: `capped[i][j]` is
/// `Detectors::lfast[i]` with `n_features = BUDGETS[j]`.
fn capped_lfast(det: &Detectors) -> Result<Vec<Vec<CpuDetector>>> {
    det.lfast
        .iter()
        .map(|(v, _)| BUDGETS.iter().map(|&b| Ok(CpuDetector::new(Config { n_features: b, ..v.config() })?)).collect())
        .collect()
}

fn detect_all(img: &Plane<u8>, det: &Detectors, capped: &[Vec<CpuDetector>]) -> Result<ImageFeatures> {
    let mut out = ImageFeatures::new();
    // L-FAST: every keypoint, and its own cap of N (SPEC 9's per-level quotas),
    // as a user with a budget runs it and as ORB and ORB-SLAM run below
    for ((v, d), caps) in det.lfast.iter().zip(capped) {
        let (k, desc) = d.detect_and_compute(img.view(), None)?;
        out.insert((v.key(), None), features(&k, &desc, usize::MAX));
        for (&b, d) in BUDGETS.iter().zip(caps) {
            let (k, desc) = d.detect_and_compute(img.view(), None)?;
            out.insert((v.key(), Some(b)), features(&k, &desc, usize::MAX));
        }
    }
    // FAST-9 has no cap: its top N scores (strongest first)
    let (k, desc) = det.fast9_described(img)?;
    out.insert(("fast9".into(), None), features(&k, &desc, usize::MAX));
    for b in BUDGETS {
        out.insert(("fast9".into(), Some(b)), features(&k, &desc, b as usize));
    }
    // ORB always has a budget: cv2.ORB_create()'s 500 for "all", N for budget N
    let (k, desc) = det.orb.detect_and_compute(img.view())?;
    out.insert(("orb".into(), None), features(&k, &desc, usize::MAX));
    for b in BUDGETS {
        let (k, desc) = Detectors::orb_with(b)?.detect_and_compute(img.view())?;
        out.insert(("orb".into(), Some(b)), features(&k, &desc, usize::MAX));
        let (k, desc) = Detectors::orbslam_with(b)?.detect_and_compute(img.view())?;
        out.insert(("orbslam".into(), Some(b)), features(&k, &desc, usize::MAX));
    }
    let (k, desc) = det.orbslam.detect_and_compute(img.view())?;
    out.insert(("orbslam".into(), None), features(&k, &desc, usize::MAX));
    Ok(out)
}

/// One scored pair.
#[derive(Clone, Debug)]
struct Row {
    scene: String,
    n: u32,
    key: String,
    budget: Option<u32>,
    score: PairScore,
}

fn budget_name(b: Option<u32>) -> String {
    b.map_or("all".into(), |b| b.to_string())
}

/// Runs the suite: `repeatability.csv`, `repeatability_<scene>.png`, the section.
pub fn run(opts: &Options) -> Result<()> {
    let mut scenes = scenes(&opts.homography)?;
    if opts.quick {
        scenes.iter_mut().for_each(|s| s.pairs.truncate(1));
    }
    let det = Detectors::new()?;
    let capped = capped_lfast(&det)?;
    let mut rows = Vec::new();
    let mut keys: Vec<String> = det.lfast.iter().map(|(v, _)| v.key()).collect();
    keys.extend(["fast9".to_string(), "orb".to_string(), "orbslam".to_string()]);
    for sc in &scenes {
        let img1 = crate::image::load_gray(&sc.reference)?;
        let f1 = detect_all(&img1, &det, &capped)?;
        for (n, path, h) in &sc.pairs {
            let img2 = crate::image::load_gray(path)?;
            let f2 = detect_all(&img2, &det, &capped)?;
            for ((key, budget), a) in &f1 {
                let b = &f2[&(key.clone(), *budget)];
                let score = score_pair(
                    &a.points,
                    &a.desc,
                    (img1.width, img1.height),
                    &b.points,
                    &b.desc,
                    (img2.width, img2.height),
                    h,
                    EPS,
                )?;
                rows.push(Row { scene: sc.name.clone(), n: *n, key: key.clone(), budget: *budget, score });
            }
        }
    }

    let mut csv = Csv::new(&[
        "scene",
        "pair",
        "detector",
        "budget",
        "n1",
        "n2",
        "n1_common",
        "n2_common",
        "correspondences",
        "repeatability",
        "correct_matches",
        "matching_score",
    ]);
    for r in &rows {
        let s = &r.score;
        csv.row(vec![
            r.scene.clone(),
            format!("1-{}", r.n),
            r.key.clone(),
            budget_name(r.budget),
            s.n1.to_string(),
            s.n2.to_string(),
            s.n1_common.to_string(),
            s.n2_common.to_string(),
            s.correspondences.to_string(),
            csv_f(s.repeatability),
            s.correct_matches.to_string(),
            csv_f(s.matching_score),
        ]);
    }
    csv.write(&opts.out.join("repeatability.csv"))?;

    let budgets: Vec<Option<u32>> = std::iter::once(None).chain(BUDGETS.iter().map(|&b| Some(b))).collect();
    let select = |scene: Option<&str>, key: &str, budget: Option<u32>| -> Vec<&Row> {
        rows.iter().filter(|r| scene.is_none_or(|s| r.scene == s) && r.key == key && r.budget == budget).collect()
    };
    for sc in &scenes {
        let panel = |title: String, budget: Option<u32>, f: fn(&PairScore) -> f64| Panel::Line {
            title,
            x_desc: "image n (pair 1-n)".into(),
            y_desc: "%".into(),
            series: keys
                .iter()
                .map(|k| Series {
                    name: label(k),
                    colour: colour_of(k),
                    points: select(Some(&sc.name), k, budget)
                        .iter()
                        .map(|r| (r.n as f64, 100.0 * f(&r.score)))
                        .collect(),
                })
                .collect(),
        };
        let b = BUDGETS[0];
        figure(
            &opts.out.join(format!("repeatability_{}.png", sc.name)),
            (1200, 900),
            (2, 2),
            &[
                panel(format!("{}: repeatability, every keypoint", sc.name), None, |s| s.repeatability),
                panel(format!("{}: matching score, every keypoint", sc.name), None, |s| s.matching_score),
                panel(format!("{}: repeatability, top {b}", sc.name), Some(b), |s| s.repeatability),
                panel(format!("{}: matching score, top {b}", sc.name), Some(b), |s| s.matching_score),
            ],
        )?;
    }

    let means: Vec<RepeatMean> = budgets
        .iter()
        .flat_map(|&b| keys.iter().map(move |k| (k, b)))
        .map(|(k, b)| {
            let rs = select(None, k, b);
            RepeatMean {
                key: k.clone(),
                budget: b,
                repeatability: mean(rs.iter().map(|r| r.score.repeatability)),
                matching_score: mean(rs.iter().map(|r| r.score.matching_score)),
                keypoints: mean(rs.iter().map(|r| r.score.n1 as f64)),
            }
        })
        .collect();
    let mut header: Vec<String> = vec!["detector".into(), "budget".into(), "keypoints (img1)".into()];
    for sc in &scenes {
        header.push(format!("{} rep / MS", sc.name));
    }
    header.extend(["mean repeatability".into(), "mean matching score".into()]);
    let trow: Vec<Vec<String>> = means
        .iter()
        .map(|m| {
            let mut r = vec![label(&m.key), budget_name(m.budget), format!("{:.0}", m.keypoints)];
            for sc in &scenes {
                let rs = select(Some(&sc.name), &m.key, m.budget);
                r.push(format!(
                    "{} / {}",
                    pct(mean(rs.iter().map(|r| r.score.repeatability))),
                    pct(mean(rs.iter().map(|r| r.score.matching_score)))
                ));
            }
            r.push(pct(m.repeatability));
            r.push(pct(m.matching_score));
            r
        })
        .collect();
    let pairs = scenes.iter().map(|s| s.pairs.len()).max().unwrap_or(0);
    let plots: String = scenes.iter().map(|s| format!("![{0}](repeatability_{0}.png)\n\n", s.name)).collect();
    let md = format!(
        "## 4. Repeatability and matching score (Mikolajczyk protocol; not in the paper)\n\n\
         Scenes of `{}`: {}; image 1 against images 2..{} through the given homographies. A keypoint repeats when \
         its warped position lies within {EPS} px of one in the other image (one-to-one, closest first), over the \
         common region; repeatability = repeated / min(common keypoints); matching score = cross-checked \
         nearest-neighbour descriptor matches that repeat / min(common keypoints). Budgets: every keypoint \
         (\"all\"; ORB is always capped, at 500 by default) and N, each detector with its own cap of N: L-FAST \
         `n_features = N` (SPEC 9's per-level quotas), ORB and ORB-SLAM `nfeatures = N`; FAST-9, single-scale and \
         without a cap, keeps its top N scores. \
         Means over the pairs. Files: `repeatability.csv`, `repeatability_<scene>.png`.\n\n{}\n{plots}",
        opts.homography.display(),
        scenes.iter().map(|s| s.name.as_str()).collect::<Vec<_>>().join(", "),
        pairs + 1,
        table(&header.iter().map(String::as_str).collect::<Vec<_>>(), &trow),
    );
    let summary = RepeatSummary {
        scenes: scenes.iter().map(|s| s.name.clone()).collect(),
        pairs,
        budgets: BUDGETS.to_vec(),
        means,
    };
    write_section(&opts.out, Suite::Repeatability, &md, &summary)
}
