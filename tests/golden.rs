//! Golden outputs of the CPU reference path on the CC0 images in tests/data:
//!
//! - `<name>.edges.png`: the improved Canny edge map (SPEC 1-7), default config;
//! - `<name>.canny.png`: the traditional Canny baseline (SPEC 12), default params;
//! - `<name>.branch.json`, `<name>.paper.json`: `detect_and_compute` keypoints and
//!   descriptors with the default config in Mode::Branch and Mode::Paper.
//!
//! Edge maps are compared byte for byte, keypoints field by field with exact f32
//! equality (the pipeline is deterministic) and descriptors bit for bit.
//!
//! Regenerate after an intended change of the output with
//! `LFAST_BLESS=1 cargo test --test golden` and review the diff of tests/data/golden.
//! On a mismatch the actual output is written under
//! `target/tmp/golden-actual/` for inspection.

mod common;

use lfast::baseline::canny::{CannyParams, canny};
use lfast::cpu::CpuDetector;
use lfast::{Config, Descriptor, KeyPoint, Mode, Plane};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

fn golden_dir() -> PathBuf {
    common::data("golden")
}

fn actual_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("golden-actual")
}

fn blessing() -> bool {
    std::env::var("LFAST_BLESS").is_ok_and(|v| v == "1")
}

fn missing(path: &Path) -> String {
    format!(
        "golden file {} is missing; create it with `LFAST_BLESS=1 cargo test --test golden` and review it",
        path.display()
    )
}

fn write_actual(file: &str, bytes: &[u8]) -> PathBuf {
    let dir = actual_dir();
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(file);
    std::fs::write(&p, bytes).unwrap();
    p
}

/// One keypoint and its descriptor, one JSON array per line in the golden file:
/// `[x, y, size, angle, response, octave, class_id, "descriptor hex"]` (the
/// header's `columns` says so too); the descriptor is 64 hex digits, byte 0
/// first, as `lfast::io::hex` writes it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct GoldenKp(f32, f32, f32, f32, f32, i32, i32, String);

const COLUMNS: &str = "x,y,size,angle,response,octave,class_id,descriptor";

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct GoldenFeatures {
    image: String,
    columns: String,
    mode: String,
    width: u32,
    height: u32,
    keypoints: Vec<GoldenKp>,
}

impl GoldenFeatures {
    fn new(image: &str, mode: Mode, img: &Plane<u8>, kps: &[KeyPoint], desc: &[Descriptor]) -> Self {
        assert_eq!(kps.len(), desc.len(), "{image}: one descriptor per keypoint");
        Self {
            image: image.into(),
            columns: COLUMNS.into(),
            mode: mode_name(mode).into(),
            width: img.width,
            height: img.height,
            keypoints: kps
                .iter()
                .zip(desc)
                .map(|(k, d)| {
                    GoldenKp(k.pt.x, k.pt.y, k.size, k.angle, k.response, k.octave, k.class_id, lfast::io::hex(d))
                })
                .collect(),
        }
    }

    /// Compact but diffable: the header on the first line, one keypoint per line.
    fn to_text(&self) -> String {
        let mut s = format!(
            "{{\"image\":{},\"columns\":{},\"mode\":{},\"width\":{},\"height\":{},\"keypoints\":[\n",
            serde_json::to_string(&self.image).unwrap(),
            serde_json::to_string(&self.columns).unwrap(),
            serde_json::to_string(&self.mode).unwrap(),
            self.width,
            self.height
        );
        for (i, k) in self.keypoints.iter().enumerate() {
            s.push_str(&serde_json::to_string(k).unwrap());
            s.push_str(if i + 1 < self.keypoints.len() { ",\n" } else { "\n" });
        }
        s.push_str("]}\n");
        s
    }
}

fn mode_name(m: Mode) -> &'static str {
    match m {
        Mode::Branch => "branch",
        Mode::Paper => "paper",
    }
}

