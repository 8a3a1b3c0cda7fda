//! Suite 5 (the paper's central claim, measured): synthetic brightness
//! changes of each standard image and KITTI frame (gamma 0.5 and 2.0, a shadow
//! ramp to 25%, a gain of 0.5) and the fraction of edge pixels (within 1 px)
//! and keypoints (within 2.5 px) that survive them: improved Canny vs Canny,
//! L-FAST vs FAST-9.

use super::format::{Csv, csv_f, num, pct, table};
use super::metrics::{Lighting, edge_survival, keypoint_survival};
use super::output::write_section;
use super::plot::{Bars, Panel, figure};
use super::{Detectors, NamedImage, Options, Result, Suite, colour_of, kitti_frames, label, load_standard, mean, stem};
use crate::config::Config;
use crate::cpu::CpuDetector;
use crate::image::Plane;
use serde::{Deserialize, Serialize};

/// Mean survival of one method under one brightness change.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SurvivalMean {
    /// Method key (`canny`, `improved-canny`, `fast9`, `lfast-...`).
    pub key: String,
    /// `edges` or `keypoints`.
    pub kind: String,
    /// The change (`gamma 0.5`, ...).
    pub transform: String,
    /// Mean survival over the images.
    pub survival: f64,
    /// Mean of count after / count before.
    pub count_ratio: f64,
}

/// What the illumination suite leaves for the report.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct IllumSummary {
    /// Standard images used.
    pub standard_images: usize,
    /// KITTI frames used.
    pub kitti_frames: usize,
    /// Per method and change.
    pub means: Vec<SurvivalMean>,
}

/// Edge-pixel tolerance (Chebyshev), pixels.
pub const EDGE_RADIUS: u32 = 1;
/// Keypoint tolerance (Euclidean), pixels.
pub const KEYPOINT_EPS: f64 = 2.5;
/// KITTI frames of a quick run.
pub const QUICK_FRAMES: usize = 2;

/// Edge maps and keypoint positions of one image under every method.
struct Observed {
    /// (method key, edge map) for the edge methods.
    edges: Vec<(String, Plane<u8>)>,
    /// (method key, positions) for the keypoint methods.
    points: Vec<(String, Vec<[f64; 2]>)>,
}

fn observe(img: &Plane<u8>, det: &Detectors, edges: &CpuDetector) -> Result<Observed> {
    let e = vec![
        ("canny".to_string(), super::continuity::traditional(img)),
        ("improved-canny".to_string(), edges.edge_image(img.view())?),
    ];
    let pos = |kps: &[crate::KeyPoint]| kps.iter().map(|k| [k.pt.x as f64, k.pt.y as f64]).collect::<Vec<_>>();
    let mut p = vec![
        ("fast9".to_string(), pos(&Detectors::fast9_sorted(img))),
        ("orbslam".to_string(), pos(&det.orbslam.detect_and_compute(img.view())?.0)),
    ];
    for (v, d) in &det.lfast {
        p.push((v.key(), pos(&d.detect(img.view(), None)?)));
    }
    Ok(Observed { edges: e, points: p })
}

/// One image, one change, one method.
#[derive(Clone, Debug)]
struct Row {
    source: &'static str,
    image: String,
    transform: String,
    key: String,
    kind: &'static str,
    before: usize,
    after: usize,
    survival: Option<f64>,
}

impl Row {
    fn ratio(&self) -> f64 {
        if self.before == 0 { f64::NAN } else { self.after as f64 / self.before as f64 }
    }
}

