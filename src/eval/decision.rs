//! The choice of defaults from suites 3-6: the candidates' numbers, the rule
//! ([`choose`]) and its report section.

use super::format::{num, pct, table};
use super::illumination::IllumSummary;
use super::kitti::KittiSummary;
use super::output::read_summary;
use super::repeatability::RepeatSummary;
use super::{Departure, Result, SPEC_BINS, SPEC_NMS_RADIUS, Suite, Variant, mode_name};
use std::fmt::Write as _;
use std::path::Path;

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
    /// Visual-odometry ATE RMSE (SE(3)), metres, when suite 6 ran.
    pub vo_ate: Option<f64>,
    /// The smallest ATE of all candidates over this one's (1 for the best
    /// trajectory, towards 0 for worse ones); set by [`choose`] when every
    /// candidate has an ATE.
    pub vo_rel: Option<f64>,
}

impl Candidate {
    /// The score: the mean of repeatability and matching score at the budget,
    /// the illumination survival and, when suite 6 ran for every candidate,
    /// the relative trajectory accuracy [`vo_rel`](Self::vo_rel) (all
    /// fractions, higher is better).
    pub fn score(&self) -> f64 {
        match self.vo_rel {
            Some(v) => (self.rep_budget + self.ms_budget + self.survival + v) / 4.0,
            None => (self.rep_budget + self.ms_budget + self.survival) / 3.0,
        }
    }
}

/// Sets every candidate's [`Candidate::vo_rel`] = smallest ATE / its ATE when
/// every candidate has a finite positive ATE; otherwise clears them all.
///
/// ```
/// use lfast::eval::decision::{Candidate, relative_ate};
/// use lfast::eval::Variant;
/// let c = |ate| Candidate { variant: Variant::ALL[0], kitti_points: 0.0, kitti_ms: 0.0, rep_all: 0.0,
///     rep_budget: 0.0, ms_budget: 0.0, survival: 0.0, vo_ate: ate, vo_rel: None };
/// let mut cs = vec![c(Some(0.05)), c(Some(0.1))];
/// relative_ate(&mut cs);
/// assert_eq!((cs[0].vo_rel, cs[1].vo_rel), (Some(1.0), Some(0.5)));
/// let mut cs = vec![c(Some(0.05)), c(None)];
/// relative_ate(&mut cs);
/// assert!(cs.iter().all(|c| c.vo_rel.is_none()));
/// ```
pub fn relative_ate(candidates: &mut [Candidate]) {
    let ok = |a: Option<f64>| a.is_some_and(|a| a.is_finite() && a > 0.0);
    let all = !candidates.is_empty() && candidates.iter().all(|c| ok(c.vo_ate));
    let best = candidates.iter().filter_map(|c| c.vo_ate).fold(f64::INFINITY, f64::min);
    for c in candidates.iter_mut() {
        c.vo_rel = if all { c.vo_ate.map(|a| best / a) } else { None };
    }
}

/// The choice of defaults made from suites 3-6.
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
pub fn choose(mut candidates: Vec<Candidate>, basis: String) -> Option<Decision> {
    relative_ate(&mut candidates);
    let best = candidates.iter().max_by(|a, b| a.score().total_cmp(&b.score()))?;
    let (best_variant, best_score) = (best.variant, best.score());
    let current = Variant::current();
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

/// The decision from the summaries in `out` (suite 6 counts when it ran); `None` when one of suites 3-5 is missing.
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
            vo_rel: None,
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
    let rest: String = v
        .departures()
        .into_iter()
        .map(|d| match d {
            Departure::Nms(r) => format!(" / nms {r}"),
            Departure::Snap(s) => format!(" / snap {s}"),
            Departure::NoEdges => " / no edges".into(),
            Departure::Bins(b) => format!(" / {b} bins"),
        })
        .collect();
    format!("{} / support {}{rest}", mode_name(v.mode), v.support)
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
                    c.vo_rel.map_or("not scored".into(), |v| num(v, 3)),
                ]
            })
            .collect();
        table(
            &[
                "L-FAST mode / support / nms / snap / edges / bins",
                "KITTI points/frame",
                "KITTI ms/frame",
                "repeatability (all)",
                &format!("repeatability @{DECISION_BUDGET}"),
                &format!("matching score @{DECISION_BUDGET}"),
                "keypoint survival",
                "score",
                "VO ATE RMSE (m)",
                "best ATE / ATE",
            ],
            &rows,
        )
    }

    /// One sentence: the recommendation and whether it changes the defaults.
    pub fn verdict(&self) -> String {
        let score = |v: Variant| self.candidates.iter().find(|c| c.variant == v).map_or(f64::NAN, Candidate::score);
        let points = |v: Variant| self.candidates.iter().find(|c| c.variant == v).map_or(f64::NAN, |c| c.kitti_points);
        let cfg = |v: Variant| v.fields();
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
        let _ = writeln!(s, "## Choice of defaults (from suites 3-6)\n");
        let _ = writeln!(
            s,
            "Candidates: L-FAST `mode` in {{paper, branch}} x `support` in {{3, 4}}; the two \
             support-3 ones with `snap_radius = 1` (the corner moved to the Harris peak, located to 1/16 px; \
             docs/quality.md); paper support 3 snap 1 with `reject_edges = true` (no corner where the Harris \
             response is not above 0: an edge); the same with `nms_radius = 4`, `snap_radius = 2`; and that one \
             with `orientation_bins = 180` (the descriptor's pattern rotated in 2° steps instead of 12°). Each \
             candidate sets `nms_radius` ({SPEC_NMS_RADIUS} unless named), `snap_radius` (0 unless named), \
             `reject_edges` (false unless named) and `orientation_bins` ({SPEC_BINS} unless named); every other field is `Config::default()`'s. Score = mean of repeatability and matching score at a budget of \
             {DECISION_BUDGET} keypoints (suite 4, every pair of every scene), keypoint survival (suite \
             5, every image, the four changes) and, when suite 6 ran for every candidate, the relative \
             trajectory accuracy: the smallest visual-odometry ATE RMSE (SE(3), the mean over suite 6's RANSAC \
             seeds) of the candidates over the candidate's own (1 for the best trajectory). The current default stays when its score is within \
             {DECISION_MARGIN} of the best; otherwise the choice is the candidate with the fewest KITTI \
             keypoints per frame (suite 3; the paper's aim: fewer points of the same quality) among those \
             within {DECISION_MARGIN} of the best. Basis: {}.\n",
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn variant_labels_name_each_departure_from_spec() {
        assert_eq!(variant_label(Variant::ALL[0]), "paper / support 3");
        assert_eq!(variant_label(Variant::ALL[8]), "paper / support 3 / nms 4 / snap 2 / no edges / 180 bins");
        assert_eq!(Variant::ALL[8].key(), "lfast-paper-s3-nms4-snap2-noedges-bins180");
        assert_eq!(Variant::ALL[8].label(), "L-FAST paper s3 nms4 snap2 no edges bins180");
        assert_eq!(Variant::ALL[5].label(), "L-FAST branch s3 snap1");
    }
}