/// Compares (or blesses) an 8-bit map with a golden PNG. Returns an error text on mismatch.
fn check_png(file: &str, got: &Plane<u8>) -> Result<(), String> {
    let path = golden_dir().join(file);
    if blessing() {
        std::fs::create_dir_all(golden_dir()).unwrap();
        lfast::image::save_gray(got, &path).unwrap();
        let n = got.data.iter().filter(|&&v| v != 0).count();
        println!("blessed {} ({}x{}, {n} edge pixels)", path.display(), got.width, got.height);
        return Ok(());
    }
    if !path.exists() {
        return Err(missing(&path));
    }
    let want = image::open(&path).map_err(|e| format!("{}: {e}", path.display()))?.to_luma8();
    if want.dimensions() != (got.width, got.height) {
        return Err(format!(
            "{file}: size {}x{} but golden is {}x{}",
            got.width,
            got.height,
            want.width(),
            want.height()
        ));
    }
    let w = got.width as usize;
    let diffs: Vec<(usize, usize, u8, u8)> = got
        .data
        .iter()
        .zip(want.as_raw())
        .enumerate()
        .filter(|(_, (g, e))| g != e)
        .map(|(i, (&g, &e))| (i % w, i / w, g, e))
        .collect();
    if diffs.is_empty() {
        return Ok(());
    }
    let actual = actual_dir().join(file);
    std::fs::create_dir_all(actual_dir()).unwrap();
    lfast::image::save_gray(got, &actual).unwrap();
    let gained = diffs.iter().filter(|d| d.2 != 0 && d.3 == 0).count();
    let lost = diffs.iter().filter(|d| d.2 == 0 && d.3 != 0).count();
    let first: Vec<String> = diffs.iter().take(8).map(|&(x, y, g, e)| format!("({x},{y}) got {g} want {e}")).collect();
    Err(format!(
        "{file}: {} of {} pixels differ ({gained} new edge pixels, {lost} lost); first: {}; actual written to {}",
        diffs.len(),
        got.data.len(),
        first.join(", "),
        actual.display()
    ))
}

fn check_json(file: &str, got: &GoldenFeatures) -> Result<(), String> {
    let path = golden_dir().join(file);
    let text = got.to_text();
    // The text must give back exactly the values it was made from, or exact
    // comparison against it would be meaningless.
    let reparsed: GoldenFeatures = serde_json::from_str(&text).unwrap();
    assert_eq!(&reparsed, got, "{file}: golden JSON does not round-trip f32 values exactly");
    if blessing() {
        std::fs::create_dir_all(golden_dir()).unwrap();
        std::fs::write(&path, &text).unwrap();
        println!("blessed {} ({} keypoints, {} bytes)", path.display(), got.keypoints.len(), text.len());
        return Ok(());
    }
    if !path.exists() {
        return Err(missing(&path));
    }
    let want_text = std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    let want: GoldenFeatures = serde_json::from_str(&want_text).map_err(|e| format!("{}: {e}", path.display()))?;
    if &want == got {
        return Ok(());
    }
    let actual = write_actual(file, text.as_bytes());
    let mut msg = format!("{file}: ");
    if (want.width, want.height) != (got.width, got.height) {
        msg += &format!("image size {}x{} vs golden {}x{}; ", got.width, got.height, want.width, want.height);
    }
    if want.keypoints.len() != got.keypoints.len() {
        msg += &format!("{} keypoints vs golden {}; ", got.keypoints.len(), want.keypoints.len());
    }
    let differing = got.keypoints.iter().zip(&want.keypoints).filter(|(g, e)| g != e).count();
    if let Some(i) = got.keypoints.iter().zip(&want.keypoints).position(|(g, e)| g != e) {
        let (g, e) = (&got.keypoints[i], &want.keypoints[i]);
        let strip = |k: &GoldenKp| GoldenKp(k.0, k.1, k.2, k.3, k.4, k.5, k.6, String::new());
        let what = if strip(g) == strip(e) {
            let bits = hamming_hex(&g.7, &e.7);
            format!("only the descriptor differs ({bits} bits)")
        } else {
            let names: Vec<&str> = COLUMNS.split(',').collect();
            let (gv, ev) = (serde_json::to_value(g).unwrap(), serde_json::to_value(e).unwrap());
            let fields: Vec<&str> = (0..7).filter(|&i| gv[i] != ev[i]).map(|i| names[i]).collect();
            format!("keypoint fields differ: {}", fields.join(", "))
        };
        msg += &format!(
            "{differing} of the common {} entries differ; first at index {i}: {what}\n  got    {}\n  golden {}\n",
            got.keypoints.len().min(want.keypoints.len()),
            serde_json::to_string(g).unwrap(),
            serde_json::to_string(e).unwrap()
        );
    }
    msg += &format!("actual written to {}", actual.display());
    Err(msg)
}

