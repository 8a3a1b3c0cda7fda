//! Video input through the `ffmpeg` program (Debian's `ffmpeg` package).
//!
//! `ffprobe` gives the first video stream's size and pixel format; `ffmpeg`
//! then decodes it to raw frames on a pipe (8-bit gray for gray streams, so a
//! lossless gray video gives its frames exactly; RGB for colour ones, turned
//! to gray by SPEC 0's luma), one frame read at a time, and its `showinfo`
//! filter reports each frame's number, presentation time and byte position
//! on stderr. An error ffmpeg reports (a truncated file, a corrupt packet)
//! ends the stream at the frame before it, with ffmpeg's message.
//!
//! A subprocess rather than linking libav* (ffmpeg-next): no C libraries or
//! clang at build time, nothing unsafe in the process, a decoder crash on a
//! hostile file cannot take the batch down, and the same program encodes the
//! test videos.

use crate::image::{Plane, luma_bt601};
use std::io::{BufRead, BufReader, Read};
use std::path::Path;
use std::process::{Child, ChildStdout, Command, Stdio};
use std::sync::mpsc::{Receiver, channel};

/// What the stderr reader saw, in order.
enum Event {
    /// `showinfo`'s line for frame `n`.
    Frame { n: u64, pts_ns: Option<i64>, pos: Option<u64> },
    /// An error (or a warning about corrupt data) from ffmpeg.
    Damage(String),
}

/// Output pixel formats asked of ffmpeg.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Pix {
    Gray8,
    Gray16,
    Rgb24,
}

impl Pix {
    fn name(self) -> &'static str {
        match self {
            Pix::Gray8 => "gray",
            Pix::Gray16 => "gray16le",
            Pix::Rgb24 => "rgb24",
        }
    }
    fn bytes(self) -> usize {
        match self {
            Pix::Gray8 => 1,
            Pix::Gray16 => 2,
            Pix::Rgb24 => 3,
        }
    }
}

/// One decoded frame.
pub struct VideoFrame {
    /// Presentation time, ns (0 when the stream has none).
    pub time_ns: u64,
    /// The frame in gray.
    pub image: Plane<u8>,
}

/// A video's frames, decoded by an `ffmpeg` child process.
pub struct VideoSource {
    child: Child,
    stdout: BufReader<ChildStdout>,
    events: Receiver<Event>,
    width: u32,
    height: u32,
    pix: Pix,
    /// Frames in the stream, when the container says.
    pub total: Option<u64>,
    next: u64,
    last: Option<(u64, Option<i64>, Option<u64>)>,
    done: bool,
    buf: Vec<u8>,
}

fn missing(program: &str, e: std::io::Error) -> String {
    if e.kind() == std::io::ErrorKind::NotFound {
        format!("video input needs the `{program}` program on the PATH (Debian: apt-get install ffmpeg)")
    } else {
        format!("cannot run `{program}`: {e}")
    }
}

/// `2.6` -> 2_600_000_000 (decimal seconds to ns, without float rounding).
fn decimal_ns(s: &str) -> Option<i64> {
    let (neg, s) = s.strip_prefix('-').map_or((false, s), |r| (true, r));
    let (int, frac) = s.split_once('.').unwrap_or((s, ""));
    if int.is_empty() && frac.is_empty() {
        return None;
    }
    let i: i64 = if int.is_empty() { 0 } else { int.parse().ok()? };
    let mut f = 0i64;
    for c in frac.chars().chain(std::iter::repeat('0')).take(9) {
        f = f * 10 + c.to_digit(10)? as i64;
    }
    let v = i.checked_mul(1_000_000_000)?.checked_add(f)?;
    Some(if neg { -v } else { v })
}

/// The value after `key` in a showinfo line, up to the next space.
fn field<'a>(line: &'a str, key: &str) -> Option<&'a str> {
    let i = line.find(key)? + key.len();
    line[i..].split_whitespace().next()
}

