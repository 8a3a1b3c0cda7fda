//! `lfast compare`: one picture that shows what L-FAST picks next to the
//! baselines. Four labelled panels of the input, two by two: the improved
//! Canny edge map (level 0), then the keypoints of L-FAST, FAST-9 and ORB at
//! the same budget, each a ring in its pyramid level's colour
//! ([`super::draw::markers`]), and a legend of the colours below. The
//! three detectors are the front ends of `lfast detect --detector`
//! ([`crate::frontend::Features`]): L-FAST on the chosen backend, the
//! baselines on the CPU, all under one config.

use super::{CliError, Common};
use crate::KeyPoint;
use crate::eval::plot;
use crate::frontend::{Features, FrontEnd};
use crate::image::Plane;
use image::{Rgb, RgbImage};
use plotters::prelude::*;
use std::path::PathBuf;

pub(super) const AFTER_HELP: &str = "\
The picture is two panels by two, each the input's size under a label:
  top left      the improved Canny edge map (SPEC 1-7, level 0), white = edge
  top right     L-FAST keypoints      (--n-features strongest over all levels)
  bottom left   FAST-9 keypoints      (OpenCV-exact, --fast-threshold, the strongest kept)
  bottom right  ORB keypoints         (as cv2.ORB_create(--n-features))
Each keypoint is a ring at its position (radius: the image width / 128, 3 to 8 pixels); the
colour gives its pyramid level (red 0, green 1, blue 2, yellow 3, magenta 4, cyan 5,
orange 6, lilac 7), as the legend under the panels shows.";

/// Keypoint budget when neither `--n-features` nor the config sets one.
const DEFAULT_BUDGET: u32 = 500;

/// Space between panels and around the picture, in pixels.
const GAP: u32 = 6;

/// Background of the label strips and the gaps.
const BACKGROUND: [u8; 3] = [24, 24, 28];

#[derive(clap::Args)]
pub(super) struct CompareArgs {
    /// The image (8/16-bit gray or colour)
    input: PathBuf,
    /// The picture to write (PNG)
    #[arg(long, short = 'o', value_name = "FILE.png")]
    out: PathBuf,
    /// FAST threshold of the FAST-9 and ORB panels
    #[arg(long, default_value_t = 20)]
    fast_threshold: i32,
    #[command(flatten)]
    common: Common,
}

/// One labelled panel.
struct Panel {
    label: String,
    image: RgbImage,
}

/// The edge map as an RGB panel: white edges on black.
fn edge_panel(edges: &Plane<u8>) -> RgbImage {
    RgbImage::from_fn(edges.width, edges.height, |x, y| {
        let v = if edges.at(x, y) != 0 { 255 } else { 0 };
        Rgb([v, v, v])
    })
}

/// Label text height for panels `width` pixels wide.
fn font_px(width: u32) -> u32 {
    (width / 26).clamp(11, 26)
}

/// Ring radius of the keypoint markers on an image `width` pixels wide.
fn marker_radius(width: u32) -> i64 {
    i64::from(width / 128).clamp(3, 8)
}

/// Where panel `i` (its label strip's top left corner) sits on the canvas.
fn origin(i: usize, (w, h): (u32, u32), strip: u32) -> (u32, u32) {
    let (col, row) = ((i % 2) as u32, (i / 2) as u32);
    (GAP + col * (w + GAP), GAP + row * (h + strip + GAP))
}

