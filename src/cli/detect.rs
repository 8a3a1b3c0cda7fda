//! `lfast detect`: a pipelined batch over many images. Decoder threads read
//! and decode files, the detector works on frames in a rayon pool (`--jobs`),
//! and the calling thread encodes and writes the outputs, all linked by
//! bounded channels so that the stages overlap and memory stays bounded.

mod recording;

use super::inputs::{self, Input, Shard};
use super::report::{self, Reporter};
use super::{CliError, Common};
use crate::baseline::orb::OrbParams;
use crate::config::Config;
use crate::frontend::{Features, FrontEnd};
use crate::image::Plane;
use crate::{Descriptor, KeyPoint};
use clap::ValueEnum;
use rayon::iter::{ParallelBridge, ParallelIterator};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc::sync_channel;

pub(super) const AFTER_HELP: &str = "\
Outputs, for an input IMG (or DIR/sub/IMG found under a directory DIR, which keeps sub/):
  json  OUT/IMG.json                 OpenCV KeyPoint field names, descriptors as hex
  csv   OUT/IMG.csv                  x,y,size,angle,response,octave,class_id,descriptor
  npy   OUT/IMG.keypoints.npy        float32 Nx7 (x, y, size, angle, response, octave, class_id)
        OUT/IMG.descriptors.npy      uint8 Nx32
  yaml  OUT/IMG.yaml                 OpenCV FileStorage: keypoints, descriptors (CV_8U matrix)
  --draw OUT/IMG.draw.png            keypoints drawn as circles of their size with orientation
Outputs are written atomically (temporary file + rename). --shard K/N takes files
i % N == K of the sorted input list, K 0-based (0/4, 1/4, 2/4, 3/4).
Directories are searched following symbolic links; a link that loops back is
reported and not followed, and a file reachable twice is processed once.
A full disk stops the batch at the first failed write; free some space and
rerun with --skip-existing to finish.
Exit code: 0 all done or skipped, 1 some files failed, 2 the run could not start.";

/// Output format.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub(super) enum Format {
    /// IMG.json: the features with OpenCV KeyPoint field names
    Json,
    /// IMG.csv: one keypoint per row
    Csv,
    /// IMG.keypoints.npy (float32 Nx7) and IMG.descriptors.npy (uint8 Nx32)
    Npy,
    /// IMG.yaml: OpenCV FileStorage
    Yaml,
    /// Recordings: REC.lfast.mcap, keypoints as foxglove.ImageAnnotations and lfast.Features
    Mcap,
}

#[derive(clap::Args)]
pub(super) struct DetectArgs {
    /// Images, directories (searched recursively for image files) or glob patterns
    inputs: Vec<PathBuf>,
    /// Also read inputs from FILE, one per line (`-` = standard input)
    #[arg(long, value_name = "FILE")]
    from_list: Option<PathBuf>,
    /// Output directory (created if missing)
    #[arg(long, short = 'o', value_name = "DIR")]
    out: PathBuf,
    /// Output formats, comma-separated or repeated
    #[arg(long, value_enum, value_delimiter = ',', default_values_t = [Format::Json])]
    format: Vec<Format>,
    /// Also write IMG.draw.png, the keypoints drawn on the image
    #[arg(long)]
    draw: bool,
    /// Skip inputs whose outputs all exist already
    #[arg(long)]
    skip_existing: bool,
    /// Process only shard K of N (K 0-based): files i % N == K of the sorted list
    #[arg(long, value_name = "K/N")]
    shard: Option<Shard>,
    /// With --format mcap: copy the image topic (MCAP) or the frames (video) into the file
    #[arg(long)]
    include_images: bool,
    #[command(flatten)]
    rec: super::recorded::RecordingArgs,
    /// Detector
    #[arg(long, value_enum, default_value_t = FrontEnd::Lfast)]
    detector: FrontEnd,
    /// FAST threshold of --detector fast and orb (orbslam has its own: 20, retry 7)
    #[arg(long, default_value_t = 20)]
    fast_threshold: i32,
    #[command(flatten)]
    common: Common,
}

/// The front end of `--detector`: L-FAST on the chosen backend, the
/// baselines on the CPU, all from the one config ([`crate::frontend`]).
fn front_end(kind: FrontEnd, cfg: Config, fast_threshold: i32, common: &Common) -> Result<Features, CliError> {
    if kind == FrontEnd::Lfast {
        return Ok(Features::lfast(common.detector(cfg)?));
    }
    if common.backend()?.0 == crate::Backend::Gpu {
        return Err(CliError::Usage(format!(
            "--detector {kind} runs on the CPU only (a baseline for comparisons); use --backend cpu or auto"
        )));
    }
    Ok(Features::cpu(kind, cfg, fast_threshold, OrbParams::default().n_features)?)
}

