//! PNG plots with plotters: line charts (per frame, per image index) and
//! grouped bar charts (the tables), one or more panels per figure. Text uses
//! the bundled DejaVu Sans (data/fonts), so no system font is needed.

use super::{EvalError, Result};
use plotters::prelude::*;
use plotters::style::FontStyle;
use std::path::Path;
use std::sync::OnceLock;

pub(crate) const FONT: &str = "sans-serif";

/// Registers the bundled font once; `false` when it cannot be parsed.
pub(crate) fn font_ready() -> bool {
    static READY: OnceLock<bool> = OnceLock::new();
    *READY.get_or_init(|| {
        plotters::style::register_font(FONT, FontStyle::Normal, include_bytes!("../../data/fonts/DejaVuSans.ttf"))
            .is_ok()
    })
}

/// Text as plotters should draw it. Its ab_glyph layout applies kerning but
/// not the glyphs' side bearings, so "T " and "T-" collapse ("L-FASTpaper",
/// "FAST9"): spaces become two thin spaces and hyphens non-breaking hyphens,
/// which have no kerning pairs in DejaVu Sans.
pub(crate) fn text(s: &str) -> String {
    s.replace(' ', "\u{2009}\u{2009}").replace('-', "\u{2011}")
}

/// Colour `i` of a fixed palette (matplotlib's "tab10"), so a detector keeps
/// its colour across plots when callers pass the same index.
pub fn colour(i: usize) -> RGBColor {
    const P: [(u8, u8, u8); 10] = [
        (31, 119, 180),
        (255, 127, 14),
        (44, 160, 44),
        (214, 39, 40),
        (148, 103, 189),
        (140, 86, 75),
        (227, 119, 194),
        (127, 127, 127),
        (188, 189, 34),
        (23, 190, 207),
    ];
    let (r, g, b) = P[i % P.len()];
    RGBColor(r, g, b)
}

/// One named line of a line chart, with its palette index.
#[derive(Clone, Debug)]
pub struct Series {
    /// Legend text.
    pub name: String,
    /// Palette index ([`colour`]).
    pub colour: usize,
    /// (x, y) points; non-finite points are left out.
    pub points: Vec<(f64, f64)>,
}

/// One named group member of a bar chart: one value per category.
#[derive(Clone, Debug)]
pub struct Bars {
    /// Legend text.
    pub name: String,
    /// Palette index ([`colour`]).
    pub colour: usize,
    /// One value per category; non-finite values draw no bar.
    pub values: Vec<f64>,
}

/// A panel of a figure.
#[derive(Clone, Debug)]
pub enum Panel {
    /// Lines over a numeric x axis.
    Line {
        /// Panel title.
        title: String,
        /// x axis label.
        x_desc: String,
        /// y axis label.
        y_desc: String,
        /// The lines.
        series: Vec<Series>,
    },
    /// Grouped bars, one group per category.
    Bar {
        /// Panel title.
        title: String,
        /// y axis label.
        y_desc: String,
        /// Category names (x axis).
        categories: Vec<String>,
        /// The members of each group.
        bars: Vec<Bars>,
    },
}

fn plot_err(path: &Path) -> impl Fn(String) -> EvalError + '_ {
    move |reason| EvalError::Plot { path: path.to_path_buf(), reason }
}

/// Draws `panels` on a `rows x cols` grid into a `size` PNG at `path`
/// (written atomically).
pub fn figure(path: &Path, size: (u32, u32), grid: (usize, usize), panels: &[Panel]) -> Result<()> {
    let err = plot_err(path);
    if !font_ready() {
        return Err(err("the bundled font data/fonts/DejaVuSans.ttf cannot be parsed".into()));
    }
    if panels.len() > grid.0 * grid.1 {
        return Err(err(format!("{} panels do not fit a {}x{} grid", panels.len(), grid.0, grid.1)));
    }
    let mut buf = vec![255u8; size.0 as usize * size.1 as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buf, size).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
        let areas = root.split_evenly(grid);
        for (panel, area) in panels.iter().zip(&areas) {
            match panel {
                Panel::Line { title, x_desc, y_desc, series } => line(area, title, x_desc, y_desc, series),
                Panel::Bar { title, y_desc, categories, bars } => bar(&root, area, title, y_desc, categories, bars),
            }
            .map_err(&err)?;
        }
        root.present().map_err(|e| err(e.to_string()))?;
    }
    let mut png = Vec::new();
    {
        use image::ImageEncoder;
        use image::codecs::png::{CompressionType, FilterType, PngEncoder};
        PngEncoder::new_with_quality(&mut png, CompressionType::Best, FilterType::Adaptive)
            .write_image(&buf, size.0, size.1, image::ExtendedColorType::Rgb8)
            .map_err(|e| err(e.to_string()))?;
    }
    Ok(crate::io::write_atomic(path, &png)?)
}

type Area<'a> = DrawingArea<BitMapBackend<'a>, plotters::coord::Shift>;