/// The panels on a two-by-two grid with a label strip above each and the
/// legend of the level colours below, as packed RGB.
fn compose(panels: &[Panel; 4]) -> Result<RgbImage, String> {
    let size = panels[0].image.dimensions();
    let (w, h) = size;
    let font = font_px(w);
    let strip = font * 8 / 5;
    let (cw, ch) = (2 * w + 3 * GAP, 3 * strip + 2 * h + 3 * GAP);
    let mut canvas = RgbImage::from_pixel(cw, ch, Rgb(BACKGROUND));
    for (i, p) in panels.iter().enumerate() {
        let (x0, y0) = origin(i, size, strip);
        image::imageops::replace(&mut canvas, &p.image, i64::from(x0), i64::from(y0 + strip));
    }
    if !plot::font_ready() {
        return Err("the bundled font data/fonts/DejaVuSans.ttf cannot be parsed".into());
    }
    let mut buf = canvas.into_raw();
    {
        let root = BitMapBackend::with_buffer(&mut buf, (cw, ch)).into_drawing_area();
        let style = |c: Rgb<u8>| (plot::FONT, font).into_font().color(&RGBColor(c.0[0], c.0[1], c.0[2]));
        let white = style(Rgb([255, 255, 255]));
        let indent = font as i32 / 3;
        let baseline = (strip as i32 - font as i32) / 2;
        for (i, p) in panels.iter().enumerate() {
            let (x0, y0) = origin(i, size, strip);
            root.draw(&Text::new(plot::text(&p.label), (x0 as i32 + indent, y0 as i32 + baseline), &white))
                .map_err(|e| e.to_string())?;
        }
        // the legend: "pyramid level" and the eight levels' numbers in their colours
        let y = origin(2, size, strip).1 as i32 + (strip + h) as i32 + baseline;
        let mut x = GAP as i32 + indent;
        let title = plot::text("keypoint colour = pyramid level:");
        root.draw(&Text::new(title.clone(), (x, y), &white)).map_err(|e| e.to_string())?;
        x += root.estimate_text_size(&title, &white).map_err(|e| e.to_string())?.0 as i32 + font as i32;
        for level in 0..8 {
            let s = style(super::draw::level_colour(level));
            root.draw(&Text::new(level.to_string(), (x, y), &s)).map_err(|e| e.to_string())?;
            x += 3 * font as i32 / 2;
        }
        root.present().map_err(|e| e.to_string())?;
    }
    RgbImage::from_raw(cw, ch, buf).ok_or_else(|| "picture buffer of the wrong size".to_string())
}

/// `img` as a PNG, compressed hard: the picture is meant to be committed.
fn png(img: &RgbImage) -> Result<Vec<u8>, String> {
    use image::ImageEncoder;
    use image::codecs::png::{CompressionType, FilterType, PngEncoder};
    let mut buf = Vec::new();
    PngEncoder::new_with_quality(&mut buf, CompressionType::Best, FilterType::Adaptive)
        .write_image(img.as_raw(), img.width(), img.height(), image::ExtendedColorType::Rgb8)
        .map_err(|e| e.to_string())?;
    Ok(buf)
}

/// The label of a keypoint panel.
fn keypoint_label(name: &str, kps: &[KeyPoint]) -> String {
    let levels = kps.iter().map(|k| k.octave).max().map_or(0, |l| l + 1);
    format!("{name}: {} keypoints, {levels} level{}", kps.len(), if levels == 1 { "" } else { "s" })
}

pub(super) fn run(a: CompareArgs) -> Result<bool, CliError> {
    a.common.pool()?.install(|| picture(&a))
}

/// Detects, draws and writes the picture, in the `--jobs` pool.
fn picture(a: &CompareArgs) -> Result<bool, CliError> {
    let mut cfg = a.common.config()?;
    if cfg.n_features == 0 {
        cfg.n_features = DEFAULT_BUDGET;
    }
    let budget = cfg.n_features;
    let img = crate::image::load_gray(&a.input)?;

    let det = a.common.detector(cfg.clone())?;
    let edges = det.edge_image(img.view())?;
    let edge_count = edges.data.iter().filter(|&&v| v != 0).count();
    let lfast = Features::lfast(det);
    let fast = Features::cpu(FrontEnd::Fast, cfg.clone(), a.fast_threshold, budget)?;
    let orb = Features::cpu(FrontEnd::Orb, cfg, a.fast_threshold, budget)?;

    let radius = marker_radius(img.width);
    let mut counts = Vec::new();
    let mut panel = |front: &Features, name: &str| -> Result<Panel, CliError> {
        let (kps, _) = front.detect_and_compute(&img)?;
        counts.push(format!("{} {}", front.kind(), kps.len()));
        Ok(Panel { label: keypoint_label(name, &kps), image: super::draw::markers(&img, &kps, radius) })
    };
    let panels = [
        Panel { label: format!("improved Canny edge map: {edge_count} edge pixels"), image: edge_panel(&edges) },
        panel(&lfast, "L-FAST")?,
        panel(&fast, &format!("FAST-9 (t = {})", a.fast_threshold))?,
        panel(&orb, "ORB")?,
    ];
    let draw_err = |reason| CliError::Draw { path: a.out.clone(), reason };
    let picture = compose(&panels).map_err(draw_err)?;
    let png = png(&picture).map_err(draw_err)?;
    if let Some(dir) = a.out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .map_err(|e| CliError::OutDir { path: dir.to_path_buf(), reason: e.to_string() })?;
    }
    crate::io::write_atomic(&a.out, &png)?;
    if !a.common.quiet {
        println!(
            "{}: {}x{}, budget {budget}: edges {edge_count} px; keypoints {}",
            a.out.display(),
            picture.width(),
            picture.height(),
            counts.join(", ")
        );
    }
    Ok(true)
}
