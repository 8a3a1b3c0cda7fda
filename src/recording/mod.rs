//! Recorded input: the frames of an MCAP file's image topic (ROS 2 bags,
//! Foxglove recordings) or of a video, streamed one at a time so that memory
//! does not grow with the recording.
//!
//! ```no_run
//! use lfast::recording::{Recording, Selection};
//! let sel = Selection { topic: Some("/camera/image_raw".into()), every: 2, ..Selection::default() };
//! for packet in Recording::open("run.mcap", &sel)? {
//!     let packet = packet?; // Err: the file is damaged here; the frames before it were good
//!     let frame = packet.decode()?; // Err: this message is malformed or of an unsupported encoding
//!     println!("frame {} at {} ns: {}x{}", packet.index, packet.time_ns, frame.image.width, frame.image.height);
//! }
//! # Ok::<(), lfast::Error>(())
//! ```
//!
//! - MCAP topics: `sensor_msgs/msg/Image` (mono8, mono16, rgb8, bgr8,
//!   rgba8, bgra8, `step` honoured) and `sensor_msgs/msg/CompressedImage`
//!   (png, jpeg) in CDR; `foxglove.RawImage` and `foxglove.CompressedImage`
//!   in protobuf (and `foxglove_msgs/msg/*` in CDR). Frames come in log-time
//!   order (file order when the file has no summary, as a truncated one).
//!   A frame's time is its message's log time.
//! - Video (mp4, mkv, avi, mov, webm): through the `ffmpeg` program; a frame's
//!   time is its presentation time.
//!
//! The first damaged part of a file (a truncated record, a chunk whose CRC
//! does not match, an error ffmpeg reports) ends the iteration with an
//! [`Error::Recording`] saying where reading stopped; every frame yielded
//! before it is intact.

mod mcap_in;
mod pixels;
mod video;
pub mod wire;

pub use mcap_in::{SchemaInfo, TopicInfo};
pub use pixels::RAW_ENCODINGS;
pub use wire::{CameraInfo, MessageKind};

use crate::error::{Error, Result};
use crate::image::Plane;
use std::path::{Path, PathBuf};

/// File extensions read as video (case-insensitive).
pub const VIDEO_EXTENSIONS: &[&str] = &["mp4", "mkv", "avi", "mov", "webm", "m4v"];

/// What kind of recording a file is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// An MCAP file (`.mcap`).
    Mcap,
    /// A video file.
    Video,
}

/// The recording format of `path`, by its extension; `None` for other files.
///
/// ```
/// use lfast::recording::{Format, format_of};
/// assert_eq!(format_of("run_0.mcap".as_ref()), Some(Format::Mcap));
/// assert_eq!(format_of("drive.MKV".as_ref()), Some(Format::Video));
/// assert_eq!(format_of("frame.png".as_ref()), None);
/// ```
pub fn format_of(path: &Path) -> Option<Format> {
    let ext = path.extension()?.to_str()?.to_ascii_lowercase();
    if ext == "mcap" { Some(Format::Mcap) } else { VIDEO_EXTENSIONS.contains(&ext.as_str()).then_some(Format::Video) }
}

/// A half-open range of frame indices, `start..end`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FrameRange {
    /// The first frame taken.
    pub start: u64,
    /// The first frame not taken; `None` = to the end.
    pub end: Option<u64>,
}

/// A half-open range of times in seconds from the first frame, `start..end`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TimeRange {
    /// Frames at or after this many seconds.
    pub start: Option<f64>,
    /// Frames before this many seconds.
    pub end: Option<f64>,
}

fn split_range(s: &str) -> Result<(&str, &str), String> {
    s.split_once("..").ok_or_else(|| format!("`{s}` is not a range START..END (either side may be left out)"))
}

impl std::str::FromStr for FrameRange {
    type Err = String;
    /// `A..B` (frames A to B-1), `A..`, `..B`, or `N` (the first N, `..N`).
    ///
    /// ```
    /// use lfast::recording::FrameRange;
    /// assert_eq!("10..20".parse::<FrameRange>(), Ok(FrameRange { start: 10, end: Some(20) }));
    /// assert_eq!("5".parse::<FrameRange>(), Ok(FrameRange { start: 0, end: Some(5) }));
    /// assert!("9..3".parse::<FrameRange>().is_err());
    /// ```
    fn from_str(s: &str) -> Result<Self, String> {
        let num = |v: &str| v.trim().parse::<u64>().map_err(|_| format!("`{v}` is not a frame number"));
        let r = match s.contains("..") {
            false => FrameRange { start: 0, end: Some(num(s)?) },
            true => {
                let (a, b) = split_range(s)?;
                FrameRange {
                    start: if a.trim().is_empty() { 0 } else { num(a)? },
                    end: if b.trim().is_empty() { None } else { Some(num(b)?) },
                }
            }
        };
        match r.end {
            Some(e) if e <= r.start => Err(format!("`{s}` takes no frame (END must be above START)")),
            _ => Ok(r),
        }
    }
}

