//! The report: Markdown tables and number formatting, CSV files, the paper's
//! published numbers, the sections each suite writes, `report.md` assembled
//! from them, the choice of defaults from suites 3-5, and docs/evaluation.md.

use super::{EvalError, Result, Suite, Variant, mode_name, write_text};
use crate::config::Config;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

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

/// A number with `d` decimals; `–` for NaN, `∞` for infinities.
pub fn num(v: f64, d: usize) -> String {
    if v.is_nan() {
        "–".into()
    } else if v.is_infinite() {
        if v > 0.0 { "∞".into() } else { "-∞".into() }
    } else {
        format!("{v:.d$}")
    }
}

/// A fraction as a percentage with one decimal.
pub fn pct(v: f64) -> String {
    if v.is_finite() { format!("{:.1}%", v * 100.0) } else { "–".into() }
}

/// A Markdown table.
pub fn table(header: &[&str], rows: &[Vec<String>]) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "| {} |", header.join(" | "));
    let _ = writeln!(
        s,
        "|{}|",
        header.iter().enumerate().map(|(i, _)| if i == 0 { "---" } else { "---:" }).collect::<Vec<_>>().join("|")
    );
    for r in rows {
        let _ = writeln!(s, "| {} |", r.join(" | "));
    }
    s
}

/// A CSV file: a header and rows; fields with a comma, quote or newline are quoted.
#[derive(Clone, Debug, Default)]
pub struct Csv {
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

impl Csv {
    /// An empty file with these columns.
    pub fn new(header: &[&str]) -> Self {
        Csv { header: header.iter().map(|s| s.to_string()).collect(), rows: Vec::new() }
    }

    /// Appends a row (as many fields as columns).
    pub fn row(&mut self, fields: Vec<String>) {
        debug_assert_eq!(fields.len(), self.header.len());
        self.rows.push(fields);
    }

    /// The text of the file.
    pub fn text(&self) -> String {
        let field = |f: &String| {
            if f.contains([',', '"', '\n']) { format!("\"{}\"", f.replace('"', "\"\"")) } else { f.clone() }
        };
        let mut s = String::new();
        for r in std::iter::once(&self.header).chain(&self.rows) {
            s.push_str(&r.iter().map(field).collect::<Vec<_>>().join(","));
            s.push('\n');
        }
        s
    }

    /// Writes the file atomically.
    pub fn write(&self, path: &Path) -> Result<()> {
        write_text(path, &self.text())
    }
}

/// A float for CSV: full precision, `nan`/`inf` spelled out.
pub fn csv_f(v: f64) -> String {
    if v.is_nan() {
        "nan".into()
    } else if v.is_infinite() {
        if v > 0.0 { "inf".into() } else { "-inf".into() }
    } else {
        format!("{v}")
    }
}

/// Writes a suite's report section (`OUT/<suite>.md`) and its numbers (`OUT/<suite>.json`).
pub fn write_section<T: Serialize>(out: &Path, suite: Suite, markdown: &str, summary: &T) -> Result<()> {
    write_text(&out.join(format!("{}.md", suite.name())), markdown)?;
    let json = serde_json::to_string_pretty(summary)
        .map_err(|e| EvalError::Output { path: out.join(format!("{}.json", suite.name())), reason: e.to_string() })?;
    write_text(&out.join(format!("{}.json", suite.name())), &json)
}

/// Reads a suite's numbers back; `None` when the suite has not run in `out`.
pub fn read_summary<T: for<'de> Deserialize<'de>>(out: &Path, suite: Suite) -> Result<Option<T>> {
    let path = out.join(format!("{}.json", suite.name()));
    let Ok(text) = std::fs::read_to_string(&path) else { return Ok(None) };
    serde_json::from_str(&text)
        .map(Some)
        .map_err(|e| EvalError::Data { path, reason: format!("unreadable suite summary ({e}); rerun the suite") })
}

/// A short description of the machine the timings were taken on.
pub fn machine() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|s| s.trim().to_string())
        })
        .unwrap_or_else(|| std::env::consts::ARCH.to_string());
    format!("{cpu}, {} worker threads", rayon::current_num_threads())
}