/// Classifies one stderr line of `ffmpeg -loglevel level+info`.
fn event(line: &str) -> Option<Event> {
    if line.contains("[Parsed_showinfo") && line.contains("] n:") {
        let n = field(line, " n:")?.parse().ok()?;
        let pts_ns = field(line, "pts_time:").and_then(decimal_ns);
        let pos = field(line, "pos:").and_then(|p| p.parse().ok());
        return Some(Event::Frame { n, pts_ns, pos });
    }
    let level = ["[error]", "[fatal]", "[panic]", "[warning]"].into_iter().find(|l| line.contains(l))?;
    let msg = line[line.find(level)? + level.len()..].trim();
    if level == "[warning]" && !msg.to_ascii_lowercase().contains("corrupt") {
        return None;
    }
    // "[matroska,webm @ 0x55...] [error] File ended prematurely" -> "matroska,webm: File ended prematurely"
    let ctx = line.strip_prefix('[').and_then(|r| r.split_once(" @ ")).map(|(c, _)| c);
    Some(Event::Damage(match ctx {
        Some(c) if !c.contains(']') => format!("{c}: {msg}"),
        _ => msg.to_string(),
    }))
}

fn probe(path: &Path) -> Result<(u32, u32, String, Option<u64>), String> {
    let out = Command::new("ffprobe")
        .args(["-v", "error", "-select_streams", "v:0", "-show_entries", "stream=width,height,pix_fmt,nb_frames"])
        .args(["-of", "default=noprint_wrappers=1"])
        .arg(path)
        .stdin(Stdio::null())
        .output()
        .map_err(|e| missing("ffprobe", e))?;
    let text = String::from_utf8_lossy(&out.stdout);
    let get = |k: &str| text.lines().find_map(|l| l.strip_prefix(k).and_then(|r| r.strip_prefix('=')));
    let (Some(w), Some(h)) = (get("width").and_then(|v| v.parse().ok()), get("height").and_then(|v| v.parse().ok()))
    else {
        let err = String::from_utf8_lossy(&out.stderr);
        let err = err.lines().last().unwrap_or("").trim();
        return Err(if err.is_empty() {
            "no video stream".to_string()
        } else {
            format!("not a readable video: {err}")
        });
    };
    let pix = get("pix_fmt").unwrap_or("").to_string();
    Ok((w, h, pix, get("nb_frames").and_then(|v| v.parse().ok())))
}

impl VideoSource {
    /// Starts decoding `path`. Errors are the reason only.
    pub fn open(path: &Path) -> Result<Self, String> {
        let (width, height, pix_fmt, total) = probe(path)?;
        crate::image::check_size(width, height).map_err(|e| e.to_string())?;
        let pix = match pix_fmt.as_str() {
            "gray" => Pix::Gray8,
            p if p.starts_with("gray") => Pix::Gray16,
            _ => Pix::Rgb24,
        };
        let mut child = Command::new("ffmpeg")
            .args(["-nostdin", "-hide_banner", "-nostats", "-loglevel", "repeat+level+info", "-i"])
            .arg(path)
            .args(["-map", "0:v:0", "-an", "-sn", "-dn", "-fps_mode", "passthrough", "-vf", "showinfo"])
            .args(["-f", "rawvideo", "-pix_fmt", pix.name(), "-"])
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| missing("ffmpeg", e))?;
        let stdout = BufReader::with_capacity(1 << 20, child.stdout.take().expect("piped stdout"));
        let stderr = child.stderr.take().expect("piped stderr");
        let (tx, events) = channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines() {
                let Ok(line) = line else { break };
                if let Some(e) = event(&line)
                    && tx.send(e).is_err()
                {
                    break;
                }
            }
        });
        let buf = vec![0; width as usize * height as usize * pix.bytes()];
        Ok(VideoSource { child, stdout, events, width, height, pix, total, next: 0, last: None, done: false, buf })
    }

    fn stopped(&self, why: &str) -> String {
        match self.last {
            None => format!("no frame could be read: {why}"),
            Some((n, pts, pos)) => {
                let t = pts.map_or(String::new(), |p| format!(" at {:.3} s", p as f64 / 1e9));
                let at = pos.map_or(String::new(), |p| format!(", byte {p}"));
                format!("reading stopped after frame {n}{t}{at}: {why}")
            }
        }
    }

    /// Waits for ffmpeg's verdict once its output has ended.
    fn finish(&mut self) -> Option<String> {
        let damage: Vec<String> = self
            .events
            .iter()
            .filter_map(|e| match e {
                Event::Damage(m) => Some(m),
                Event::Frame { .. } => None,
            })
            .collect();
        let status = self.child.wait();
        if let Some(first) = damage.first() {
            return Some(first.clone());
        }
        match status {
            Ok(s) if s.success() => None,
            Ok(s) => Some(format!("ffmpeg exited with {s}")),
            Err(e) => Some(format!("ffmpeg: {e}")),
        }
    }

    /// The next frame; an error (saying where reading stopped) ends the stream.
    pub fn next_frame(&mut self) -> Option<Result<VideoFrame, String>> {
        if self.done {
            return None;
        }
        let mut got = 0;
        while got < self.buf.len() {
            match self.stdout.read(&mut self.buf[got..]) {
                Ok(0) => break,
                Ok(n) => got += n,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(e) => {
                    self.done = true;
                    return Some(Err(self.stopped(&format!("reading ffmpeg's output: {e}"))));
                }
            }
        }
        if got < self.buf.len() {
            self.done = true;
            let why = self.finish();
            return match (why, got) {
                (None, 0) => None,
                (None, _) => Some(Err(self.stopped("ffmpeg's output ended inside a frame"))),
                (Some(w), _) => Some(Err(self.stopped(&w))),
            };
        }
        // this frame's showinfo line, unless an error came first
        loop {
            match self.events.recv() {
                Ok(Event::Frame { n, pts_ns, pos }) if n == self.next => {
                    self.last = Some((n, pts_ns, pos));
                    break;
                }
                Ok(Event::Frame { .. }) => continue,
                Ok(Event::Damage(m)) => {
                    self.done = true;
                    let _ = self.child.kill();
                    let _ = self.child.wait();
                    return Some(Err(self.stopped(&m)));
                }
                Err(_) => {
                    self.done = true;
                    let why = self.finish().unwrap_or_else(|| "ffmpeg reported no frame information".into());
                    return Some(Err(self.stopped(&why)));
                }
            }
        }
        let (w, h) = (self.width, self.height);
        let data: Vec<u8> = match self.pix {
            Pix::Gray8 => self.buf.clone(),
            Pix::Gray16 => self.buf.chunks_exact(2).map(|p| p[1]).collect(),
            Pix::Rgb24 => self.buf.chunks_exact(3).map(|p| luma_bt601(p[0], p[1], p[2])).collect(),
        };
        self.next += 1;
        let time_ns = self.last.and_then(|l| l.1).unwrap_or(0).max(0) as u64;
        match Plane::from_vec(w, h, data) {
            Ok(image) => Some(Ok(VideoFrame { time_ns, image })),
            Err(e) => {
                self.done = true;
                Some(Err(e.to_string()))
            }
        }
    }
}

