//! `lfast detect` over recordings: per-frame outputs named by index and time
//! (`OUT/REC/INDEX_TIME.json`, ...), and `--format mcap`'s one file per
//! recording (`OUT/REC.lfast.mcap`, see [`super::super::mcap_out`]).

use super::super::mcap_out::{AnnotationWriter, FrameImage, FrameOut, ImageCopy};
use super::super::recorded::{self, Done, Sink, Work};
use super::super::report::{self, Reporter};
use super::super::{CliError, inputs::Input};
use super::{DetectArgs, Detected, Format, Write, outputs, write_all};
use crate::frontend::Features;
use crate::recording::{Decoded, Format as RecFormat, Recording};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

struct DetectWork<'a> {
    det: &'a Features,
    formats: &'a [Format],
    draw: bool,
    keep_image: bool,
}

impl Work for DetectWork<'_> {
    type Out = Detected;
    fn outputs(&self, base: &Path) -> Vec<PathBuf> {
        outputs(base, self.formats, self.draw)
    }
    fn process(&self, f: Decoded) -> crate::Result<Detected> {
        let (kps, desc) = self.det.detect_and_compute(&f.image)?;
        let (width, height) = (f.image.width, f.image.height);
        Ok(Detected { width, height, kps, desc, img: self.keep_image.then_some(f.image) })
    }
    fn noun(&self) -> &'static str {
        "keypoints"
    }
}

struct DetectSink<'a> {
    out: &'a Path,
    formats: &'a [Format],
    draw: bool,
    mcap: bool,
    include_images: bool,
    writer: Option<AnnotationWriter>,
    write: Write<'a>,
}

/// `OUT/REL.lfast.mcap`.
fn mcap_path(out: &Path, rel: &Path) -> PathBuf {
    let mut s = out.join(rel).into_os_string();
    s.push(".lfast.mcap");
    PathBuf::from(s)
}

impl Sink<Detected> for DetectSink<'_> {
    fn recording_exists(&self, rel: &Path) -> bool {
        self.mcap && mcap_path(self.out, rel).is_file()
    }
    fn per_frame_skip(&self) -> bool {
        !self.mcap
    }
    fn start(&mut self, rec: &Recording, rel: &Path) -> crate::Result<()> {
        if !self.mcap {
            return Ok(());
        }
        let path = mcap_path(self.out, rel);
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir).map_err(|source| crate::Error::Io { path: dir.to_path_buf(), source })?;
        }
        let copy = match (self.include_images, rec.schema()) {
            (false, _) => ImageCopy::None,
            (true, Some(s)) => ImageCopy::Messages(s),
            (true, None) => ImageCopy::Frames,
        };
        self.writer = Some(AnnotationWriter::create(&path, rec.topic().unwrap_or("/video"), copy)?);
        Ok(())
    }
    fn frame(&mut self, f: &Done<'_, Detected>) -> crate::Result<u64> {
        let d = f.out;
        let info = crate::io::FrameInfo {
            topic: f.topic.map(str::to_string),
            index: f.packet.index,
            time_ns: f.packet.time_ns,
            stamp_ns: f.stamp_ns,
        };
        write_all(f.recording, Some(&info), f.outputs, self.formats, self.draw, d, self.write)?;
        if let Some(w) = &mut self.writer {
            let image = match (self.include_images, f.packet.message(), &d.img) {
                (false, _, _) => None,
                (true, Some(m), _) => Some(FrameImage::Message(m)),
                (true, None, Some(p)) => Some(FrameImage::Gray(p)),
                (true, None, None) => None,
            };
            w.write(&FrameOut {
                time_ns: f.packet.time_ns,
                stamp_ns: f.stamp_ns,
                index: f.packet.index,
                width: d.width,
                height: d.height,
                kps: &d.kps,
                desc: &d.desc,
                image,
            })?;
        }
        Ok(d.kps.len() as u64)
    }
    fn finish(&mut self) -> crate::Result<()> {
        match self.writer.take() {
            Some(w) => w.finish(),
            None => Ok(()),
        }
    }
}

/// `lfast detect` with recording inputs; `Ok(false)` when something failed.
pub(super) fn run(
    a: &DetectArgs,
    det: &Features,
    pool: &rayon::ThreadPool,
    recordings: &[Input],
    formats: &[Format],
    write: Write,
) -> Result<bool, CliError> {
    let mcap = formats.contains(&Format::Mcap);
    if a.include_images && !mcap {
        return Err(CliError::Usage("--include-images goes with --format mcap".into()));
    }
    // video frames are kept for --include-images
    let video = recordings.iter().any(|i| crate::recording::format_of(&i.path) == Some(RecFormat::Video));
    let work = DetectWork { det, formats, draw: a.draw, keep_image: a.draw || (a.include_images && video) };
    let mut sink =
        DetectSink { out: &a.out, formats, draw: a.draw, mcap, include_images: a.include_images, writer: None, write };
    report::log_warnings(a.common.quiet);
    report::catch_interrupts();
    let mut rep = Reporter::counting(0, a.common.quiet, "frames", "messages");
    let stop = AtomicBool::new(false);
    let sel = a.rec.selection();
    recorded::run(recordings, &sel, &a.out, a.skip_existing, pool, &work, &mut sink, &mut rep, &stop);
    let tail =
        format!("backend {}, detector {}, {} threads", det.backend_name(), det.kind(), pool.current_num_threads());
    let ok = rep.finish("keypoints", &tail);
    report::exit_if_interrupted();
    Ok(ok)
}