impl std::str::FromStr for TimeRange {
    type Err = String;
    /// `A..B` in seconds from the first frame (`2.5..10`, `..30`, `60..`).
    ///
    /// ```
    /// use lfast::recording::TimeRange;
    /// assert_eq!("2.5..10".parse::<TimeRange>(), Ok(TimeRange { start: Some(2.5), end: Some(10.0) }));
    /// assert!("..-1".parse::<TimeRange>().is_err());
    /// ```
    fn from_str(s: &str) -> Result<Self, String> {
        let (a, b) = split_range(s)?;
        let secs = |v: &str| -> Result<Option<f64>, String> {
            let v = v.trim();
            if v.is_empty() {
                return Ok(None);
            }
            match v.parse::<f64>() {
                Ok(x) if x.is_finite() && x >= 0.0 => Ok(Some(x)),
                _ => Err(format!("`{v}` is not a time in seconds (0 or more)")),
            }
        };
        let r = TimeRange { start: secs(a)?, end: secs(b)? };
        if let (Some(a), Some(b)) = (r.start, r.end)
            && b <= a
        {
            return Err(format!("`{s}` takes no frame (END must be above START)"));
        }
        Ok(r)
    }
}

/// Which frames of a recording to take.
#[derive(Clone, Debug, PartialEq)]
pub struct Selection {
    /// The MCAP topic; `None` = the file's one image topic. Ignored for video.
    pub topic: Option<String>,
    /// Frame indices (over every frame of the topic or video).
    pub frames: FrameRange,
    /// Times, in seconds from the first frame.
    pub time: TimeRange,
    /// Every Nth frame of those in the ranges (0 and 1: every frame).
    pub every: u64,
}

impl Default for Selection {
    fn default() -> Self {
        Selection { topic: None, frames: FrameRange::default(), time: TimeRange::default(), every: 1 }
    }
}

/// A frame as read, not yet decoded.
#[derive(Debug)]
enum Payload {
    /// A serialised MCAP message of this kind (`None`: not an image type we read).
    Message(Option<MessageKind>, Vec<u8>),
    /// A decoded video frame.
    Gray(Plane<u8>),
}

/// One frame of a recording, as read (decoding is [`Packet::decode`], so that
/// it can run on another thread).
#[derive(Debug)]
pub struct Packet {
    /// The frame's index among all frames of the topic or video, from 0.
    pub index: u64,
    /// The message's log time (MCAP) or the presentation time (video), ns.
    pub time_ns: u64,
    payload: Payload,
}

/// A decoded frame.
#[derive(Clone, Debug)]
pub struct Decoded {
    /// The image in 8-bit gray (SPEC 0).
    pub image: Plane<u8>,
    /// The image's own time stamp (`header.stamp`, `timestamp`), ns; `None` for video.
    pub stamp_ns: Option<u64>,
}

impl Packet {
    /// The serialised MCAP message (`None` for video).
    pub fn message(&self) -> Option<&[u8]> {
        match &self.payload {
            Payload::Message(_, d) => Some(d),
            Payload::Gray(_) => None,
        }
    }

    /// The frame in gray. Errors: [`Error::Unsupported`] for an encoding or
    /// format that is not read (naming it), [`Error::Message`] for a message
    /// that ends early, [`Error::InvalidImage`] / [`Error::Image`] for pixels
    /// that do not make the image they claim.
    pub fn decode(&self) -> Result<Decoded> {
        match &self.payload {
            Payload::Gray(p) => Ok(Decoded { image: p.clone(), stamp_ns: None }),
            Payload::Message(None, _) => Err(Error::Unsupported { reason: "this message type".into() }),
            Payload::Message(Some(kind), data) => {
                let msg = wire::image(*kind, data).map_err(|reason| Error::Message { reason })?;
                let stamp = match msg {
                    wire::ImageMsg::Raw { stamp_ns, .. } | wire::ImageMsg::Compressed { stamp_ns, .. } => stamp_ns,
                };
                Ok(Decoded { image: pixels::gray(&msg)?, stamp_ns: Some(stamp) })
            }
        }
    }
}

enum Source {
    Mcap(Box<mcap_in::McapSource>),
    Video(video::VideoSource),
}

/// The frames of a recording, in order; see the [module](self) documentation.
pub struct Recording {
    path: PathBuf,
    format: Format,
    source: Source,
    sel: Selection,
    /// Frames read from the source so far (the next one's index).
    read: u64,
    /// Frames in the ranges so far (for `every`).
    in_range: u64,
    first_time: Option<u64>,
    done: bool,
}