/// The 1-minute load average (`/proc/loadavg`), when the system reports one.
pub fn load_average() -> Option<f64> {
    std::fs::read_to_string("/proc/loadavg").ok()?.split_whitespace().next()?.parse().ok()
}

/// Rebuilds `OUT/report.md` from the sections present, in suite order, and
/// adds the choice of defaults when suites 3-5 have all run.
pub fn assemble(out: &Path) -> Result<()> {
    let mut s = String::new();
    let _ = writeln!(s, "# lfast evaluation report\n");
    let _ = writeln!(
        s,
        "Generated by `lfast eval` (lfast {}); every number below is recomputed by the command that \
         wrote this folder. Definitions of every metric: [docs/evaluation.md](../evaluation.md) (when \
         this folder is `docs/eval_report`). CSV files next to this report hold every number per image, \
         frame and pair.\n",
        env!("CARGO_PKG_VERSION")
    );
    let mut any = false;
    for suite in Suite::ALL {
        let p = out.join(format!("{}.md", suite.name()));
        if let Ok(text) = std::fs::read_to_string(&p) {
            s.push_str(&text);
            s.push('\n');
            any = true;
        }
    }
    if !any {
        return Err(EvalError::Data { path: out.to_path_buf(), reason: "no suite section (*.md) to assemble".into() });
    }
    if let Some(d) = decide(out)? {
        s.push_str(&d.markdown());
    } else {
        let _ = writeln!(
            s,
            "## Choice of defaults\n\nNeeds the kitti, repeatability and illumination suites in this folder (`lfast eval all`).\n"
        );
    }
    write_text(&out.join("report.md"), &s)
}

// ---------------------------------------------------------------------------
// The summaries suites 3-5 write, as far as the choice of defaults reads them.

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

/// The budget the choice of defaults compares at (ORB's default feature count).
pub const DECISION_BUDGET: u32 = 500;
/// A challenger must beat the current default's score by more than this to
/// replace it (differences below it are within what one more scene could flip).
pub const DECISION_MARGIN: f64 = 0.01;

/// One candidate's numbers in the choice of defaults.
#[derive(Clone, Debug)]
pub struct Candidate {
    /// The variant.
    pub variant: Variant,
    /// KITTI keypoints per frame.
    pub kitti_points: f64,
    /// KITTI detection ms per frame.
    pub kitti_ms: f64,
    /// Repeatability, every keypoint.
    pub rep_all: f64,
    /// Repeatability at [`DECISION_BUDGET`].
    pub rep_budget: f64,
    /// Matching score at [`DECISION_BUDGET`].
    pub ms_budget: f64,
    /// Keypoint survival, mean over the four changes.
    pub survival: f64,
    /// Visual-odometry ATE RMSE (SE(3)), metres, when suite 6 ran (shown, not scored).
    pub vo_ate: Option<f64>,
}

impl Candidate {
    /// The score: the mean of repeatability and matching score at the budget
    /// and the illumination survival (all fractions, higher is better).
    pub fn score(&self) -> f64 {
        (self.rep_budget + self.ms_budget + self.survival) / 3.0
    }
}

/// The choice of defaults made from suites 3-5.
#[derive(Clone, Debug)]
pub struct Decision {
    /// Every candidate, in [`Variant::ALL`] order.
    pub candidates: Vec<Candidate>,
    /// The best score.
    pub best: Variant,
    /// The current default (`Config::default()`).
    pub current: Variant,
    /// What the evaluation recommends (the rule of [`choose`]).
    pub chosen: Variant,
    /// Scenes and frames behind the numbers.
    pub basis: String,
}

/// Applies the rule of [`Decision`] to candidates; `None` without any.
///
/// The current default stays when its score is within [`DECISION_MARGIN`] of
/// the best. Otherwise the choice is, among the candidates within the margin
/// of the best, the one with the fewest KITTI keypoints per frame (the
/// paper's aim: fewer points of the same quality), ties to the higher score.
pub fn choose(candidates: Vec<Candidate>, basis: String) -> Option<Decision> {
    let best = candidates.iter().max_by(|a, b| a.score().total_cmp(&b.score()))?;
    let (best_variant, best_score) = (best.variant, best.score());
    let d = Config::default();
    let current = Variant { mode: d.mode, support: d.support };
    let current_score = candidates.iter().find(|c| c.variant == current).map(Candidate::score);
    let chosen = match current_score {
        Some(cur) if best_score - cur <= DECISION_MARGIN => current,
        _ => candidates
            .iter()
            .filter(|c| best_score - c.score() <= DECISION_MARGIN)
            .min_by(|a, b| a.kitti_points.total_cmp(&b.kitti_points).then(b.score().total_cmp(&a.score())))
            .map_or(best_variant, |c| c.variant),
    };
    Some(Decision { candidates, best: best_variant, current, chosen, basis })
}

