//! The `lfast` command line: `detect`, `edges`, `info`, `compare`, `eval`, `vo` and `ate`. `src/main.rs` only
//! calls [`main`]; everything else lives here so it can be tested and reused.
//!
//! Exit codes: 0 when every file was done (or skipped), 1 when at least one
//! input failed (the others are still processed), 2 when the run could not
//! start at all (bad arguments or config, no inputs, an unwritable output
//! directory, `--backend gpu` with no usable GPU adapter).

mod compare;
mod detect;
mod draw;
mod edges;
mod eval;
mod info;
mod inputs;
mod mcap_out;
mod recorded;
mod report;
mod vo;

use crate::config::{Config, Mode};
use clap::{Parser, Subcommand, ValueEnum};
use std::path::PathBuf;
use std::process::ExitCode;

/// Errors that stop a run before (or instead of) any per-file work.
#[derive(Debug, thiserror::Error)]
pub enum CliError {
    /// An error from the library (config, I/O).
    #[error(transparent)]
    Lib(#[from] crate::Error),
    /// The output directory cannot be created or written to.
    #[error("output directory {path}: {reason}")]
    OutDir {
        /// The directory.
        path: PathBuf,
        /// Why it cannot be used.
        reason: String,
    },
    /// A list file cannot be read, a glob is malformed, or nothing matched.
    #[error("{0}")]
    Inputs(String),
    /// Inconsistent options.
    #[error("{0}")]
    Usage(String),
    /// A picture (`lfast compare`) cannot be drawn.
    #[error("{path}: cannot draw the picture: {reason}")]
    Draw {
        /// The picture's path.
        path: PathBuf,
        /// Why.
        reason: String,
    },
}

#[derive(Parser)]
#[command(name = "lfast", version, about = "L-FAST feature detector (improved Canny + L-FAST + ORB)")]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

/// Where detection runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Backend {
    /// The GPU when an adapter opens, else the CPU (with a warning)
    Auto,
    /// The GPU, or exit 2 when no adapter opens
    Gpu,
    /// The CPU reference path.
    Cpu,
}

#[derive(clap::Args, Clone)]
struct Common {
    /// TOML file with detector parameters (see docs/algorithm.md); flags override it
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
    /// Pyramid scale between levels
    #[arg(long)]
    scale_factor: Option<f64>,
    /// Local-threshold spread alpha, in hundredths
    #[arg(long)]
    alpha_pct: Option<u32>,
    /// Backend: auto (a hardware GPU, or the adapter --adapter names; else the CPU), gpu (any
    /// adapter, software ones included) or cpu
    #[arg(long, value_enum, default_value_t = Backend::Auto)]
    backend: Backend,
    /// GPU adapter: a case-insensitive part of its name (default: $WGPU_ADAPTER_NAME, else the
    /// high-performance one); see `lfast info`
    #[arg(long, value_name = "NAME")]
    adapter: Option<String>,
    /// Worker threads (default: all cores)
    #[arg(long, short = 'j', value_name = "N")]
    jobs: Option<usize>,
    /// No progress bar or per-file lines; errors and the summary only
    #[arg(long, short = 'q')]
    quiet: bool,
}

#[derive(Subcommand)]
enum Cmd {
    /// Detect keypoints and descriptors in images, directories (recursive) or globs
    #[command(after_help = detect::AFTER_HELP)]
    Detect(detect::DetectArgs),
    /// Write the improved Canny edge map of each input as a PNG
    #[command(after_help = edges::AFTER_HELP)]
    Edges(edges::EdgesArgs),
    /// GPU adapters (the one chosen, its limits), the CPU fallback, CPU features
    Info {
        /// Choose the adapter as `--adapter` does for the other commands
        #[arg(long, value_name = "NAME")]
        adapter: Option<String>,
        /// Also print the GPU workspace of WxH frames (bytes per pixel, the largest buffer, the
        /// limits it needs); comma-separated or repeated
        #[arg(long, value_name = "WxH", value_delimiter = ',', value_parser = info::parse_size)]
        size: Vec<(u32, u32)>,
        /// Configuration file for --size (the default config otherwise)
        #[arg(long, value_name = "FILE")]
        config: Option<std::path::PathBuf>,
    },
    /// Evaluation suites: the paper's experiments and more, as CSV, plots and a report
    #[command(after_help = eval::AFTER_HELP)]
    Eval(eval::EvalArgs),
    /// Monocular visual odometry over a KITTI-format folder, with the ATE when poses exist
    #[command(after_help = vo::VO_AFTER_HELP)]
    Vo(vo::VoArgs),
    /// One picture: the edge map and the keypoints of L-FAST, FAST-9 and ORB at one budget
    #[command(after_help = compare::AFTER_HELP)]
    Compare(compare::CompareArgs),
    /// Absolute trajectory error of a KITTI-format estimate (Umeyama SE(3)/Sim(3), as evo_ape)
    Ate(vo::AteArgs),
}