fn hamming_hex(a: &str, b: &str) -> u32 {
    let dec = |s: &str| -> Vec<u8> {
        (0..s.len() / 2).map(|i| u8::from_str_radix(&s[2 * i..2 * i + 2], 16).unwrap_or(0)).collect()
    };
    dec(a).iter().zip(dec(b)).map(|(x, y)| (x ^ y).count_ones()).sum()
}

/// Runs every golden check for one image of tests/data and reports all failures at once.
fn golden(name: &str) {
    let path = common::data(&format!("{name}.png"));
    let img = lfast::image::load_gray(&path).unwrap_or_else(|e| panic!("{e}"));
    let mut failures = Vec::new();

    let det = CpuDetector::new(Config::default()).unwrap();
    let em = det.edges(img.view()).unwrap();
    assert!(em.edges.data.iter().all(|&v| v == 0 || v == 255), "{name}: edge map is not binary");
    failures.extend(check_png(&format!("{name}.edges.png"), &em.edges).err());

    let c = canny(&img, &CannyParams::default());
    assert!(c.data.iter().all(|&v| v == 0 || v == 255), "{name}: Canny map is not binary");
    failures.extend(check_png(&format!("{name}.canny.png"), &c).err());

    // the default config in branch mode, and the paper's pipeline literally (which never moves)
    for (mode, cfg) in
        [(Mode::Branch, Config { mode: Mode::Branch, ..Config::default() }), (Mode::Paper, Config::paper())]
    {
        let det = CpuDetector::new(cfg).unwrap();
        let (kps, desc) = det.detect_and_compute(img.view(), None).unwrap();
        let got = GoldenFeatures::new(&format!("{name}.png"), mode, &img, &kps, &desc);
        failures.extend(check_json(&format!("{name}.{}.json", mode_name(mode)), &got).err());
    }

    if !failures.is_empty() {
        panic!(
            "{name}: {} golden mismatch(es):\n{}\n(if the change is intended: LFAST_BLESS=1 cargo test --test golden)",
            failures.len(),
            failures.join("\n")
        );
    }
}

#[test]
fn golden_camera() {
    golden("camera_cc0_v0.18plus");
}

#[test]
fn golden_coins() {
    golden("coins");
}

#[test]
fn golden_text() {
    golden("text");
}

#[test]
fn golden_chessboard() {
    golden("chessboard_GRAY");
}

/// RGB input: exercises the SPEC 0 colour conversion on the way in.
#[test]
fn golden_astronaut_rgb() {
    golden("astronaut_256");
}

/// Every golden file in tests/data/golden belongs to an image this test knows,
/// so a renamed image cannot leave a stale golden file behind unnoticed.
#[test]
fn no_stray_golden_files() {
    if blessing() {
        return;
    }
    let names = ["camera_cc0_v0.18plus", "coins", "text", "chessboard_GRAY", "astronaut_256"];
    let kinds = ["edges.png", "canny.png", "branch.json", "paper.json"];
    let dir = golden_dir();
    let entries = std::fs::read_dir(&dir).unwrap_or_else(|e| panic!("{}: {e}; {}", dir.display(), missing(&dir)));
    let mut n = 0;
    for e in entries {
        let f = e.unwrap().file_name().to_string_lossy().into_owned();
        let known = names.iter().any(|nm| kinds.iter().any(|k| f == format!("{nm}.{k}")));
        assert!(known, "unexpected file {f} in {}", dir.display());
        n += 1;
    }
    assert_eq!(n, names.len() * kinds.len(), "golden files missing in {}", dir.display());
}
