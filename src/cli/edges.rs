//! `lfast edges`: the improved Canny edge map of many inputs, with `--debug`
//! intermediates.

use super::inputs::{self, Input, Problem};
use super::report::{self, Reporter};
use super::{CliError, Common};
use crate::cpu::classify;
use image::ExtendedColorType;
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::sync_channel;

pub(super) const AFTER_HELP: &str = "\
Outputs, for an input IMG (or DIR/sub/IMG found under a directory DIR, which keeps sub/):
  OUT/IMG.edges.png       the edge map E (255 = edge)
  with --debug also:
  OUT/IMG.denoised.png    the flagged-median output D
  OUT/IMG.magnitude.png   the gradient magnitude M, scaled so its maximum is 255
  OUT/IMG.classes.png     SPEC 6 classes: strong red, weak-strong yellow, weak green,
                          weak-weak blue, none black
  OUT/IMG.threshold.png   the local threshold TL1 of each pixel's window
With one input file and --out FILE.png (not an existing directory), the edge map is
written to FILE.png itself. A full disk stops the batch at the first failed write.";

#[derive(clap::Args)]
pub(super) struct EdgesArgs {
    /// Images, directories (searched recursively for image files) or glob patterns
    inputs: Vec<PathBuf>,
    /// Also read inputs from FILE, one per line (`-` = standard input)
    #[arg(long, value_name = "FILE")]
    from_list: Option<PathBuf>,
    /// Output directory (or, for one input, a .png file)
    #[arg(long, short = 'o', value_name = "DIR")]
    out: PathBuf,
    /// Also write the intermediates: denoised, magnitude, class map, local threshold
    #[arg(long)]
    debug: bool,
    #[command(flatten)]
    rec: super::recorded::RecordingArgs,
    #[command(flatten)]
    common: Common,
}

fn is_png_name(p: &Path) -> bool {
    p.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("png"))
}

fn with_suffix(base: &Path, suffix: &str) -> PathBuf {
    let mut s = base.as_os_str().to_owned();
    s.push(suffix);
    PathBuf::from(s)
}

/// Class colours of `--debug`'s class map.
fn class_colour(c: u8) -> [u8; 3] {
    match c {
        classify::STRONG => [255, 0, 0],
        classify::WEAK_STRONG => [255, 255, 0],
        classify::WEAK => [0, 255, 0],
        classify::WEAK_WEAK => [0, 96, 255],
        _ => [0, 0, 0],
    }
}

/// Files to write, (path, bytes), and the edge pixel count.
type Processed = (Vec<(PathBuf, Vec<u8>)>, u64);

fn process(det: &crate::Detector, input: &Input, edges_path: &Path, debug: bool) -> crate::Result<Processed> {
    let img = crate::image::load_gray(&input.path)?;
    images(det, &img, edges_path, debug)
}

