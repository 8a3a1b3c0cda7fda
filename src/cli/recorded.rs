//! Recordings (MCAP files, videos) through `detect` and `edges`: each
//! recording is read by one thread ([`crate::recording`], streamed), its
//! frames decoded and processed several at once in the pool, and written in
//! order by the calling thread, all linked by bounded channels so that memory
//! stays flat however long the recording.
//!
//! A frame's outputs are `OUT/REC/INDEX_TIME.*`: REC the recording's name
//! without extension, INDEX the frame's index among all frames of the topic
//! or video (six digits at least), TIME its log (or presentation) time in ns.
//! A recording that cannot be opened, a frame that cannot be decoded, and the
//! damage that ends a recording early are each one error line; the frames
//! before the damage are all written.

use super::inputs::Input;
use super::report::{self, Reporter};
use crate::recording::{Decoded, Packet, Recording, Selection};
use rayon::iter::{ParallelBridge, ParallelIterator};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::sync_channel;

/// The per-frame work of a command, on the pool's threads.
pub(super) trait Work: Sync {
    /// What a frame becomes.
    type Out: Send;
    /// The output files of the frame whose outputs are `base.*`.
    fn outputs(&self, base: &Path) -> Vec<PathBuf>;
    /// Processes one decoded frame.
    fn process(&self, frame: Decoded) -> crate::Result<Self::Out>;
    /// What [`Sink::frame`] counts ("keypoints").
    fn noun(&self) -> &'static str;
}

/// One frame done, for the [`Sink`].
pub(super) struct Done<'a, T> {
    /// The recording.
    pub recording: &'a Path,
    /// Its MCAP topic.
    pub topic: Option<&'a str>,
    /// The frame as read (index, time, message).
    pub packet: &'a Packet,
    /// The image's own stamp.
    pub stamp_ns: Option<u64>,
    /// The frame's output files.
    pub outputs: &'a [PathBuf],
    /// What [`Work::process`] made.
    pub out: &'a T,
}