/// The decision from the summaries in `out`; `None` when one of suites 3-5 is missing.
pub fn decide(out: &Path) -> Result<Option<Decision>> {
    let (Some(k), Some(r), Some(i)) = (
        read_summary::<KittiSummary>(out, Suite::Kitti)?,
        read_summary::<RepeatSummary>(out, Suite::Repeatability)?,
        read_summary::<IllumSummary>(out, Suite::Illumination)?,
    ) else {
        return Ok(None);
    };
    let vo = read_summary::<super::vo::VoSummary>(out, Suite::Vo)?;
    let rep = |key: &str, budget: Option<u32>| r.means.iter().find(|m| m.key == key && m.budget == budget);
    let mut cands = Vec::new();
    for v in Variant::ALL {
        let key = v.key();
        let km = k.means.iter().find(|m| m.key == key);
        let surv: Vec<f64> =
            i.means.iter().filter(|m| m.key == key && m.kind == "keypoints").map(|m| m.survival).collect();
        let (Some(km), Some(all), Some(b)) = (km, rep(&key, None), rep(&key, Some(DECISION_BUDGET))) else { continue };
        if surv.is_empty() {
            continue;
        }
        cands.push(Candidate {
            variant: v,
            kitti_points: km.keypoints,
            kitti_ms: km.detect_ms,
            rep_all: all.repeatability,
            rep_budget: b.repeatability,
            ms_budget: b.matching_score,
            survival: super::mean(surv),
            vo_ate: vo.as_ref().and_then(|s| s.rows.iter().find(|row| row.key == key)).and_then(|row| row.ate_rmse),
        });
    }
    let basis = format!(
        "{} KITTI frames; {} homography scene(s) ({}) x {} pairs; {} standard images + {} KITTI frames under 4 brightness changes",
        k.frames,
        r.scenes.len(),
        r.scenes.join(", "),
        r.pairs,
        i.standard_images,
        i.kitti_frames
    );
    Ok(choose(cands, basis))
}

fn variant_label(v: Variant) -> String {
    format!("{} / support {}", mode_name(v.mode), v.support)
}

impl Decision {
    /// The candidates' table.
    pub fn table(&self) -> String {
        let rows: Vec<Vec<String>> = self
            .candidates
            .iter()
            .map(|c| {
                let mut name = variant_label(c.variant);
                if c.variant == self.current {
                    name.push_str(" (current default)");
                }
                vec![
                    name,
                    num(c.kitti_points, 0),
                    num(c.kitti_ms, 1),
                    pct(c.rep_all),
                    pct(c.rep_budget),
                    pct(c.ms_budget),
                    pct(c.survival),
                    num(c.score(), 3),
                    c.vo_ate.map_or("–".into(), |v| num(v, 3)),
                ]
            })
            .collect();
        table(
            &[
                "L-FAST mode / support",
                "KITTI points/frame",
                "KITTI ms/frame",
                "repeatability (all)",
                &format!("repeatability @{DECISION_BUDGET}"),
                &format!("matching score @{DECISION_BUDGET}"),
                "keypoint survival",
                "score",
                "VO ATE RMSE (m, not scored)",
            ],
            &rows,
        )
    }