/// One image's (or frame's) features.
pub(super) struct Detected {
    pub width: u32,
    pub height: u32,
    pub kps: Vec<KeyPoint>,
    pub desc: Vec<Descriptor>,
    /// The image, for --draw (and --include-images of a video).
    pub img: Option<Plane<u8>>,
}

/// What one file has become so far, passed between the stages.
enum Stage {
    Skip,
    Failed(String),
    Problem(inputs::Problem),
    Decoded(Plane<u8>),
    Detected(Detected),
}

/// `base` + `suffix`, e.g. `out/sub/img` + `.json`.
fn with_suffix(base: &Path, suffix: &str) -> PathBuf {
    let mut s = base.as_os_str().to_owned();
    s.push(suffix);
    PathBuf::from(s)
}

/// The output files of one input (or frame), in the order they are written.
pub(super) fn outputs(base: &Path, formats: &[Format], draw: bool) -> Vec<PathBuf> {
    let mut v = Vec::new();
    for f in formats {
        match f {
            Format::Json => v.push(with_suffix(base, ".json")),
            Format::Csv => v.push(with_suffix(base, ".csv")),
            Format::Npy => {
                v.push(with_suffix(base, ".keypoints.npy"));
                v.push(with_suffix(base, ".descriptors.npy"));
            }
            Format::Yaml => v.push(with_suffix(base, ".yaml")),
            Format::Mcap => {}
        }
    }
    if draw {
        v.push(with_suffix(base, ".draw.png"));
    }
    v
}

struct Job<'a> {
    input: &'a Input,
    outputs: Vec<PathBuf>,
}

/// Writes one output file: [`crate::io::write_atomic`] in the binary, a writer
/// that fails on cue in tests.
pub(super) type Write<'a> = &'a dyn Fn(&Path, &[u8]) -> crate::Result<()>;

thread_local! {
    /// The JSON text of the writer thread's frames, one buffer for all (a
    /// 3840x2160 frame's is ~9 MB, paged in anew when allocated per frame).
    static JSON: std::cell::RefCell<String> = const { std::cell::RefCell::new(String::new()) };
}

/// Encodes and writes every per-file output of `image` (a frame of it when
/// `frame` says), through `write`.
pub(super) fn write_all(
    image: &Path,
    frame: Option<&crate::io::FrameInfo>,
    outputs: &[PathBuf],
    formats: &[Format],
    draw: bool,
    d: &Detected,
    write: Write,
) -> crate::Result<()> {
    let Detected { width, height, kps, desc, img } = d;
    let mut outs = outputs.iter();
    let mut put = |bytes: &[u8]| -> crate::Result<()> {
        let p = outs.next().expect("one output path per encoded file");
        if let Some(dir) = p.parent() {
            std::fs::create_dir_all(dir).map_err(|source| crate::Error::Io { path: dir.to_path_buf(), source })?;
        }
        write(p, bytes)
    };
    for f in formats {
        match f {
            Format::Json => JSON.with_borrow_mut(|json| {
                json.clear();
                crate::io::frame_features_json_into(json, image, frame, *width, *height, kps, desc);
                put(json.as_bytes())
            })?,
            Format::Csv => put(crate::io::features_csv(kps, desc).as_bytes())?,
            Format::Npy => {
                put(&crate::io::keypoints_npy(kps))?;
                put(&crate::io::descriptors_npy(desc))?;
            }
            Format::Yaml => put(crate::io::features_yaml(kps, desc).as_bytes())?,
            Format::Mcap => {}
        }
    }
    if draw && let Some(img) = img {
        put(&super::draw::overlay_png(img, kps)?)?;
    }
    Ok(())
}

/// Batches whose first frame has more pixels than this (1920x1080's) detect
/// at most `workers / 2` frames at once ([`frames_in_flight`]).
const LARGE_FRAME: u64 = 1920 * 1080;

