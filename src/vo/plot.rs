//! PNG plots with plotters: the top-down trajectory (the paper's Fig 11)
//! and the CDF of per-frame errors (Fig 12). Text uses the bundled DejaVu
//! Sans (no system fonts needed).

use super::{Pose, VoError};
use plotters::prelude::*;
use std::path::Path;
use std::sync::OnceLock;

const FONT: &[u8] = include_bytes!("../../data/fonts/DejaVuSans.ttf");

/// Registers the bundled font as "sans-serif" once.
fn font() -> Result<(), String> {
    static DONE: OnceLock<Result<(), String>> = OnceLock::new();
    DONE.get_or_init(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, FONT)
            .map_err(|_| "the bundled font data/fonts/DejaVuSans.ttf cannot be read".to_string())
    })
    .clone()
}

fn err(path: &Path) -> impl Fn(String) -> VoError + '_ {
    move |reason| VoError::Plot { path: path.to_path_buf(), reason }
}

/// A range around `lo..hi` with a margin, never empty.
fn padded(lo: f64, hi: f64) -> (f64, f64) {
    let span = (hi - lo).max(1.0);
    (lo - 0.05 * span, hi + 0.05 * span)
}

/// Top-down view (x right, z forward) of the ground truth and the estimate,
/// both as they are (the estimate starts at the ground truth's first pose
/// and is scaled by it), on equal axes.
pub fn trajectory(path: &Path, title: &str, gt: Option<&[Pose]>, est: &[Pose]) -> Result<(), VoError> {
    let e = err(path);
    font().map_err(&e)?;
    let xz = |p: &[Pose]| p.iter().map(|p| (p.translation.x, p.translation.z)).collect::<Vec<_>>();
    let est_xz = xz(est);
    let gt_xz = gt.map(xz).unwrap_or_default();
    let all = est_xz.iter().chain(&gt_xz);
    let (mut x0, mut x1, mut z0, mut z1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, z) in all {
        (x0, x1, z0, z1) = (x0.min(x), x1.max(x), z0.min(z), z1.max(z));
    }
    if x0 > x1 {
        (x0, x1, z0, z1) = (0.0, 1.0, 0.0, 1.0);
    }
    // equal scale on both axes: widen the narrower range (the plot is square)
    let (cx, cz) = (0.5 * (x0 + x1), 0.5 * (z0 + z1));
    let half = 0.5 * (x1 - x0).max(z1 - z0).max(1.0);
    let (xr, zr) = (padded(cx - half, cx + half), padded(cz - half, cz + half));
    let root = BitMapBackend::new(path, (800, 800)).into_drawing_area();
    root.fill(&WHITE).map_err(|x| e(x.to_string()))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(format!("{title}: top-down trajectory"), ("sans-serif", 24))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .build_cartesian_2d(xr.0..xr.1, zr.0..zr.1)
        .map_err(|x| e(x.to_string()))?;
    chart
        .configure_mesh()
        .x_desc("x (m)")
        .y_desc("z (m)")
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(|x| e(x.to_string()))?;
    if !gt_xz.is_empty() {
        chart
            .draw_series(LineSeries::new(gt_xz.clone(), BLACK.stroke_width(2)))
            .map_err(|x| e(x.to_string()))?
            .label("ground truth")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.stroke_width(2)));
    }
    chart
        .draw_series(LineSeries::new(est_xz.clone(), RED.stroke_width(2)))
        .map_err(|x| e(x.to_string()))?
        .label("estimate")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED.stroke_width(2)));
    if let Some(&start) = gt_xz.first().or(est_xz.first()) {
        chart.draw_series(std::iter::once(Circle::new(start, 5, BLUE.filled()))).map_err(|x| e(x.to_string()))?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .label_font(("sans-serif", 16))
        .draw()
        .map_err(|x| e(x.to_string()))?;
    root.present().map_err(|x| e(x.to_string()))?;
    Ok(())
}

/// Empirical CDFs of per-frame translation errors, one curve each.
pub fn error_cdf(path: &Path, title: &str, curves: &[(String, Vec<f64>)]) -> Result<(), VoError> {
    let e = err(path);
    font().map_err(&e)?;
    let xmax = curves.iter().flat_map(|(_, v)| v.iter().copied()).fold(0.0f64, f64::max).max(1e-3) * 1.05;
    let root = BitMapBackend::new(path, (800, 500)).into_drawing_area();
    root.fill(&WHITE).map_err(|x| e(x.to_string()))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(format!("{title}: CDF of per-frame ATE"), ("sans-serif", 24))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..xmax, 0.0..1.0)
        .map_err(|x| e(x.to_string()))?;
    chart
        .configure_mesh()
        .x_desc("translation error (m)")
        .y_desc("fraction of frames")
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(|x| e(x.to_string()))?;
    let colours = [RED, BLUE, GREEN, MAGENTA, CYAN];
    for (k, (name, v)) in curves.iter().enumerate() {
        let mut s = v.clone();
        s.sort_by(f64::total_cmp);
        let n = s.len() as f64;
        // a step function: at each error the fraction jumps by 1/n
        let mut pts = vec![(0.0, 0.0)];
        for (i, x) in s.iter().enumerate() {
            pts.push((*x, i as f64 / n));
            pts.push((*x, (i + 1) as f64 / n));
        }
        pts.push((xmax, 1.0));
        let c = colours[k % colours.len()];
        chart
            .draw_series(LineSeries::new(pts, c.stroke_width(2)))
            .map_err(|x| e(x.to_string()))?
            .label(name.as_str())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerRight)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .label_font(("sans-serif", 16))
        .draw()
        .map_err(|x| e(x.to_string()))?;
    root.present().map_err(|x| e(x.to_string()))?;
    Ok(())
}