/// The edge map of `img` (and with `debug` its intermediates) as PNG files
/// named after `edges_path` (`x.edges.png`, `x.denoised.png`, ...).
fn images(det: &crate::Detector, img: &crate::Plane<u8>, edges_path: &Path, debug: bool) -> crate::Result<Processed> {
    let png = super::draw::png;
    if !debug {
        let e = det.edge_image(img.view())?;
        let n = e.data.iter().filter(|&&v| v != 0).count() as u64;
        return Ok((vec![(edges_path.to_path_buf(), png(&e.data, e.width, e.height, ExtendedColorType::L8)?)], n));
    }
    // the intermediates come from the CPU's staged path (equal to the GPU's, tested)
    let em = crate::cpu::edge_map(img, det.config());
    let (w, h) = (em.edges.width, em.edges.height);
    let n = em.edges.data.iter().filter(|&&v| v != 0).count() as u64;
    let base = edges_path.with_file_name(
        edges_path.file_name().and_then(|n| n.to_str()).and_then(|n| n.strip_suffix(".edges.png")).unwrap_or("debug"),
    );
    let m = em.magnitude();
    let max = m.data.iter().copied().max().unwrap_or(0).max(1) as u32;
    let mag: Vec<u8> = m.data.iter().map(|&v| (v as u32 * 255 / max) as u8).collect();
    let classes: Vec<u8> = em.classes.data.iter().flat_map(|&c| class_colour(c)).collect();
    let tl = em.local_threshold_map(det.config().alpha_pct);
    Ok((
        vec![
            (edges_path.to_path_buf(), png(&em.edges.data, w, h, ExtendedColorType::L8)?),
            (with_suffix(&base, ".denoised.png"), png(&em.denoised.data, w, h, ExtendedColorType::L8)?),
            (with_suffix(&base, ".magnitude.png"), png(&mag, w, h, ExtendedColorType::L8)?),
            (with_suffix(&base, ".classes.png"), png(&classes, w, h, ExtendedColorType::Rgb8)?),
            (with_suffix(&base, ".threshold.png"), png(&tl.data, tl.width, tl.height, ExtendedColorType::L8)?),
        ],
        n,
    ))
}

fn write(files: &[(PathBuf, Vec<u8>)]) -> crate::Result<()> {
    for (p, bytes) in files {
        if let Some(dir) = p.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|source| crate::Error::Io { path: dir.to_path_buf(), source })?;
        }
        crate::io::write_atomic(p, bytes)?;
    }
    Ok(())
}

/// Runs `lfast edges`; `Ok(false)` when some file failed.
pub(super) fn run(a: EdgesArgs) -> Result<bool, CliError> {
    let det = a.common.detector(a.common.config()?)?;
    let backend = det.backend_name();
    let pool = a.common.pool()?;
    // One input file and --out FILE.png: write there (the single-image form).
    let single = a.inputs.len() == 1
        && a.from_list.is_none()
        && crate::recording::format_of(&a.inputs[0]).is_none()
        && !a.inputs[0].is_dir()
        && (a.inputs[0].exists() || !a.inputs[0].to_string_lossy().contains(['*', '?', '[']))
        && is_png_name(&a.out)
        && !a.out.is_dir();
    let out_dir = if single {
        a.out.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new(".")).to_path_buf()
    } else {
        a.out.clone()
    };
    report::prepare_out_dir(&out_dir)?;
    if !single {
        let all = inputs::collect(&a.inputs, a.from_list.as_deref(), &out_dir)?;
        let (recordings, _) = super::recorded::split(all, &a.rec)?;
        if !recordings.is_empty() {
            return run_recordings(&a, &det, &pool, &recordings);
        }
    }
    let jobs: Vec<(Input, PathBuf)> = if single {
        let inp = inputs::collect(&a.inputs, None, &out_dir)?.remove(0);
        vec![(inp, a.out.clone())]
    } else {
        inputs::collect(&a.inputs, a.from_list.as_deref(), &out_dir)?
            .into_iter()
            .map(|i| {
                let p = with_suffix(&out_dir.join(&i.rel), ".edges.png");
                (i, p)
            })
            .collect()
    };
    report::log_warnings(a.common.quiet);
    report::catch_interrupts();
    let mut rep = Reporter::new(jobs.iter().filter(|(i, _)| i.is_file()).count() as u64, a.common.quiet);
    let threads = pool.current_num_threads();
    // set when the disk is full: no file is started after it
    let stop = AtomicBool::new(false);
    std::thread::scope(|s| {
        let (tx, rx) = sync_channel(2 * threads.max(1));
        let (jobs, det, debug, stop) = (&jobs, &det, a.debug, &stop);
        s.spawn(move || {
            pool.install(|| {
                jobs.par_iter().enumerate().for_each_with(tx, |tx, (i, (input, path))| {
                    if report::interrupted() || stop.load(Ordering::Relaxed) {
                        return;
                    }
                    let r = match &input.problem {
                        Some(p) => Err(p.clone()),
                        None => process(det, input, path, debug).map_err(|e| Problem::File(report::reason(&e))),
                    };
                    let _ = tx.send((i, r));
                })
            })
        });
        for (i, r) in rx {
            // after SIGINT/SIGTERM: the files written so far are complete; stop
            if report::interrupted() {
                break;
            }
            let (input, path) = &jobs[i];
            match r {
                Err(p) => rep.problem(&input.path, &p),
                Ok((files, n)) => match write(&files) {
                    Ok(()) => {
                        rep.done(n, || format!("{}: {n} edge pixels -> {}", input.path.display(), path.display()))
                    }
                    // no later write can succeed: stop at once, the files written stay
                    Err(e) if crate::io::is_disk_full(&e) => {
                        stop.store(true, Ordering::Relaxed);
                        rep.stopped(&report::disk_full(&e, rep.finished(), jobs.len()));
                        break;
                    }
                    Err(e) => rep.failed(&input.path, &e.to_string()),
                },
            }
        }
    });
    let ok = rep.finish("edge pixels", &format!("backend {backend}, {threads} threads"));
    report::exit_if_interrupted();
    Ok(ok)
}