/// How many frames a batch of `w x h` frames (its first frame's size) has in
/// detection at once in the pool of `workers` threads (the workers left over
/// take bands of the frames in hand: every stage splits into bands and
/// levels). Up to 1920x1080, one frame per worker: each worker's bands stay
/// in its cache (51 KITTI frames, two workers: 0.22-0.23 s
/// against 0.23-0.24 s one at a time). Larger frames, half as many frames as
/// workers (at least one): their planes outgrow the caches, and two frames'
/// sets of planes in flight cost more than the bands' hand-over (four
/// 3840x2160 JPEGs on two cores: 0.36-0.38 s, 694 ms of CPU and 72k page
/// faults one per worker; 0.35-0.36 s, 655 ms and 50k one at a time;
/// 1920x1080 ties).
fn frames_in_flight(w: u32, h: u32, workers: usize) -> usize {
    if w as u64 * h as u64 > LARGE_FRAME { (workers / 2).max(1) } else { workers.max(1) }
}

/// Runs `lfast detect`; `Ok(false)` when some file failed.
///
/// The process ends after the command, so the detector is not torn down once
/// every output is written: the operating system reclaims its GPU device,
/// pipelines and buffers at exit faster than their destructors free them one
/// by one (the whole run on one KITTI file on lavapipe: medians of eight
/// alternated runs 284 -> 272 ms).
pub(super) fn run(a: DetectArgs) -> Result<bool, CliError> {
    run_with(a, &crate::io::write_atomic, std::mem::forget)
}