/// Runs the suite: `illumination.csv`, `illumination.png`, the section.
pub fn run(opts: &Options) -> Result<()> {
    let mut images: Vec<(&'static str, NamedImage)> =
        load_standard(&opts.standard)?.into_iter().map(|n| ("standard", n)).collect();
    let mut frames = kitti_frames(&opts.kitti)?;
    if opts.quick {
        frames.truncate(QUICK_FRAMES);
    }
    let n_standard = images.len();
    for f in &frames {
        images.push(("kitti", NamedImage { name: stem(f), image: crate::image::load_gray(f)? }));
    }
    let det = Detectors::new()?;
    let edges = CpuDetector::new(Config::default())?;
    let mut rows = Vec::new();
    for (source, n) in &images {
        let before = observe(&n.image, &det, &edges)?;
        for l in Lighting::SUITE {
            let after = observe(&l.apply(&n.image), &det, &edges)?;
            for ((key, a), (_, b)) in before.edges.iter().zip(&after.edges) {
                rows.push(Row {
                    source,
                    image: n.name.clone(),
                    transform: l.name(),
                    key: key.clone(),
                    kind: "edges",
                    before: a.data.iter().filter(|&&v| v != 0).count(),
                    after: b.data.iter().filter(|&&v| v != 0).count(),
                    survival: edge_survival(a, b, EDGE_RADIUS)?,
                });
            }
            for ((key, a), (_, b)) in before.points.iter().zip(&after.points) {
                rows.push(Row {
                    source,
                    image: n.name.clone(),
                    transform: l.name(),
                    key: key.clone(),
                    kind: "keypoints",
                    before: a.len(),
                    after: b.len(),
                    survival: keypoint_survival(a, b, KEYPOINT_EPS),
                });
            }
        }
    }

    let mut csv =
        Csv::new(&["source", "image", "transform", "method", "kind", "before", "after", "survival", "count_ratio"]);
    for r in &rows {
        csv.row(vec![
            r.source.into(),
            r.image.clone(),
            r.transform.clone(),
            r.key.clone(),
            r.kind.into(),
            r.before.to_string(),
            r.after.to_string(),
            csv_f(r.survival.unwrap_or(f64::NAN)),
            csv_f(r.ratio()),
        ]);
    }
    csv.write(&opts.out.join("illumination.csv"))?;

    let transforms: Vec<String> = Lighting::SUITE.iter().map(Lighting::name).collect();
    let mut keys: Vec<(String, &'static str)> =
        vec![("canny".into(), "edges"), ("improved-canny".into(), "edges"), ("fast9".into(), "keypoints")];
    keys.push(("orbslam".into(), "keypoints"));
    keys.extend(det.lfast.iter().map(|(v, _)| (v.key(), "keypoints")));
    let select = |source: Option<&str>, key: &str, t: &str| -> Vec<&Row> {
        rows.iter().filter(|r| source.is_none_or(|s| r.source == s) && r.key == key && r.transform == t).collect()
    };
    let surv = |rs: &[&Row]| mean(rs.iter().filter_map(|r| r.survival));
    let ratio = |rs: &[&Row]| mean(rs.iter().map(|r| r.ratio()).filter(|v| v.is_finite()));

    let bars = |kind: &str| -> Vec<Bars> {
        keys.iter()
            .filter(|(_, k)| *k == kind)
            .map(|(key, _)| Bars {
                name: label(key),
                colour: colour_of(key),
                values: transforms.iter().map(|t| 100.0 * surv(&select(None, key, t))).collect(),
            })
            .collect()
    };
    figure(
        &opts.out.join("illumination.png"),
        (1200, 960),
        (2, 1),
        &[
            Panel::Bar {
                title: format!("Edge pixels surviving (within {EDGE_RADIUS} px), mean over all images"),
                y_desc: "%".into(),
                categories: transforms.clone(),
                bars: bars("edges"),
            },
            Panel::Bar {
                title: format!("Keypoints surviving (within {KEYPOINT_EPS} px), mean over all images"),
                y_desc: "%".into(),
                categories: transforms.clone(),
                bars: bars("keypoints"),
            },
        ],
    )?;

    let means: Vec<SurvivalMean> = keys
        .iter()
        .flat_map(|(key, kind)| {
            transforms.iter().map(|t| {
                let rs = select(None, key, t);
                SurvivalMean {
                    key: key.clone(),
                    kind: kind.to_string(),
                    transform: t.clone(),
                    survival: surv(&rs),
                    count_ratio: ratio(&rs),
                }
            })
        })
        .collect();
    let mut header = vec!["images".to_string(), "method".into()];
    header.extend(transforms.iter().map(|t| format!("{t}: survival (count ratio)")));
    header.push("mean survival".into());
    let sources: Vec<(&str, Option<&str>)> =
        vec![("standard", Some("standard")), ("KITTI", Some("kitti")), ("all", None)];
    let mut trow = Vec::new();
    for (sname, src) in &sources {
        if select(*src, "canny", &transforms[0]).is_empty() {
            continue;
        }
        for (key, _) in &keys {
            let mut r = vec![sname.to_string(), label(key)];
            let mut all = Vec::new();
            for t in &transforms {
                let rs = select(*src, key, t);
                all.extend(rs.iter().filter_map(|r| r.survival));
                r.push(format!("{} (×{})", pct(surv(&rs)), num(ratio(&rs), 2)));
            }
            r.push(pct(mean(all)));
            trow.push(r);
        }
    }
    let m = |key: &str| mean(means.iter().filter(|x| x.key == key).map(|x| x.survival));
    let current = super::Variant::current().key();
    let md = format!(
        "## 5. Illumination: what survives a brightness change (the paper's claim, measured)\n\n\
         {n_standard} standard image(s) and {} KITTI frame(s), each changed four ways: gamma 0.5, gamma 2.0, a shadow \
         ramp (right half darkened linearly to 25% at the border) and a gain of 0.5. Survival = fraction of the \
         original image's edge pixels with an edge pixel within {EDGE_RADIUS} px (keypoints: a keypoint within \
         {KEYPOINT_EPS} px) in the changed image; count ratio = count after / count before. Files: \
         `illumination.csv`, `illumination.png`.\n\n{}\n\
         Over all images and changes: edges survive {} with the improved Canny vs {} with Canny; keypoints {} with \
         {} (the current default) vs {} with FAST-9.\n\n\
         Paper: claims L-FAST's points are more stable under obvious brightness changes; it gives no number \
         for it.\n\n![illumination](illumination.png)\n",
        frames.len(),
        table(&header.iter().map(String::as_str).collect::<Vec<_>>(), &trow),
        pct(m("improved-canny")),
        pct(m("canny")),
        pct(m(&current)),
        label(&current),
        pct(m("fast9")),
    );
    let summary = IllumSummary { standard_images: n_standard, kitti_frames: frames.len(), means };
    write_section(&opts.out, Suite::Illumination, &md, &summary)
}