/// `lfast edges` over recordings: `OUT/REC/INDEX_TIME.edges.png` per frame.
struct EdgesWork<'a> {
    det: &'a crate::Detector,
    debug: bool,
}

impl super::recorded::Work for EdgesWork<'_> {
    /// The PNG files by suffix, and the edge pixel count.
    type Out = Processed;
    fn outputs(&self, base: &Path) -> Vec<PathBuf> {
        vec![with_suffix(base, ".edges.png")]
    }
    fn process(&self, f: crate::recording::Decoded) -> crate::Result<Processed> {
        // named by suffix here; the sink puts them beside the frame's base
        images(self.det, &f.image, Path::new(".edges.png"), self.debug)
    }
    fn noun(&self) -> &'static str {
        "edge pixels"
    }
}

struct EdgesSink;

impl super::recorded::Sink<Processed> for EdgesSink {
    fn recording_exists(&self, _: &Path) -> bool {
        false
    }
    fn per_frame_skip(&self) -> bool {
        false
    }
    fn start(&mut self, _: &crate::recording::Recording, _: &Path) -> crate::Result<()> {
        Ok(())
    }
    fn frame(&mut self, f: &super::recorded::Done<'_, Processed>) -> crate::Result<u64> {
        let edges = &f.outputs[0];
        let name = edges.file_name().and_then(|n| n.to_str()).unwrap_or_default();
        let base = edges.with_file_name(name.strip_suffix(".edges.png").unwrap_or(name));
        let files: Vec<(PathBuf, Vec<u8>)> = f
            .out
            .0
            .iter()
            .map(|(suffix, bytes)| (with_suffix(&base, &suffix.to_string_lossy()), bytes.clone()))
            .collect();
        write(&files)?;
        Ok(f.out.1)
    }
    fn finish(&mut self) -> crate::Result<()> {
        Ok(())
    }
}

fn run_recordings(
    a: &EdgesArgs,
    det: &crate::Detector,
    pool: &rayon::ThreadPool,
    recordings: &[Input],
) -> Result<bool, CliError> {
    report::log_warnings(a.common.quiet);
    report::catch_interrupts();
    let mut rep = Reporter::counting(0, a.common.quiet, "frames", "messages");
    let stop = AtomicBool::new(false);
    let work = EdgesWork { det, debug: a.debug };
    let sel = a.rec.selection();
    super::recorded::run(recordings, &sel, &a.out, false, pool, &work, &mut EdgesSink, &mut rep, &stop);
    let tail = format!("backend {}, {} threads", det.backend_name(), pool.current_num_threads());
    let ok = rep.finish("edge pixels", &tail);
    report::exit_if_interrupted();
    Ok(ok)
}
