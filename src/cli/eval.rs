//! `lfast eval`: runs the evaluation suites of [`crate::eval`] and writes
//! their CSV files, plots and report.

use super::CliError;
use crate::eval::{self, EvalError, Options, Suite};
use clap::ValueEnum;
use std::path::{Path, PathBuf};
use std::time::Instant;

pub(super) const AFTER_HELP: &str = "\
Suites (docs/evaluation.md defines every metric):
  noise          PSNR/SNR of the flagged median vs a Gaussian, 5% salt-and-pepper (paper Table 1)
  continuity     edge pixels A, 4-/8-connected components B/C of Canny vs improved Canny (Table 2)
  kitti          keypoints and time per frame: FAST-9, ORB, L-FAST variants (Figs 9-10)
  repeatability  repeatability and matching score on Oxford-format scenes, also at equal budgets
  illumination   edge pixels and keypoints surviving gamma, shadow and gain changes
  vo             visual odometry with each detector: trajectory error (lfast::vo)
  all            every suite, then the choice of the L-FAST defaults

Data (default under $LFAST_TEST_DATA, else ../shared/data): noise and continuity read a folder of images
(standard/); kitti and vo a KITTI folder (image_0/*.png, calib.txt, poses.txt) or a folder of
sequences (kitti/); repeatability a scene folder (img1..imgN + H1to2p..H1toNp) or a folder of
scenes (homography/). --data replaces that folder; for illumination and all it is a root
holding standard/, kitti/ and homography/.

Writes OUT/<suite>.csv, OUT/*.png, OUT/<suite>.md and .json, and rebuilds OUT/report.md from
every suite present in OUT. OUT/images/ holds the edge maps of the continuity suite (derived
from the input images: do not commit them). --doc FILE also writes the evaluation page:
  lfast eval all --out docs/eval_report --doc docs/evaluation.md";

/// Which suite to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub(super) enum SuiteArg {
    /// Paper Table 1
    Noise,
    /// Paper Table 2
    Continuity,
    /// Paper Figs 9-10
    Kitti,
    /// Mikolajczyk repeatability and matching score
    Repeatability,
    /// Brightness changes
    Illumination,
    /// Visual odometry
    Vo,
    /// Every suite
    All,
}

#[derive(clap::Args)]
pub(super) struct EvalArgs {
    /// The suite
    #[arg(value_enum)]
    suite: SuiteArg,
    /// Output folder (created when missing)
    #[arg(long, short = 'o', value_name = "DIR")]
    out: PathBuf,
    /// The suite's data folder (illumination, all: a root with standard/, kitti/, homography/)
    #[arg(long, value_name = "DIR")]
    data: Option<PathBuf>,
    /// Reduced run for CI: 3 KITTI frames (2 for illumination, 5 for vo), the first pair of
    /// each scene, one timing repeat
    #[arg(long)]
    quick: bool,
    /// Seed of the salt-and-pepper noise
    #[arg(long, default_value_t = eval::DEFAULT_SEED)]
    seed: u64,
    /// Timing repeats per frame (the median is reported)
    #[arg(long, default_value_t = 3, value_name = "N")]
    repeats: usize,
    /// Also write the evaluation page (definitions, headline numbers, choice of defaults) to FILE
    #[arg(long, value_name = "FILE")]
    doc: Option<PathBuf>,
    /// Worker threads (default: all cores); timings depend on it
    #[arg(long, short = 'j', value_name = "N")]
    jobs: Option<usize>,
}

fn cli_err(e: EvalError) -> CliError {
    match e {
        EvalError::Lib(e) => CliError::Lib(e),
        EvalError::Output { path, reason } | EvalError::Plot { path, reason } => CliError::OutDir { path, reason },
        e @ (EvalError::Data { .. } | EvalError::Mismatch(_)) => CliError::Inputs(e.to_string()),
    }
}

/// The options for `a`: default folders, with `--data` replacing the suite's.
fn options(a: &EvalArgs) -> Options {
    let root_default = eval::default_data();
    let rooted = matches!(a.suite, SuiteArg::All | SuiteArg::Illumination);
    let mut o = match (&a.data, rooted) {
        (Some(root), true) => {
            let mut o = Options::with_root(&a.out, root);
            o.kitti = root.join("kitti");
            o
        }
        _ => Options::with_root(&a.out, &root_default),
    };
    if let (Some(d), false) = (&a.data, rooted) {
        match a.suite {
            SuiteArg::Noise | SuiteArg::Continuity => o.standard = d.clone(),
            SuiteArg::Kitti | SuiteArg::Vo => o.kitti = d.clone(),
            SuiteArg::Repeatability => o.homography = d.clone(),
            SuiteArg::Illumination | SuiteArg::All => {}
        }
    }
    o.quick = a.quick;
    o.seed = a.seed;
    o.repeats = a.repeats;
    o
}

fn suites(s: SuiteArg) -> Vec<Suite> {
    match s {
        SuiteArg::Noise => vec![Suite::Noise],
        SuiteArg::Continuity => vec![Suite::Continuity],
        SuiteArg::Kitti => vec![Suite::Kitti],
        SuiteArg::Repeatability => vec![Suite::Repeatability],
        SuiteArg::Illumination => vec![Suite::Illumination],
        SuiteArg::Vo => vec![Suite::Vo],
        SuiteArg::All => Suite::ALL.to_vec(),
    }
}

/// Runs `lfast eval`.
pub(super) fn run(a: EvalArgs) -> Result<bool, CliError> {
    if a.jobs == Some(0) {
        return Err(CliError::Usage("--jobs must be at least 1".into()));
    }
    if a.repeats == 0 {
        return Err(CliError::Usage("--repeats must be at least 1".into()));
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.jobs.unwrap_or(0))
        .build()
        .map_err(|e| CliError::Usage(format!("cannot start the worker threads: {e}")))?;
    let opts = options(&a);
    pool.install(|| -> Result<(), CliError> {
        eval::create_dir(&opts.out).map_err(cli_err)?;
        let start = Instant::now();
        for s in suites(a.suite) {
            let t = Instant::now();
            eval::run_suite(s, &opts).map_err(cli_err)?;
            println!(
                "eval {}: {:.1} s -> {}",
                s.name(),
                t.elapsed().as_secs_f64(),
                opts.out.join(format!("{}.md", s.name())).display()
            );
        }
        eval::report::assemble(&opts.out).map_err(cli_err)?;
        println!("report: {} ({:.1} s)", opts.out.join("report.md").display(), start.elapsed().as_secs_f64());
        if let Some(doc) = &a.doc {
            if let Some(dir) = doc.parent().filter(|d| !d.as_os_str().is_empty()) {
                eval::create_dir(dir).map_err(cli_err)?;
            }
            eval::report::write_doc(&opts.out, doc).map_err(cli_err)?;
            println!("doc: {}", Path::new(doc).display());
        }
        Ok(())
    })?;
    Ok(true)
}