/// [`run`] writing every output through `write`; `release` takes the front
/// end once the last output is written (the tests drop it).
fn run_with(a: DetectArgs, write: Write, release: fn(Features)) -> Result<bool, CliError> {
    let cfg = a.common.config()?;
    let det = front_end(a.detector, cfg, a.fast_threshold, &a.common)?;
    let backend = det.backend_name();
    let pool = a.common.pool()?;
    super::report::prepare_out_dir(&a.out)?;
    let all = inputs::collect(&a.inputs, a.from_list.as_deref(), &a.out)?;
    let mine = inputs::shard(all, a.shard);
    let mut formats: Vec<Format> = Vec::new();
    for f in &a.format {
        if !formats.contains(f) {
            formats.push(*f);
        }
    }
    let (recordings, mine) = super::recorded::split(mine, &a.rec)?;
    if !recordings.is_empty() {
        return recording::run(&a, &det, &pool, &recordings, &formats, write);
    }
    if formats.contains(&Format::Mcap) || a.include_images {
        return Err(CliError::Usage(
            "--format mcap and --include-images are for recordings (MCAP files, videos); the inputs are images".into(),
        ));
    }
    let jobs: Vec<Job> =
        mine.iter().map(|i| Job { input: i, outputs: outputs(&a.out.join(&i.rel), &formats, a.draw) }).collect();

    report::log_warnings(a.common.quiet);
    report::catch_interrupts();
    let mut rep = Reporter::new(jobs.iter().filter(|j| j.input.is_file()).count() as u64, a.common.quiet);
    let threads = pool.current_num_threads().max(1);
    // Decoder threads: half the workers, 2 to 4 (1 with one worker). Two even
    // on two cores: the first frame's decode holds up every worker, and a
    // second decoder fills the other core with the next frame meanwhile (four
    // 3840x2160 JPEGs, `--jobs 2`: median 1.10 -> 1.00 s; 51 KITTI PNGs the same).
    let decoders = (threads / 2).clamp(2.min(threads), 4);
    // on a software adapter the decoders take only the cores its threads leave ([`yield_cores`])
    let yielding = det.on_software_gpu();
    let next = AtomicUsize::new(0);
    // set when the disk is full: no file is taken after it
    let stop = AtomicBool::new(false);
    let (skip_existing, draw) = (a.skip_existing, a.draw);
    // the gray planes' buffers once detected, for the decoders to fill again:
    // a 3840x2160 frame's 8 MB would otherwise be paged in anew for each file
    let spent = Mutex::new(Vec::<Vec<u8>>::new());
    let keep_spent = decoders + 3 * threads;
    std::thread::scope(|s| {
        let (jobs, next, det, stop, spent) = (&jobs, &next, &det, &stop, &spent);
        let (tx_dec, rx_dec) = sync_channel::<(usize, Stage)>(2 * threads);
        let (tx_det, rx_det) = sync_channel::<(usize, Stage)>(2 * threads);
        // stage 1: decode
        for _ in 0..decoders {
            let tx = tx_dec.clone();
            s.spawn(move || {
                if yielding {
                    yield_cores();
                }
                let mut loader = crate::image::GrayLoader::default();
                loop {
                    if report::interrupted() || stop.load(Ordering::Relaxed) {
                        break;
                    }
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(job) = jobs.get(i) else { break };
                    let st = if let Some(p) = &job.input.problem {
                        Stage::Problem(p.clone())
                    } else if skip_existing && job.outputs.iter().all(|p| p.is_file()) {
                        Stage::Skip
                    } else {
                        let buf = spent.lock().ok().and_then(|mut v| v.pop()).unwrap_or_default();
                        match loader.load_into(&job.input.path, buf) {
                            Ok(img) => Stage::Decoded(img),
                            Err(e) => Stage::Failed(report::reason(&e)),
                        }
                    };
                    if tx.send((i, st)).is_err() {
                        break;
                    }
                }
            });
        }
        drop(tx_dec);
        // stage 2: detect, several frames at once in the pool ([`frames_in_flight`])
        s.spawn(move || {
            // a frame's results as the next stage takes them; its buffer to the decoders
            let detected = |img: Plane<u8>, r: crate::Result<(Vec<KeyPoint>, Vec<Descriptor>)>| match r {
                Ok((kps, desc)) => {
                    let (width, height) = (img.width, img.height);
                    let img = if draw {
                        Some(img)
                    } else {
                        if let Ok(mut v) = spent.lock()
                            && v.len() < keep_spent
                        {
                            v.push(img.data);
                        }
                        None
                    };
                    Stage::Detected(Detected { width, height, kps, desc, img })
                }
                Err(e) => Stage::Failed(report::reason(&e)),
            };
            // on the GPU: one stream, frames in flight while earlier ones are read back
            if let Features::Lfast(d) = det {
                let mut stream = d.stream::<usize>();
                if stream.on_gpu() {
                    let send = |d: crate::Done<usize>| {
                        let _ = tx_det.send((d.tag, detected(d.image, d.result)));
                    };
                    for (i, st) in rx_dec {
                        match st {
                            Stage::Decoded(img) => stream.push(i, img).into_iter().for_each(send),
                            other => {
                                let _ = tx_det.send((i, other));
                            }
                        }
                    }
                    stream.finish().into_iter().for_each(send);
                    return;
                }
            }
            let detect = |(i, st): (usize, Stage)| {
                let st = match st {
                    Stage::Decoded(mut img) => {
                        let r = det.detect_and_compute_in(&mut img);
                        detected(img, r)
                    }
                    other => other,
                };
                let _ = tx_det.send((i, st));
            };
            // files that fail or are skipped before the first decoded frame pass straight on
            let mut rx_dec = rx_dec.into_iter();
            let (i, img) = loop {
                match rx_dec.next() {
                    Some((i, Stage::Decoded(img))) => break (i, img),
                    Some(other) => detect(other),
                    None => return,
                }
            };
            // the first frame's size decides for the batch (a batch's frames mostly share one)
            let loops = frames_in_flight(img.width, img.height, threads);
            let frames = std::iter::once((i, Stage::Decoded(img))).chain(rx_dec);
            if loops >= threads {
                // a frame per worker: par_bridge's workers take the next frame when done
                return pool.install(|| frames.par_bridge().for_each(detect));
            }
            // fewer loops than workers, each taking the next frame when its last
            // is done; the workers not in a loop take bands of their frames
            let frames = Mutex::new(frames);
            let next = || frames.lock().ok()?.next();
            let work = || {
                while let Some(it) = next() {
                    detect(it);
                }
            };
            pool.in_place_scope(|sc| {
                for _ in 0..loops {
                    sc.spawn(|_| work());
                }
            });
        });
        // stage 3 (this thread): encode, write, report
        for (i, st) in rx_det {
            // after SIGINT/SIGTERM: the files written so far are complete; stop
            if report::interrupted() {
                break;
            }
            let job = &jobs[i];
            match &st {
                Stage::Skip => rep.skipped(|| format!("{}: skipped (outputs exist)", job.input.path.display())),
                Stage::Failed(reason) => rep.failed(&job.input.path, reason),
                Stage::Problem(p) => rep.problem(&job.input.path, p),
                Stage::Detected(d) => match write_all(&job.input.path, None, &job.outputs, &formats, draw, d, write) {
                    Ok(()) => rep.done(d.kps.len() as u64, || {
                        let (n, to) = (d.kps.len(), job.outputs[0].display());
                        format!("{}: {n} keypoints -> {to}", job.input.path.display())
                    }),
                    // no later write can succeed: stop at once, the files written stay
                    Err(e) if crate::io::is_disk_full(&e) => {
                        stop.store(true, Ordering::Relaxed);
                        rep.stopped(&report::disk_full(&e, rep.finished(), jobs.len()));
                        break;
                    }
                    Err(e) => rep.failed(&job.input.path, &e.to_string()),
                },
                Stage::Decoded(_) => rep.failed(&job.input.path, "internal error: not detected"),
            }
        }
    });
    let tail = format!("backend {backend}, detector {}, {threads} threads", det.kind());
    let ok = rep.finish("keypoints", &tail);
    report::exit_if_interrupted();
    release(det);
    Ok(ok)
}