impl Recording {
    /// Opens `path` ([`format_of`] decides how) and checks the topic.
    /// Errors: [`Error::Io`] for a file that cannot be opened,
    /// [`Error::Recording`] for one that cannot be read as a recording (the
    /// reason lists the image topics when the choice is not clear),
    /// [`Error::Unsupported`] for a topic whose message type is not read.
    pub fn open(path: impl AsRef<Path>, sel: &Selection) -> Result<Self> {
        let path = path.as_ref();
        let rec_err = |reason: String| Error::Recording { path: path.to_path_buf(), reason };
        std::fs::metadata(path).map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
        let format = format_of(path).ok_or_else(|| {
            rec_err(format!("not a recording (MCAP: .mcap; video: .{})", VIDEO_EXTENSIONS.join(", .")))
        })?;
        let source = match format {
            Format::Mcap => {
                let s = mcap_in::McapSource::open(path, sel.topic.as_deref()).map_err(rec_err)?;
                if let Some(schema) = &s.schema
                    && MessageKind::of(&schema.name, &schema.message_encoding).is_none()
                {
                    return Err(Error::Unsupported {
                        reason: format!(
                            "{}: topic `{}` holds {} messages in {} encoding (read: sensor_msgs and foxglove_msgs in cdr, foxglove.* in protobuf)",
                            path.display(),
                            s.topic,
                            schema.name,
                            schema.message_encoding
                        ),
                    });
                }
                Source::Mcap(Box::new(s))
            }
            Format::Video => Source::Video(video::VideoSource::open(path).map_err(rec_err)?),
        };
        Ok(Recording {
            path: path.to_path_buf(),
            format,
            source,
            sel: sel.clone(),
            read: 0,
            in_range: 0,
            first_time: None,
            done: false,
        })
    }

    /// The file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// MCAP or video.
    pub fn format(&self) -> Format {
        self.format
    }

    /// The MCAP topic read (`None` for video).
    pub fn topic(&self) -> Option<&str> {
        match &self.source {
            Source::Mcap(s) => Some(&s.topic),
            Source::Video(_) => None,
        }
    }

    /// The schema of the topic's channel, to copy its messages (`None` for video).
    pub fn schema(&self) -> Option<&SchemaInfo> {
        match &self.source {
            Source::Mcap(s) => s.schema.as_ref(),
            Source::Video(_) => None,
        }
    }

    /// Messages on the topic, or frames in the video, when the file says.
    pub fn total(&self) -> Option<u64> {
        match &self.source {
            Source::Mcap(s) => s.total,
            Source::Video(v) => v.total,
        }
    }

    /// Messages (frames) read so far, taken or not.
    pub fn position(&self) -> u64 {
        self.read
    }

    /// Whether frames come in log-time order (an MCAP file without a summary
    /// is read in file order; a video in presentation order).
    pub fn log_time_order(&self) -> bool {
        match &self.source {
            Source::Mcap(s) => s.log_time_order(),
            Source::Video(_) => true,
        }
    }

    /// The first `sensor_msgs/msg/CameraInfo` of the topic nearest the image
    /// topic (the longest common prefix, e.g. `/cam/camera_info` beside
    /// `/cam/image_raw`), with its topic. `Ok(None)` when there is none or
    /// for video; an error when it is malformed.
    pub fn camera_info(&self) -> Result<Option<(String, CameraInfo)>> {
        let Source::Mcap(s) = &self.source else { return Ok(None) };
        match mcap_in::first_message_of(&self.path, "sensor_msgs/msg/CameraInfo", &s.topic) {
            None => Ok(None),
            Some((topic, data)) => match wire::camera_info(&data) {
                Ok(info) => Ok(Some((topic, info))),
                Err(reason) => Err(Error::Message { reason: format!("{topic}: {reason}") }),
            },
        }
    }

    fn next_raw(&mut self) -> Option<std::result::Result<(u64, Payload), String>> {
        match &mut self.source {
            Source::Mcap(s) => s.next_message().map(|r| r.map(|m| (m.log_time, Payload::Message(m.kind, m.data)))),
            Source::Video(v) => v.next_frame().map(|r| r.map(|f| (f.time_ns, Payload::Gray(f.image)))),
        }
    }
}

impl Iterator for Recording {
    type Item = Result<Packet>;

    fn next(&mut self) -> Option<Result<Packet>> {
        loop {
            if self.done || self.sel.frames.end.is_some_and(|e| self.read >= e) {
                self.done = true;
                return None;
            }
            let (time_ns, payload) = match self.next_raw()? {
                Ok(x) => x,
                Err(reason) => {
                    self.done = true;
                    return Some(Err(Error::Recording { path: self.path.clone(), reason }));
                }
            };
            let index = self.read;
            self.read += 1;
            let first = *self.first_time.get_or_insert(time_ns);
            let secs = time_ns.saturating_sub(first) as f64 / 1e9;
            if index < self.sel.frames.start || self.sel.time.start.is_some_and(|s| secs < s) {
                continue;
            }
            if self.sel.time.end.is_some_and(|e| secs >= e) {
                if self.log_time_order() {
                    self.done = true;
                    return None;
                }
                continue;
            }
            let k = self.in_range;
            self.in_range += 1;
            if !k.is_multiple_of(self.sel.every.max(1)) {
                continue;
            }
            return Some(Ok(Packet { index, time_ns, payload }));
        }
    }
}