    /// One sentence: the recommendation and whether it changes the defaults.
    pub fn verdict(&self) -> String {
        let score = |v: Variant| self.candidates.iter().find(|c| c.variant == v).map_or(f64::NAN, Candidate::score);
        let points = |v: Variant| self.candidates.iter().find(|c| c.variant == v).map_or(f64::NAN, |c| c.kitti_points);
        let cfg = |v: Variant| format!("`mode = \"{}\"`, `support = {}`", mode_name(v.mode), v.support);
        let (cur, best, chosen) = (self.current, self.best, self.chosen);
        if chosen == cur && best == cur {
            format!("Keep the current defaults {}: they score best ({}).", cfg(cur), num(score(cur), 3))
        } else if chosen == cur {
            format!(
                "Keep the current defaults {} ({}): the best candidate, {} ({}), is ahead by {} only, within the \
                 margin of {DECISION_MARGIN}.",
                cfg(cur),
                num(score(cur), 3),
                variant_label(best),
                num(score(best), 3),
                num(score(best) - score(cur), 3)
            )
        } else if chosen == best {
            format!(
                "Change the defaults to {} (score {}) from {} (score {}): a lead of {}, more than the margin of \
                 {DECISION_MARGIN}.",
                cfg(chosen),
                num(score(chosen), 3),
                cfg(cur),
                num(score(cur), 3),
                num(score(chosen) - score(cur), 3)
            )
        } else {
            format!(
                "Change the defaults to {} (score {}) from {} (score {}): {} scores best ({}), but {} is within the \
                 margin of {DECISION_MARGIN} of it with fewer keypoints ({} instead of {} per KITTI frame), and \
                 both lead the current default by more than the margin.",
                cfg(chosen),
                num(score(chosen), 3),
                cfg(cur),
                num(score(cur), 3),
                variant_label(best),
                num(score(best), 3),
                variant_label(chosen),
                num(points(chosen), 0),
                num(points(best), 0)
            )
        }
    }

    /// The report section.
    pub fn markdown(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "## Choice of defaults (from suites 3-5)\n");
        let _ = writeln!(
            s,
            "Candidates: L-FAST `mode` in {{paper, branch}} x `support` in {{3, 4}}, everything else as \
             `Config::default()`. Score = mean of repeatability and matching score at a budget of \
             {DECISION_BUDGET} keypoints (suite 4, every pair of every scene) and keypoint survival (suite \
             5, every image, the four changes). The current default stays when its score is within \
             {DECISION_MARGIN} of the best; otherwise the choice is the candidate with the fewest KITTI \
             keypoints per frame (suite 3; the paper's aim: fewer points of the same quality) among those \
             within {DECISION_MARGIN} of the best. The visual-odometry ATE (suite 6, when it ran) is shown, \
             not scored: one trajectory per candidate. Basis: {}.\n",
            self.basis
        );
        s.push_str(&self.table());
        let cost = |v: Variant| {
            self.candidates
                .iter()
                .find(|c| c.variant == v)
                .map_or((f64::NAN, f64::NAN), |c| (c.kitti_points, c.kitti_ms))
        };
        if self.chosen != self.current {
            let ((pc, mc), (pn, mn)) = (cost(self.chosen), cost(self.current));
            let _ = writeln!(
                s,
                "\nCost of the change on KITTI: {} instead of {} keypoints per frame, {} instead of {} ms per frame \
                 (detection).",
                num(pc, 0),
                num(pn, 0),
                num(mc, 1),
                num(mn, 1)
            );
        }
        let _ = writeln!(s, "\n**{}**\n", self.verdict());
        s
    }
}

/// Writes docs/evaluation.md (to `doc`) from the summaries in `out`:
/// what each suite measures and how, the headline numbers next to the
/// paper's, and the choice of defaults.
pub fn write_doc(out: &Path, doc: &Path) -> Result<()> {
    let rel = relative_link(doc, out);
    let mut s = String::new();
    s.push_str(DOC_INTRO);
    let _ = writeln!(s, "The full report of the last run: [{rel}/report.md]({rel}/report.md).\n");
    s.push_str("## Headline numbers next to the paper's\n\n");
    s.push_str(&headline(out)?);
    s.push_str("\n## Choice of defaults\n\n");
    match decide(out)? {
        Some(d) => {
            let _ = writeln!(s, "{}\n", d.markdown().lines().skip(2).collect::<Vec<_>>().join("\n"));
        }
        None => s.push_str(
            "Not decided: the kitti, repeatability and illumination suites have not all run in that folder.\n\n",
        ),
    }
    s.push_str(DOC_METHODS);
    write_text(doc, &s)
}