impl Drop for VideoSource {
    fn drop(&mut self) {
        if !self.done {
            let _ = self.child.kill();
        }
        let _ = self.child.wait();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimal_seconds_to_nanoseconds() {
        assert_eq!(decimal_ns("2.6"), Some(2_600_000_000));
        assert_eq!(decimal_ns("0"), Some(0));
        assert_eq!(decimal_ns("12.000000001"), Some(12_000_000_001));
        assert_eq!(decimal_ns("0.1234567891"), Some(123_456_789));
        assert_eq!(decimal_ns("-0.5"), Some(-500_000_000));
        assert_eq!(decimal_ns("NOPTS"), None);
        assert_eq!(decimal_ns(""), None);
    }

    #[test]
    fn stderr_lines_become_frames_and_damage() {
        let l =
            "[Parsed_showinfo_0 @ 0x55a1] [info] n:  27 pts:   2700 pts_time:2.7     pos:  5582759 fmt:gray s:1241x376";
        match event(l) {
            Some(Event::Frame { n, pts_ns, pos }) => {
                assert_eq!((n, pts_ns, pos), (27, Some(2_700_000_000), Some(5582759)))
            }
            _ => panic!("a frame"),
        }
        match event("[matroska,webm @ 0x55a18dc5b940] [error] File ended prematurely") {
            Some(Event::Damage(m)) => assert_eq!(m, "matroska,webm: File ended prematurely"),
            _ => panic!("damage"),
        }
        match event("[warning] t.avi: corrupt input packet in stream 0") {
            Some(Event::Damage(m)) => assert_eq!(m, "t.avi: corrupt input packet in stream 0"),
            _ => panic!("damage"),
        }
        assert!(event("[info] Stream mapping:").is_none());
        assert!(event("[Parsed_showinfo_0 @ 0x55a1] [info] color_range:pc color_space:unknown").is_none());
        assert!(event("[swscaler @ 0x1] [warning] deprecated pixel format used").is_none());
    }
}
