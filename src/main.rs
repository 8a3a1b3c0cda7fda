//! `lfast`: command-line front end. Argument parsing only; the work is in the library.

use clap::{Parser, Subcommand};
use lfast::{Config, Mode, cpu::CpuDetector};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Parser)]
#[command(name = "lfast", version, about = "L-FAST feature detector (improved Canny + L-FAST + ORB)")]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(clap::Args)]
struct Common {
    /// TOML file with detector parameters (see docs/algorithm.md)
    #[arg(long)]
    config: Option<PathBuf>,
    /// L-FAST mode: paper or branch
    #[arg(long)]
    mode: Option<Mode>,
    /// Keypoint cap over all levels (0 = none)
    #[arg(long)]
    n_features: Option<u32>,
    /// Pyramid levels
    #[arg(long)]
    n_levels: Option<u32>,
}

#[derive(Subcommand)]
enum Cmd {
    /// Detect keypoints and ORB descriptors; writes DIR/<image stem>.json
    Detect {
        image: PathBuf,
        #[arg(long)]
        out: PathBuf,
        #[command(flatten)]
        common: Common,
    },
    /// Write the improved Canny edge map as a PNG
    Edges {
        image: PathBuf,
        #[arg(short, long)]
        out: PathBuf,
        #[command(flatten)]
        common: Common,
    },
}

fn config(c: &Common) -> lfast::Result<Config> {
    let mut cfg = match &c.config {
        Some(p) => Config::load(p)?,
        None => Config::default(),
    };
    cfg.mode = c.mode.unwrap_or(cfg.mode);
    cfg.n_features = c.n_features.unwrap_or(cfg.n_features);
    cfg.n_levels = c.n_levels.unwrap_or(cfg.n_levels);
    cfg.validate()?;
    Ok(cfg)
}

fn run(cli: Cli) -> lfast::Result<()> {
    match cli.cmd {
        Cmd::Detect { image, out, common } => {
            let det = CpuDetector::new(config(&common)?)?;
            let img = lfast::image::load_gray(&image)?;
            let (kps, desc) = det.detect_and_compute(img.view(), None)?;
            std::fs::create_dir_all(&out).map_err(|source| lfast::Error::Io { path: out.clone(), source })?;
            let stem = image.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "image".into());
            let path = out.join(format!("{stem}.json"));
            let json = lfast::io::features_json(&image, img.width, img.height, &kps, &desc);
            lfast::io::write_atomic(&path, json.as_bytes())?;
            println!("{}: {} keypoints -> {}", image.display(), kps.len(), path.display());
        }
        Cmd::Edges { image, out, common } => {
            let det = CpuDetector::new(config(&common)?)?;
            let img = lfast::image::load_gray(&image)?;
            let edges = det.edge_image(img.view())?;
            write_png(&edges, &out)?;
            let n = edges.data.iter().filter(|&&v| v != 0).count();
            println!("{}: {n} edge pixels -> {}", image.display(), out.display());
        }
    }
    Ok(())
}

fn write_png(p: &lfast::Plane<u8>, out: &Path) -> lfast::Result<()> {
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|source| lfast::Error::Io { path: dir.into(), source })?;
    }
    lfast::image::save_gray(p, out)
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("lfast: {e}");
            ExitCode::FAILURE
        }
    }
}