/// `to` as a relative link from the folder of the file `from` (`../x` where
/// needed); the path as given when the two share no root.
pub fn relative_link(from: &Path, to: &Path) -> String {
    let abs = |p: &Path| std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
    let base = abs(from.parent().unwrap_or(Path::new(".")));
    let target = abs(to);
    let (b, t): (Vec<_>, Vec<_>) = (base.components().collect(), target.components().collect());
    let common = b.iter().zip(&t).take_while(|(x, y)| x == y).count();
    if common == 0 {
        return to.to_string_lossy().into_owned();
    }
    let mut rel = PathBuf::new();
    for _ in common..b.len() {
        rel.push("..");
    }
    for c in &t[common..] {
        rel.push(c);
    }
    if rel.as_os_str().is_empty() { ".".into() } else { rel.to_string_lossy().replace('\\', "/") }
}

/// The headline table: every suite's main number and the paper's.
pub fn headline(out: &Path) -> Result<String> {
    let mut rows: Vec<Vec<String>> = Vec::new();
    if let Some(n) = read_summary::<super::noise::NoiseSummary>(out, Suite::Noise)? {
        rows.push(vec![
            "1 noise: PSNR, flagged median vs Gaussian (mean of images)".into(),
            format!("{} dB vs {} dB", num(n.mean_median_psnr, 2), num(n.mean_gauss_psnr, 2)),
            "median above Gaussian on every image (Table 1)".into(),
        ]);
    }
    if let Some(c) = read_summary::<super::continuity::ContinuitySummary>(out, Suite::Continuity)? {
        rows.push(vec![
            "2 continuity: C/B, improved vs traditional Canny (noisy, mean)".into(),
            format!("{} vs {}", num(c.mean_cb_improved, 3), num(c.mean_cb_canny, 3)),
            "improved closer to 0 (Table 2)".into(),
        ]);
    }
    if let Some(k) = read_summary::<KittiSummary>(out, Suite::Kitti)? {
        let get = |key: &str| k.means.iter().find(|m| m.key == key);
        let cur = Variant { mode: Config::default().mode, support: Config::default().support }.key();
        if let (Some(f), Some(l)) = (get("fast9"), get(&cur)) {
            rows.push(vec![
                format!("3 KITTI points/frame: FAST-9 vs {}", super::label(&cur)),
                format!("{} vs {}", num(f.keypoints, 0), num(l.keypoints, 0)),
                format!("{} vs {} (Fig 9)", paper::FAST_POINTS, paper::LFAST_POINTS),
            ]);
            rows.push(vec![
                format!("3 KITTI ms/frame: FAST-9 vs {}, detection", super::label(&cur)),
                format!("{} vs {}", num(f.detect_ms, 1), num(l.detect_ms, 1)),
                format!("{} vs {} (Fig 10)", paper::FAST_MS, paper::LFAST_MS),
            ]);
        }
        if let Some(l0) = get("lfast-default-l0") {
            rows.push(vec![
                "3 KITTI points/frame: L-FAST default, level 0 only".into(),
                num(l0.keypoints, 0),
                format!("{} (Fig 9)", paper::LFAST_POINTS),
            ]);
        }
    }
    if let Some(r) = read_summary::<RepeatSummary>(out, Suite::Repeatability)? {
        let cur = Variant { mode: Config::default().mode, support: Config::default().support }.key();
        let get = |key: &str| r.means.iter().find(|m| m.key == key && m.budget == Some(DECISION_BUDGET));
        if let (Some(l), Some(f), Some(o)) = (get(&cur), get("fast9"), get("orb")) {
            rows.push(vec![
                format!("4 repeatability @{DECISION_BUDGET}: {} / FAST-9 / ORB", super::label(&cur)),
                format!("{} / {} / {}", pct(l.repeatability), pct(f.repeatability), pct(o.repeatability)),
                "not measured".into(),
            ]);
            rows.push(vec![
                format!("4 matching score @{DECISION_BUDGET}: {} / FAST-9 / ORB", super::label(&cur)),
                format!("{} / {} / {}", pct(l.matching_score), pct(f.matching_score), pct(o.matching_score)),
                "not measured".into(),
            ]);
        }
    }
    if let Some(i) = read_summary::<IllumSummary>(out, Suite::Illumination)? {
        let cur = Variant { mode: Config::default().mode, support: Config::default().support }.key();
        let m = |key: &str| super::mean(i.means.iter().filter(|m| m.key == key).map(|m| m.survival));
        rows.push(vec![
            "5 edge survival: improved Canny vs Canny (mean of changes)".into(),
            format!("{} vs {}", pct(m("improved-canny")), pct(m("canny"))),
            "claimed better under uneven light, not measured".into(),
        ]);
        rows.push(vec![
            format!("5 keypoint survival: {} vs FAST-9", super::label(&cur)),
            format!("{} vs {}", pct(m(&cur)), pct(m("fast9"))),
            "claimed better under brightness changes, not measured".into(),
        ]);
    }
    if let Some(v) = read_summary::<super::vo::VoSummary>(out, Suite::Vo)? {
        let cur = Variant { mode: Config::default().mode, support: Config::default().support }.key();
        let ate = |key: &str| v.rows.iter().find(|r| r.key == key).and_then(|r| r.ate_rmse).unwrap_or(f64::NAN);
        rows.push(vec![
            format!("6 VO ATE RMSE (m): {} / FAST-9 / ORB", super::label(&cur)),
            format!("{} / {} / {}", num(ate(&cur), 3), num(ate("fast9"), 3), num(ate("orb"), 3)),
            "Tables 3-5: a full SLAM system, not comparable".into(),
        ]);
    }
    Ok(table(&["measure", "lfast (this run)", "paper"], &rows))
}