/// Lets the calling thread run only on cores nothing else wants (Linux
/// `SCHED_IDLE`, this thread alone; elsewhere nothing changes): the decoders
/// beside a software adapter. lavapipe splits each dispatch's workgroups
/// evenly between its threads up front, so a decoder that takes a core from
/// one of them holds up the whole dispatch while the other waits; at idle
/// priority the decoders run in the gaps between dispatches and while one
/// thread of a dispatch waits (51 KITTI frames on two cores: the run's idle
/// core time 0.56 -> 0.35 s, its wall time ~3% shorter; docs/gpu.md). They
/// stay a few frames ahead (the channel's), and when they fall behind the GPU
/// waits for them and the cores are theirs. Whether it took effect.
fn yield_cores() -> bool {
    #[cfg(target_os = "linux")]
    let took = {
        let param = libc::sched_param { sched_priority: 0 };
        // SAFETY: pid 0 is the calling thread (Linux schedules each thread on
        // its own); `param` is a valid sched_param for the call's duration.
        unsafe { libc::sched_setscheduler(0, libc::SCHED_IDLE, &param) == 0 }
    };
    #[cfg(not(target_os = "linux"))]
    let took = false;
    took
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;
    use std::cell::Cell;
    use std::ffi::OsStr;
    use std::io::Write as _;

    fn args(args: &[&OsStr]) -> DetectArgs {
        let argv = [OsStr::new("lfast"), OsStr::new("detect")].into_iter().chain(args.iter().copied());
        match super::super::Cli::try_parse_from(argv).expect("valid arguments").cmd {
            super::super::Cmd::Detect(a) => a,
            _ => unreachable!("a detect command line"),
        }
    }

    /// Every file under `dir`, relative, with its bytes.
    fn tree(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
        let mut v: Vec<_> = walkdir::WalkDir::new(dir)
            .into_iter()
            .map(|e| e.unwrap())
            .filter(|e| e.file_type().is_file())
            .map(|e| (e.path().strip_prefix(dir).unwrap().to_path_buf(), std::fs::read(e.path()).unwrap()))
            .collect();
        v.sort();
        v
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn yield_cores_sets_the_calling_thread_alone_to_idle() {
        // SAFETY (each call): sched_getscheduler(0) only reads the calling thread's policy
        let before = unsafe { libc::sched_getscheduler(0) };
        let inside = std::thread::spawn(|| (yield_cores(), unsafe { libc::sched_getscheduler(0) })).join().unwrap();
        assert_eq!(inside, (true, libc::SCHED_IDLE));
        assert_eq!(unsafe { libc::sched_getscheduler(0) }, before);
    }

    #[test]
    fn decoders_yield_to_a_software_gpu_only() {
        let cpu =
            Features::Lfast(Box::new(crate::Detector::new(crate::Config::default(), crate::Backend::Cpu).unwrap()));
        assert!(!cpu.on_software_gpu());
        let Some(ctx) = crate::testing::context() else { return };
        let software = crate::gpu::is_software(&ctx.info);
        let gpu = Features::Lfast(Box::new(crate::Detector::from_context(ctx, crate::Config::default()).unwrap()));
        assert_eq!(gpu.on_software_gpu(), software);
        assert_eq!(gpu.backend_name(), "gpu");
    }

    #[test]
    fn large_frames_take_half_the_workers_frames() {
        assert_eq!(frames_in_flight(1241, 376, 2), 2);
        assert_eq!(frames_in_flight(1920, 1080, 2), 2);
        assert_eq!(frames_in_flight(1080, 1921, 2), 1);
        assert_eq!(frames_in_flight(3840, 2160, 16), 8);
        assert_eq!(frames_in_flight(3840, 2160, 3), 1);
        assert_eq!(frames_in_flight(3840, 2160, 1), 1);
        assert_eq!(frames_in_flight(64, 64, 0), 1);
    }

    #[test]
    fn a_batch_of_large_frames_equals_one_frame_at_a_time() {
        // frames over 1920x1080 run one at a time on two workers (the other
        // takes bands); a file that fails before the first frame is passed on
        let root = tempfile::tempdir().unwrap();
        let (inp, two, one) = (root.path().join("in"), root.path().join("two"), root.path().join("one"));
        std::fs::create_dir(&inp).unwrap();
        std::fs::write(inp.join("a_broken.png"), b"not a png").unwrap();
        let base = crate::image::load_gray(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/coins.png")).unwrap();
        let (w, h) = (2000u32, 1100u32);
        for k in 0..3u32 {
            // the coins tiled, shifted per file
            let data = (0..w * h)
                .map(|i| base.at((i % w + 37 * k) % base.width, (i / w + 11 * k) % base.height))
                .collect::<Vec<u8>>();
            image::GrayImage::from_raw(w, h, data).unwrap().save(inp.join(format!("f{k}.png"))).unwrap();
        }
        let run = |out: &Path, jobs: &str| {
            let v: Vec<&OsStr> = vec![
                inp.as_os_str(),
                OsStr::new("--out"),
                out.as_os_str(),
                OsStr::new("--backend"),
                OsStr::new("cpu"),
                OsStr::new("--jobs"),
                OsStr::new(jobs),
                OsStr::new("--quiet"),
            ];
            run_with(args(&v), &crate::io::write_atomic, drop).unwrap()
        };
        assert!(!run(&two, "2"), "the broken file fails the batch");
        assert!(!run(&one, "1"));
        let got = tree(&two);
        assert_eq!(got.len(), 3, "{:?}", got.iter().map(|f| &f.0).collect::<Vec<_>>());
        assert!(got.iter().all(|(_, bytes)| bytes.len() > 10_000), "features in every frame");
        assert_eq!(got, tree(&one));
    }

    #[test]
    fn a_full_disk_stops_the_batch_at_the_first_failed_write_and_skip_existing_finishes() {
        let root = tempfile::tempdir().unwrap();
        let (inp, out, clean) = (root.path().join("in"), root.path().join("out"), root.path().join("clean"));
        std::fs::create_dir(&inp).unwrap();
        let frame = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/chessboard_GRAY.png")).unwrap();
        for i in 0..6 {
            std::fs::write(inp.join(format!("f{i}.png")), &frame).unwrap();
        }
        let run_to = |dir: &Path, extra: &[&str], write: Write| {
            let mut v: Vec<&OsStr> = vec![inp.as_os_str(), OsStr::new("--out"), dir.as_os_str()];
            v.extend(["--format", "json,csv", "--backend", "cpu", "--jobs", "2", "--quiet"].map(OsStr::new));
            v.extend(extra.iter().map(OsStr::new));
            run_with(args(&v), write, drop)
        };
        assert!(run_to(&clean, &[], &crate::io::write_atomic).unwrap());
        let want = tree(&clean);
        assert_eq!(want.len(), 12);

        // the fifth write (the first output of the third file finished) meets a
        // full disk half-way through; every later one would too
        let calls = Cell::new(0);
        let full = |p: &Path, bytes: &[u8]| -> crate::Result<()> {
            calls.set(calls.get() + 1);
            if calls.get() < 5 {
                return crate::io::write_atomic(p, bytes);
            }
            crate::io::write_atomic_with(p, |f| {
                f.write_all(&bytes[..bytes.len() / 2])?;
                Err(std::io::ErrorKind::StorageFull.into())
            })
        };
        assert!(!run_to(&out, &[], &full).unwrap(), "a full disk fails the batch");
        assert_eq!(calls.get(), 5, "no write is tried after the disk is full");
        let got = tree(&out);
        assert_eq!(got.len(), 4, "two files' outputs, nothing else (no temporary file): {got:?}");
        for f in &got {
            assert!(want.contains(f), "{} is whole", f.0.display());
        }

        // space freed: --skip-existing does the rest, and the result is the clean run's
        let calls = Cell::new(0);
        let counting = |p: &Path, bytes: &[u8]| {
            calls.set(calls.get() + 1);
            crate::io::write_atomic(p, bytes)
        };
        assert!(run_to(&out, &["--skip-existing"], &counting).unwrap());
        assert_eq!(calls.get(), 8, "only the four files not done are written");
        assert_eq!(tree(&out), want);
    }
}