impl Common {
    /// The detector configuration: the file, then the flags over it, validated.
    fn config(&self) -> Result<Config, CliError> {
        let mut cfg = match &self.config {
            Some(p) => Config::load(p)?,
            None => Config::default(),
        };
        cfg.mode = self.mode.unwrap_or(cfg.mode);
        cfg.n_features = self.n_features.unwrap_or(cfg.n_features);
        cfg.n_levels = self.n_levels.unwrap_or(cfg.n_levels);
        cfg.scale_factor = self.scale_factor.unwrap_or(cfg.scale_factor);
        cfg.alpha_pct = self.alpha_pct.unwrap_or(cfg.alpha_pct);
        cfg.validate()?;
        Ok(cfg)
    }

    /// Checks `--backend` and `--adapter`; the backend and the adapter options.
    fn backend(&self) -> Result<(crate::Backend, crate::gpu::GpuOptions), CliError> {
        let opts = crate::gpu::GpuOptions { adapter_name: self.adapter.clone(), ..Default::default() };
        match (self.backend, &self.adapter) {
            (Backend::Cpu, Some(_)) => {
                Err(CliError::Usage("--adapter needs --backend gpu or auto (--backend cpu has no adapters)".into()))
            }
            (Backend::Cpu, None) => Ok((crate::Backend::Cpu, opts)),
            (Backend::Gpu, _) => Ok((crate::Backend::Gpu, opts)),
            (Backend::Auto, _) => Ok((crate::Backend::Auto, opts)),
        }
    }

    /// The L-FAST detector on the chosen backend; in auto mode a missing GPU
    /// is a one-line note on stderr, not an error.
    fn detector(&self, cfg: Config) -> Result<crate::Detector, CliError> {
        let (backend, opts) = self.backend()?;
        let det = crate::Detector::with_gpu_options(cfg, backend, &opts)?;
        if backend == crate::Backend::Auto && det.backend_name() == "cpu" && !self.quiet {
            eprintln!("lfast: note: no hardware GPU adapter, running on the CPU (see `lfast info`)");
        }
        Ok(det)
    }

    /// A rayon pool with `--jobs` threads (all cores by default).
    fn pool(&self) -> Result<rayon::ThreadPool, CliError> {
        if self.jobs == Some(0) {
            return Err(CliError::Usage("--jobs must be at least 1".into()));
        }
        rayon::ThreadPoolBuilder::new()
            .num_threads(self.jobs.unwrap_or(0))
            .build()
            .map_err(|e| CliError::Usage(format!("cannot start {} worker threads: {e}", self.jobs.unwrap_or(0))))
    }
}

/// Runs the command line `args` (including the program name); returns the exit code.
pub fn run_from<I, T>(args: I) -> ExitCode
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    let cli = match Cli::try_parse_from(args) {
        Ok(c) => c,
        Err(e) => {
            let _ = e.print();
            return ExitCode::from(if e.use_stderr() { 2 } else { 0 });
        }
    };
    let r = match cli.cmd {
        Cmd::Detect(a) => detect::run(a),
        Cmd::Edges(a) => edges::run(a),
        Cmd::Info { adapter, size, config } => info::run(adapter, &size, config.as_deref()),
        Cmd::Eval(a) => eval::run(a),
        Cmd::Vo(a) => vo::run_vo(a),
        Cmd::Ate(a) => vo::run_ate(a),
        Cmd::Compare(a) => compare::run(a),
    };
    match r {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::from(1),
        Err(e) => {
            eprintln!("lfast: {e}");
            ExitCode::from(2)
        }
    }
}

/// The `lfast` binary's entry point: parses `std::env::args_os()` and runs.
pub fn main() -> ExitCode {
    run_from(std::env::args_os())
}