const DOC_INTRO: &str = "\
# Evaluation: the paper's experiments, and what it did not measure

This page is written by `lfast eval` (do not edit it by hand):

```sh
nice -n 10 cargo run --release -- eval all --out docs/eval_report --doc docs/evaluation.md
```

runs the six suites below on `../shared/data` and rewrites this page and
`docs/eval_report/` (report.md, CSV files, PNG plots). One suite alone:
`lfast eval noise|continuity|kitti|repeatability|illumination|vo --out DIR [--data DIR]`;
`--quick` is a reduced run (3 KITTI frames, 2 for illumination, 5 for vo; the first pair of
each scene; one timing repeat).
Every suite runs on the CPU path (deterministic; timings with `std::time::Instant`) and the
noise is seeded (`--seed`, default 2022), so a rerun gives the same numbers except the times.

";

const DOC_METHODS: &str = "\
## What each suite measures

Data (never copied into the repository: only numbers and plots are committed):
`../shared/data/standard` (cameraman, lena, peppers_gray, terraux; colour converted to gray
with SPEC 0's BT.601), `../shared/data/kitti/seq01_000000-000050` (51 frames, 1241x376),
`../shared/data/homography/{bikes,boat,graf}` (Oxford format, img1..img6 and H1to2p..H1to6p).
`--data DIR` points one suite at another folder of the same format; for `all` it is a root
holding `standard/`, `kitti/` (a KITTI folder, or a folder of sequences) and `homography/`.

Detectors: FAST-9 is `lfast::baseline::fast::fast9` (threshold 20, NMS, OpenCV-exact, full
resolution only); ORB is `lfast::baseline::orb` as `cv2.ORB_create()` (500 features, 8 levels);
L-FAST is `lfast::cpu::CpuDetector` with `Config::default()` except the mode and support under
test (8-level pyramid, no cap). FAST-9 keypoints get descriptors from `CpuDetector::compute`.

### 1. noise (paper Table 1)

Salt-and-pepper noise: every pixel independently, with probability 0.05, becomes 0 or 255 (equal
odds), drawn from SplitMix64 seeded with the seed mixed with the image's file name (FNV-1a).
Filters: the flagged median (SPEC 1, delta 0.1) and a 5x5 Gaussian, sigma 0.8 (Q8 integer
weights, BORDER_REFLECT_101, as OpenCV). Against the clean image K and the filtered image I
of N pixels:

- MSE = (1/N) Σ (K − I)²;  **PSNR = 10 log10(255² / MSE)** dB (∞ when identical);
- **SNR = 10 log10(Σ K² / Σ (K − I)²)** dB: the power of the clean image over the power of the error.

### 2. continuity (paper Table 2)

On the same noisy images: traditional Canny (`baseline::canny`: 5x5 Gaussian sigma 0.8, Sobel,
L2 magnitude, thresholds 200/100, NMS, hysteresis) vs the improved Canny (SPEC 1-7). Of each
edge map: **A** = edge pixels, **B** = 4-connected components, **C** = 8-connected components.
C ≤ B: every 8-component is a union of 4-components, so **C/B** (\"continuity\") is 1 when no
curve is held together only by diagonal steps and falls as curves break into 4-pieces; the paper
reads closer to 0 as better. **C/A** (\"smoothness\") is curves per edge pixel: lower means
fewer, longer curves. The clean images are reported too. Beyond the paper, against each
method's own clean-image map: **recall** = fraction of its clean-image edge pixels with an
edge pixel within 1 px in its noisy-image map, **spurious** = fraction of its noisy-image edge
pixels with none within 1 px in its clean-image map (edges made by the noise). The edge maps side by side (noisy
input | Canny | improved Canny) go to `images/` of the output folder, which is not committed
(they are derived from images that may not be redistributed).

### 3. kitti (paper Figs 9-10)

Every frame of the folder: keypoints of FAST-9, ORB and the four L-FAST variants (and the
default L-FAST on level 0 alone, comparable to single-scale FAST-9); times per frame of
detection (keypoints with orientation; FAST-9 alone for FAST-9) and of detection plus
descriptors, the improved Canny edge map (level 0) and traditional Canny separately. Each time
is the median of 3 runs of the frame (1 with `--quick`), after one untimed warm-up frame,
measured with `std::time::Instant` on the machine named in the report (its thread count is
rayon's pool, all cores unless `--jobs`).

### 4. repeatability (Mikolajczyk et al. 2005 protocol)

For each scene, image 1 against images 2..6 with the given homography H (image 1 → image n).
Common region: keypoints of image 1 whose H-warped position lies inside image n, and keypoints
of image n whose H⁻¹-warped position lies inside image 1. Two keypoints correspond when the
warped position of the first lies within **2.5 px** of the second (in image n); pairs are made
one-to-one, closest first. **Repeatability** = correspondences / min(common keypoints of the two
images). **Matching score** = mutual nearest-neighbour descriptor matches (Hamming distance,
cross-checked) whose positions correspond within 2.5 px, / min(common keypoints). Every
keypoint, and at **equal budgets**: the top N by response of each detector (N = 500 and 1000;
ORB run with `nfeatures = N`). Positions only (no scale or region overlap), for every detector
alike.

### 5. illumination

Each standard image and each KITTI frame, changed four ways: **gamma 0.5** and **gamma 2.0**
(255 (v/255)^γ, rounded), a **shadow ramp** (left half untouched, right half multiplied by a
factor falling linearly from 1 at the centre column to 0.25 at the last), and a global **gain
0.5**. Edge survival: the fraction of the original edge map's pixels with an edge pixel within
1 px (the 3x3 square) in the changed image's map; improved Canny vs traditional Canny.
Keypoint survival: the fraction of the original keypoints with a keypoint within 2.5 px in
the changed image; L-FAST variants vs FAST-9. Count ratio = count after / count before (a
detector that fires everywhere survives trivially, so read the two together).

### 6. vo

`lfast::vo::run_suite` (docs/vo.md) on the KITTI sequence, on the CPU, for FAST-9, ORB and the
four L-FAST variants: monocular odometry (consecutive-frame matching, essential matrix with
RANSAC, steps scaled by the ground truth), and the absolute trajectory error RMSE after SE(3)
and Sim(3) alignment. Shown next to the choice of defaults, not scored.

### Choice of defaults

Score of an L-FAST variant = mean of (repeatability at 500, matching score at 500, keypoint
survival). The current default stays when it is within 0.01 of the best score; otherwise the
choice is the candidate with the fewest KITTI keypoints per frame among those within 0.01 of
the best (fewer points of the same quality, the paper's aim). The rule is in
`lfast::eval::report::choose`.
";