/// A range padded by 5% (and widened when flat).
fn padded(lo: f64, hi: f64, from_zero: bool) -> (f64, f64) {
    let (mut lo, mut hi) = if lo.is_finite() && hi.is_finite() { (lo, hi) } else { (0.0, 1.0) };
    if from_zero {
        lo = lo.min(0.0);
    }
    if hi - lo < 1e-9 {
        hi = lo + 1.0;
    }
    let pad = (hi - lo) * 0.05;
    (if from_zero && lo >= 0.0 { 0.0 } else { lo - pad }, hi + pad)
}

fn line(area: &Area<'_>, title: &str, x_desc: &str, y_desc: &str, series: &[Series]) -> Result<(), String> {
    let pts = || series.iter().flat_map(|s| s.points.iter().copied()).filter(|p| p.0.is_finite() && p.1.is_finite());
    let (x0, x1) = pts().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| (a.min(p.0), b.max(p.0)));
    let (y0, y1) = pts().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| (a.min(p.1), b.max(p.1)));
    let (x0, x1) = match (x0.is_finite(), x1 > x0) {
        (true, true) => (x0, x1),
        (true, false) => (x0 - 1.0, x0 + 1.0), // one x value: centre it
        _ => (0.0, 1.0),
    };
    // headroom for the legend in the upper right, one text line per series
    let (y0, y1) = padded(y0, y1 * (1.08 + 0.055 * series.len() as f64), true);
    let mut chart = ChartBuilder::on(area)
        .caption(text(title), (FONT, 20))
        .margin(12)
        .x_label_area_size(42)
        .y_label_area_size(64)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .x_desc(text(x_desc))
        .y_desc(text(y_desc))
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 15))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(|e| e.to_string())?;
    for s in series {
        let c = colour(s.colour);
        let pts: Vec<(f64, f64)> = s.points.iter().copied().filter(|p| p.0.is_finite() && p.1.is_finite()).collect();
        chart
            .draw_series(LineSeries::new(pts.clone(), c.stroke_width(2)))
            .map_err(|e| e.to_string())?
            .label(text(&s.name))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(3)));
        if pts.len() <= 12 {
            chart.draw_series(pts.iter().map(|&p| Circle::new(p, 3, c.filled()))).map_err(|e| e.to_string())?;
        }
    }
    chart
        .configure_series_labels()
        .label_font((FONT, 13))
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(160, 160, 160))
        .position(SeriesLabelPosition::UpperRight)
        .draw()
        .map_err(|e| e.to_string())?;
    Ok(())
}

fn bar(
    root: &Area<'_>,
    area: &Area<'_>,
    title: &str,
    y_desc: &str,
    cats: &[String],
    bars: &[Bars],
) -> Result<(), String> {
    let n = cats.len().max(1);
    let vals = || bars.iter().flat_map(|b| b.values.iter().copied()).filter(|v| v.is_finite());
    let (lo, hi) = vals().fold((0.0f64, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
    // headroom for the legend in the upper right, one text line per series
    let (y0, y1) = padded(lo, hi * (1.08 + 0.055 * bars.len() as f64), true);
    let label = |v: &SegmentValue<usize>| match v {
        SegmentValue::CenterOf(i) | SegmentValue::Exact(i) => cats.get(*i).map(|c| text(c)).unwrap_or_default(),
        SegmentValue::Last => String::new(),
    };
    let mut chart = ChartBuilder::on(area)
        .caption(text(title), (FONT, 20))
        .margin(12)
        .x_label_area_size(42)
        .y_label_area_size(64)
        // an integer range includes its end: 0..n-1 is n segments
        .build_cartesian_2d((0..n - 1).into_segmented(), y0..y1)
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(n)
        .x_label_formatter(&label)
        .y_desc(text(y_desc))
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 15))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(|e| e.to_string())?;
    let k = bars.len().max(1) as f64;
    for (s, b) in bars.iter().enumerate() {
        let c = colour(b.colour);
        for (i, &v) in b.values.iter().enumerate().take(n) {
            if !v.is_finite() {
                continue;
            }
            // the segment's pixel span, 80% of it shared by the group
            let left = chart.backend_coord(&(SegmentValue::Exact(i), 0.0)).0 as f64;
            let right = chart.backend_coord(&(SegmentValue::Exact(i + 1), 0.0)).0 as f64;
            let inner = (right - left) * 0.8;
            let x = left + (right - left) * 0.1 + inner * s as f64 / k;
            let base = chart.backend_coord(&(SegmentValue::Exact(i), 0.0f64.clamp(y0, y1))).1;
            let top = chart.backend_coord(&(SegmentValue::Exact(i), v.clamp(y0, y1))).1;
            let (xa, xb) = (x.round() as i32, (x + inner / k).round() as i32 - 1);
            root.draw(&Rectangle::new([(xa, top.min(base)), (xb.max(xa), top.max(base))], c.filled()))
                .map_err(|e| e.to_string())?;
        }
        chart
            .draw_series(std::iter::empty::<Rectangle<(SegmentValue<usize>, f64)>>())
            .map_err(|e| e.to_string())?
            .label(text(&b.name))
            .legend(move |(x, y)| Rectangle::new([(x, y - 6), (x + 14, y + 6)], c.filled()));
    }
    chart
        .configure_series_labels()
        .label_font((FONT, 13))
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(160, 160, 160))
        .position(SeriesLabelPosition::UpperRight)
        .draw()
        .map_err(|e| e.to_string())?;
    Ok(())
}