/// Where a command's frames go, on the calling thread.
pub(super) trait Sink<T> {
    /// Whether `--skip-existing` skips the whole recording whose output name is `rel`.
    fn recording_exists(&self, rel: &Path) -> bool;
    /// Whether per-frame outputs that exist may be skipped (not when every
    /// frame must reach a file of the whole recording).
    fn per_frame_skip(&self) -> bool;
    /// Before the first frame of `rec`, named `rel`.
    fn start(&mut self, rec: &Recording, rel: &Path) -> crate::Result<()>;
    /// Writes one frame; returns its item count (keypoints, edge pixels).
    fn frame(&mut self, f: &Done<'_, T>) -> crate::Result<u64>;
    /// After the last frame, also when the recording ended at damage or an interrupt.
    fn finish(&mut self) -> crate::Result<()>;
}

/// `OUT/REL/INDEX_TIME`.
pub(super) fn frame_base(out: &Path, rel: &Path, p: &Packet) -> PathBuf {
    out.join(rel).join(format!("{:06}_{}", p.index, p.time_ns))
}

/// How a frame is described on its lines: `REC: frame 12 (1.200 s)`.
fn frame_name(path: &Path, p: &Packet, first: u64) -> String {
    let s = p.time_ns.saturating_sub(first) as f64 / 1e9;
    format!("{}: frame {} ({s:.3} s)", path.display(), p.index)
}

/// What happened to a frame in the pool.
enum Stage<T> {
    /// The damage that ends the recording.
    Damage(crate::Error),
    Skip(Packet),
    Failed(Packet, crate::Error),
    Done(Packet, Option<u64>, T),
}

/// The line that stops the run on a full disk.
fn disk_full(e: &crate::Error, done: u64) -> String {
    let path = match e {
        crate::Error::Io { path, .. } => path.display().to_string(),
        other => other.to_string(),
    };
    format!(
        "disk full writing {path}: {done} frames done (no space left on device); free some space and rerun with --skip-existing to finish"
    )
}

/// Runs `work` over every frame of `inputs` (recordings), writing through
/// `sink`; counts frames on `rep`. Returns normally also after a full disk
/// (`stop` is then set).
pub(super) fn run<W: Work, S: Sink<W::Out>>(
    inputs: &[Input],
    sel: &Selection,
    out: &Path,
    skip_existing: bool,
    pool: &rayon::ThreadPool,
    work: &W,
    sink: &mut S,
    rep: &mut Reporter,
    stop: &AtomicBool,
) {
    let threads = pool.current_num_threads().max(1);
    // messages read before this recording, for the bar
    let mut before = 0u64;
    for input in inputs {
        if report::interrupted() || stop.load(Ordering::Relaxed) {
            break;
        }
        if let Some(p) = &input.problem {
            rep.problem(&input.path, p);
            continue;
        }
        if skip_existing && sink.recording_exists(&input.rel) {
            rep.skipped(|| format!("{}: skipped (outputs exist)", input.path.display()));
            continue;
        }
        let rec = match Recording::open(&input.path, sel) {
            Ok(r) => r,
            Err(e) => {
                rep.failed(&input.path, &report::reason(&e));
                continue;
            }
        };
        if let Err(e) = sink.start(&rec, &input.rel) {
            rep.failed(&input.path, &report::reason(&e));
            continue;
        }
        let total = rec.total().unwrap_or(0);
        let topic = rec.topic().map(str::to_string);
        let path = rec.path().to_path_buf();
        let per_frame_skip = skip_existing && sink.per_frame_skip();
        let read = AtomicU64::new(0);
        // set when this recording is to stop early (an unsupported encoding)
        let halt = AtomicBool::new(false);
        let mut first_time: Option<u64> = None;
        std::thread::scope(|s| {
            let (tx_read, rx_read) = sync_channel::<(u64, crate::Result<Packet>)>(2 * threads);
            let (tx_done, rx_done) = sync_channel::<(u64, Stage<W::Out>)>(2 * threads);
            let (read, halt) = (&read, &halt);
            // stage 1: read, in order
            s.spawn(move || {
                let mut rec = rec;
                let mut seq = 0;
                while !(report::interrupted() || stop.load(Ordering::Relaxed) || halt.load(Ordering::Relaxed)) {
                    let Some(item) = rec.next() else { break };
                    read.store(rec.position(), Ordering::Relaxed);
                    if tx_read.send((seq, item)).is_err() {
                        break;
                    }
                    seq += 1;
                }
            });
            // stage 2: decode and process, several frames at once
            s.spawn(move || {
                pool.install(|| {
                    rx_read.into_iter().par_bridge().for_each(|(seq, item)| {
                        let st = match item {
                            Err(e) => Stage::Damage(e),
                            Ok(p)
                                if per_frame_skip
                                    && work.outputs(&frame_base(out, &input.rel, &p)).iter().all(|o| o.is_file()) =>
                            {
                                Stage::Skip(p)
                            }
                            Ok(p) => match p.decode() {
                                Ok(d) => {
                                    let stamp = d.stamp_ns;
                                    match work.process(d) {
                                        Ok(o) => Stage::Done(p, stamp, o),
                                        Err(e) => Stage::Failed(p, e),
                                    }
                                }
                                Err(e) => Stage::Failed(p, e),
                            },
                        };
                        let _ = tx_done.send((seq, st));
                    })
                })
            });
            // stage 3 (this thread): in order, write and report
            let mut waiting: BTreeMap<u64, Stage<W::Out>> = BTreeMap::new();
            let mut next = 0u64;
            for (seq, st) in rx_done {
                waiting.insert(seq, st);
                while let Some(st) = waiting.remove(&next) {
                    next += 1;
                    if report::interrupted() || stop.load(Ordering::Relaxed) || halt.load(Ordering::Relaxed) {
                        continue;
                    }
                    rep.position(before + read.load(Ordering::Relaxed), before + total);
                    match st {
                        Stage::Damage(e) => rep.failed(&path, &report::reason(&e)),
                        Stage::Skip(p) => {
                            let first = *first_time.get_or_insert(p.time_ns);
                            rep.skipped(|| format!("{}: skipped (outputs exist)", frame_name(&path, &p, first)))
                        }
                        Stage::Failed(p, e) => {
                            let first = *first_time.get_or_insert(p.time_ns);
                            let name = frame_name(&path, &p, first);
                            rep.failed(Path::new(&name), &report::reason(&e));
                            if matches!(e, crate::Error::Unsupported { .. }) {
                                // every later frame would fail the same way
                                halt.store(true, Ordering::Relaxed);
                            }
                        }
                        Stage::Done(p, stamp_ns, o) => {
                            let first = *first_time.get_or_insert(p.time_ns);
                            let outputs = work.outputs(&frame_base(out, &input.rel, &p));
                            let done = Done {
                                recording: &path,
                                topic: topic.as_deref(),
                                packet: &p,
                                stamp_ns,
                                outputs: &outputs,
                                out: &o,
                            };
                            match sink.frame(&done) {
                                Ok(n) => rep.done(n, || {
                                    let to = outputs.first().map_or(String::new(), |o| format!(" -> {}", o.display()));
                                    format!("{}: {n} {}{to}", frame_name(&path, &p, first), work.noun())
                                }),
                                Err(e) if crate::io::is_disk_full(&e) => {
                                    stop.store(true, Ordering::Relaxed);
                                    rep.stopped(&disk_full(&e, rep.finished()));
                                }
                                Err(e) => rep.failed(Path::new(&frame_name(&path, &p, first)), &e.to_string()),
                            }
                        }
                    }
                }
            }
        });
        before += total.max(read.load(Ordering::Relaxed));
        if let Err(e) = sink.finish() {
            if crate::io::is_disk_full(&e) {
                stop.store(true, Ordering::Relaxed);
                rep.stopped(&disk_full(&e, rep.finished()));
            } else {
                rep.failed(&path, &report::reason(&e));
            }
        }
    }
}

/// The options that choose a recording's frames.
#[derive(clap::Args, Clone, Debug, Default)]
pub(super) struct RecordingArgs {
    /// MCAP input: the image topic to read (default: the file's one image topic)
    #[arg(long, value_name = "NAME")]
    pub topic: Option<String>,
    /// Recordings: take every Nth frame (of those in --frames and --time)
    #[arg(long, value_name = "N", default_value_t = 1, value_parser = clap::value_parser!(u64).range(1..))]
    pub every: u64,
    /// Recordings: frames START..END (0-based, END excluded; `..N` or `N`: the first N)
    #[arg(long, value_name = "RANGE")]
    pub frames: Option<crate::recording::FrameRange>,
    /// Recordings: times START..END in seconds from the first frame (`5..12.5`, `..30`)
    #[arg(long, value_name = "RANGE")]
    pub time: Option<crate::recording::TimeRange>,
}

impl RecordingArgs {
    /// The selection these options make.
    pub fn selection(&self) -> Selection {
        Selection {
            topic: self.topic.clone(),
            frames: self.frames.unwrap_or_default(),
            time: self.time.unwrap_or_default(),
            every: self.every,
        }
    }

    /// Whether any of them was given (they need a recording input).
    pub fn any(&self) -> bool {
        self.topic.is_some() || self.every != 1 || self.frames.is_some() || self.time.is_some()
    }
}

/// Splits inputs into recordings and images; both kinds at once, or the
/// recording options with images only, is a usage error.
pub(super) fn split(all: Vec<Input>, a: &RecordingArgs) -> Result<(Vec<Input>, Vec<Input>), super::CliError> {
    let (recs, images): (Vec<Input>, Vec<Input>) =
        all.into_iter().partition(|i| crate::recording::format_of(&i.path).is_some());
    if !recs.is_empty() && !images.is_empty() {
        return Err(super::CliError::Usage(format!(
            "give recordings ({}, ...) and images ({}, ...) in separate runs",
            recs[0].path.display(),
            images[0].path.display()
        )));
    }
    if recs.is_empty() && a.any() {
        return Err(super::CliError::Usage(
            "--topic, --every, --frames and --time choose frames of recordings (MCAP, video); no input is one".into(),
        ));
    }
    Ok((recs, images))
}
