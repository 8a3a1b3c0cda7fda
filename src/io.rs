//! Writing features: JSON with OpenCV KeyPoint field names, atomic file writes.

use crate::error::{Error, Result};
use crate::keypoint::{Descriptor, KeyPoint};
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::path::Path;

/// One image's features as written by `lfast detect`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Features {
    /// The image file.
    pub image: String,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Keypoints in SPEC 9 order.
    pub keypoints: Vec<KeyPoint>,
    /// `descriptors[i]` of `keypoints[i]`, 64 hex digits, byte 0 first.
    pub descriptors: Vec<String>,
    /// Which frame of a recording (`image` is then the recording); absent for image files.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frame: Option<FrameInfo>,
}

/// Where a frame of a recording (an MCAP file, a video) comes from.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct FrameInfo {
    /// The MCAP topic; absent for video.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub topic: Option<String>,
    /// The frame's index among all frames of the topic or video, from 0.
    pub index: u64,
    /// The message's log time (MCAP) or the presentation time (video), ns.
    pub time_ns: u64,
    /// The image's own time stamp (`header.stamp`, `timestamp`), ns; absent for video.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stamp_ns: Option<u64>,
}

/// Lower-case hex of a descriptor, byte 0 first.
///
/// ```
/// let mut d = [0u8; 32];
/// d[0] = 0xa5;
/// assert!(lfast::io::hex(&d).starts_with("a500"));
/// ```
pub fn hex(d: &Descriptor) -> String {
    let mut s = String::with_capacity(2 * d.len());
    push_hex(&mut s, d);
    s
}

/// Appends [`hex`] of `d` to `out`.
fn push_hex(out: &mut String, d: &Descriptor) {
    const DIGITS: &[u8; 16] = b"0123456789abcdef";
    let mut digits = [0u8; 64];
    for (pair, &b) in digits.chunks_exact_mut(2).zip(d) {
        (pair[0], pair[1]) = (DIGITS[(b >> 4) as usize], DIGITS[(b & 15) as usize]);
    }
    out.push_str(std::str::from_utf8(&digits[..2 * d.len()]).expect("hex digits are ASCII"));
}

/// The JSON text of one image's features.
pub fn features_json(image: &Path, width: u32, height: u32, kps: &[KeyPoint], desc: &[Descriptor]) -> String {
    frame_features_json(image, None, width, height, kps, desc)
}

/// The JSON text of the features of one image file (`frame` = `None`) or of
/// one frame of the recording `image`: [`Features`] as `serde_json::to_string_pretty`
/// lays it out, byte for byte, written directly (a 3840x2160 frame's 20,000
/// keypoints make ~9 MB of it: in about half the time serde's pretty printer
/// took, with no copy of the keypoints and no string per descriptor).
pub fn frame_features_json(
    image: &Path,
    frame: Option<&FrameInfo>,
    width: u32,
    height: u32,
    kps: &[KeyPoint],
    desc: &[Descriptor],
) -> String {
    let mut out = String::new();
    frame_features_json_into(&mut out, image, frame, width, height, kps, desc);
    out
}

/// [`frame_features_json`] appended to `out`: a writer that keeps one
/// `String` for every frame allocates (and pages in) nothing once it is large enough.
pub fn frame_features_json_into(
    out: &mut String,
    image: &Path,
    frame: Option<&FrameInfo>,
    width: u32,
    height: u32,
    kps: &[KeyPoint],
    desc: &[Descriptor],
) {
    use std::fmt::Write as _;
    out.reserve(256 + kps.len() * 240 + desc.len() * 72);
    out.push_str("{\n  \"image\": ");
    json_str(out, &image.display().to_string());
    let _ = write!(out, ",\n  \"width\": {width},\n  \"height\": {height},\n  \"keypoints\": [");
    for (i, k) in kps.iter().enumerate() {
        out.push_str(if i == 0 { "\n" } else { ",\n" });
        out.push_str("    {\n      \"pt\": [\n        ");
        json_f32(out, k.pt.x);
        out.push_str(",\n        ");
        json_f32(out, k.pt.y);
        out.push_str("\n      ],\n      \"size\": ");
        json_f32(out, k.size);
        out.push_str(",\n      \"angle\": ");
        json_f32(out, k.angle);
        out.push_str(",\n      \"response\": ");
        json_f32(out, k.response);
        let _ = write!(out, ",\n      \"octave\": {},\n      \"class_id\": {}\n    }}", k.octave, k.class_id);
    }
    out.push_str(if kps.is_empty() { "],\n  \"descriptors\": [" } else { "\n  ],\n  \"descriptors\": [" });
    for (i, d) in desc.iter().enumerate() {
        out.push_str(if i == 0 { "\n    \"" } else { ",\n    \"" });
        push_hex(out, d);
        out.push('"');
    }
    out.push_str(if desc.is_empty() { "]" } else { "\n  ]" });
    if let Some(f) = frame {
        out.push_str(",\n  \"frame\": {\n    ");
        if let Some(t) = &f.topic {
            out.push_str("\"topic\": ");
            json_str(out, t);
            out.push_str(",\n    ");
        }
        let _ = write!(out, "\"index\": {},\n    \"time_ns\": {}", f.index, f.time_ns);
        if let Some(st) = f.stamp_ns {
            let _ = write!(out, ",\n    \"stamp_ns\": {st}");
        }
        out.push_str("\n  }");
    }
    out.push_str("\n}");
}

/// A JSON string as serde_json escapes it.
fn json_str(out: &mut String, s: &str) {
    out.push_str(&serde_json::to_string(s).expect("a str always serialises"));
}

/// An f32 as serde_json writes it: its shortest round-trip digits, `null` when not finite.
fn json_f32(out: &mut String, v: f32) {
    use serde_json::ser::Formatter as _;
    if !v.is_finite() {
        out.push_str("null");
        return;
    }
    // the longest f32 serde_json writes, "-1.1754944e-38", is 14 bytes
    let mut buf = std::io::Cursor::new([0u8; 32]);
    serde_json::ser::CompactFormatter.write_f32(&mut buf, v).expect("an f32 fits 32 bytes");
    let n = buf.position() as usize;
    out.push_str(std::str::from_utf8(&buf.get_ref()[..n]).expect("digits are ASCII"));
}

/// Writes `bytes` to `path` atomically: see [`write_atomic_with`].
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic_with(path, |f| f.write_all(bytes))
}

/// Writes `path` atomically: `fill` writes the content into a new temporary
/// file beside it (`.NAME.PID-RANDOM.tmp`, created exclusively), which is then
/// synced to disk and renamed over `path`. Whatever fails (`fill`, say on a
/// full disk, the sync or the rename), the temporary file is removed and
/// `path` keeps what it had: a reader sees the old file or the new one, never
/// a part. The error names `path`.
///
/// ```
/// let dir = tempfile::tempdir().unwrap();
/// let p = dir.path().join("a.txt");
/// lfast::io::write_atomic(&p, b"old").unwrap();
/// let full = std::io::Error::from(std::io::ErrorKind::StorageFull);
/// let e = lfast::io::write_atomic_with(&p, |f| {
///     std::io::Write::write_all(f, b"ne")?;
///     Err(full)
/// })
/// .unwrap_err();
/// assert!(lfast::io::is_disk_full(&e));
/// assert_eq!(std::fs::read(&p).unwrap(), b"old");
/// assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
/// ```
pub fn write_atomic_with(path: &Path, fill: impl FnOnce(&mut std::fs::File) -> std::io::Result<()>) -> Result<()> {
    let mut f = AtomicFile::create(path)?;
    fill(f.file()).map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
    f.commit()
}

/// A file written over time and put in place at once: the writes go to a
/// temporary file beside `path` (as [`write_atomic_with`]'s), which
/// [`commit`](Self::commit) syncs and renames over `path`. Dropped without a
/// commit (an error, an interrupt), it is removed and `path` keeps what it had.
#[derive(Debug)]
pub struct AtomicFile {
    path: std::path::PathBuf,
    tmp: tempfile::NamedTempFile,
}

impl AtomicFile {
    /// Creates the temporary file for `path`.
    pub fn create(path: &Path) -> Result<Self> {
        let io = |source| Error::Io { path: path.to_path_buf(), source };
        let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        let prefix = format!(".{name}.{}-", std::process::id());
        let mut b = tempfile::Builder::new();
        b.prefix(&prefix).suffix(TMP_SUFFIX).rand_bytes(6);
        // the mode a plain File::create gives (0666 less the umask), not tempfile's 0600
        #[cfg(unix)]
        b.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o666));
        // On every early return the NamedTempFile drops, which removes it.
        let tmp = b.tempfile_in(dir).map_err(io)?;
        Ok(AtomicFile { path: path.to_path_buf(), tmp })
    }

    /// The temporary file, to write to.
    pub fn file(&mut self) -> &mut std::fs::File {
        self.tmp.as_file_mut()
    }

    /// The destination.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Syncs the temporary file and renames it over the destination.
    pub fn commit(self) -> Result<()> {
        let io = |source| Error::Io { path: self.path.clone(), source };
        self.tmp.as_file().sync_all().map_err(io)?;
        let path = self.path.clone();
        self.tmp.persist(&path).map_err(|e| Error::Io { path, source: e.error })?;
        Ok(())
    }
}

/// The suffix of [`write_atomic_with`]'s temporary files.
pub const TMP_SUFFIX: &str = ".tmp";

/// Whether `e` says that the disk is full (ENOSPC) or a quota is exhausted
/// (EDQUOT): no later write to that file system can succeed until space is freed.
pub fn is_disk_full(e: &Error) -> bool {
    match e {
        Error::Io { source, .. } => {
            matches!(source.kind(), std::io::ErrorKind::StorageFull | std::io::ErrorKind::QuotaExceeded)
        }
        _ => false,
    }
}

/// One row of text per keypoint: `x,y,size,angle,response,octave,class_id,descriptor`
/// (OpenCV KeyPoint fields, then the descriptor as 64 hex digits), with a header line.
///
/// ```
/// let kp = lfast::KeyPoint::new(1.5, 2.5, 31.0);
/// let csv = lfast::io::features_csv(&[kp], &[[0u8; 32]]);
/// assert!(csv.starts_with("x,y,size,angle,response,octave,class_id,descriptor\n1.5,2.5,31,-1,0,0,-1,00"));
/// ```
pub fn features_csv(kps: &[KeyPoint], desc: &[Descriptor]) -> String {
    let mut s = String::from("x,y,size,angle,response,octave,class_id,descriptor\n");
    for (i, k) in kps.iter().enumerate() {
        let d = desc.get(i).map(hex).unwrap_or_default();
        s.push_str(&format!(
            "{},{},{},{},{},{},{},{d}\n",
            k.pt.x, k.pt.y, k.size, k.angle, k.response, k.octave, k.class_id
        ));
    }
    s
}

/// A NumPy `.npy` (format version 1.0) file of a C-order 2-D array:
/// `descr` is the dtype (`"<f4"`, `"|u1"`), `data` the little-endian bytes.
fn npy(descr: &str, rows: usize, cols: usize, data: &[u8]) -> Vec<u8> {
    let mut header = format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': ({rows}, {cols}), }}");
    // magic (6) + version (2) + header length (2) + header, padded with spaces
    // and ended by '\n' to a multiple of 64 bytes.
    let unpadded = 10 + header.len() + 1;
    header.push_str(&" ".repeat((64 - unpadded % 64) % 64));
    header.push('\n');
    let mut out = Vec::with_capacity(10 + header.len() + data.len());
    out.extend_from_slice(b"\x93NUMPY\x01\x00");
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    out.extend_from_slice(data);
    out
}

/// Keypoints as a `.npy` float32 array of shape (N, 7): x, y, size, angle,
/// response, octave, class_id.
///
/// ```
/// let b = lfast::io::keypoints_npy(&[lfast::KeyPoint::new(1.0, 2.0, 7.0)]);
/// assert!(b.starts_with(b"\x93NUMPY\x01\x00"));
/// let hlen = u16::from_le_bytes([b[8], b[9]]) as usize;
/// assert_eq!((10 + hlen) % 64, 0);
/// assert!(std::str::from_utf8(&b[10..10 + hlen]).unwrap().contains("'shape': (1, 7)"));
/// assert_eq!(b.len(), 10 + hlen + 7 * 4);
/// ```
pub fn keypoints_npy(kps: &[KeyPoint]) -> Vec<u8> {
    let mut data = Vec::with_capacity(kps.len() * 7 * 4);
    for k in kps {
        for v in [k.pt.x, k.pt.y, k.size, k.angle, k.response, k.octave as f32, k.class_id as f32] {
            data.extend_from_slice(&v.to_le_bytes());
        }
    }
    npy("<f4", kps.len(), 7, &data)
}

/// Descriptors as a `.npy` uint8 array of shape (N, 32).
pub fn descriptors_npy(desc: &[Descriptor]) -> Vec<u8> {
    npy("|u1", desc.len(), 32, desc.as_flattened())
}

/// A float in a form OpenCV's YAML reader takes as a real (always a `.` or an exponent).
fn yaml_real(v: f32) -> String {
    if v.is_finite() {
        format!("{v:?}")
    } else if v.is_nan() {
        ".Nan".into()
    } else if v > 0.0 {
        ".Inf".into()
    } else {
        "-.Inf".into()
    }
}

/// OpenCV FileStorage YAML (`cv2.FileStorage(path, cv2.FILE_STORAGE_READ)` reads
/// it): `keypoints`, one `[x, y, size, angle, response, octave, class_id]`
/// sequence per keypoint as `cv::write(fs, name, keypoints)` writes them, and
/// `descriptors`, an N x 32 `CV_8U` `!!opencv-matrix`.
///
/// ```
/// let y = lfast::io::features_yaml(&[lfast::KeyPoint::new(1.0, 2.0, 7.0)], &[[7u8; 32]]);
/// assert!(y.starts_with("%YAML:1.0\n---\n"));
/// assert!(y.contains("rows: 1") && y.contains("cols: 32") && y.contains("dt: u"));
/// ```
pub fn features_yaml(kps: &[KeyPoint], desc: &[Descriptor]) -> String {
    let mut s = String::from("%YAML:1.0\n---\n");
    if kps.is_empty() {
        s.push_str("keypoints: []\n");
    } else {
        s.push_str("keypoints:\n");
        for k in kps {
            s.push_str(&format!(
                "   - [ {}, {}, {}, {}, {}, {}, {} ]\n",
                yaml_real(k.pt.x),
                yaml_real(k.pt.y),
                yaml_real(k.size),
                yaml_real(k.angle),
                yaml_real(k.response),
                k.octave,
                k.class_id
            ));
        }
    }
    s.push_str(&format!("descriptors: !!opencv-matrix\n   rows: {}\n   cols: 32\n   dt: u\n   data: [", desc.len()));
    let bytes = desc.as_flattened();
    for (i, b) in bytes.iter().enumerate() {
        if i > 0 {
            s.push(',');
        }
        s.push_str(if i % 32 == 0 { "\n       " } else { " " });
        s.push_str(&b.to_string());
    }
    s.push_str(" ]\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What serde_json's pretty printer writes for the same features.
    fn serde_pretty(image: &Path, frame: Option<&FrameInfo>, kps: &[KeyPoint], desc: &[Descriptor]) -> String {
        let f = Features {
            image: image.display().to_string(),
            width: 3840,
            height: 7,
            keypoints: kps.to_vec(),
            descriptors: desc.iter().map(hex).collect(),
            frame: frame.cloned(),
        };
        serde_json::to_string_pretty(&f).unwrap()
    }

    #[test]
    fn features_json_is_serde_pretty_byte_for_byte() {
        let mut rng = crate::rng::SplitMix64::new(7);
        let mut next = move || rng.next_u64() as u32;
        // every class of f32: random bits (NaN and infinities too), integers, tiny, huge, signed zeros
        let mut specials = vec![0.0f32, -0.0, 1.0, -1.0, 31.0, 359.99997, 1e-45, f32::MIN_POSITIVE, f32::MAX, f32::MIN];
        specials.extend([f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 0.1, 1e7, 1.5e16, 123456.79, -1.1754944e-38]);
        let mut float =
            |i: usize| if i.is_multiple_of(3) { specials[i / 3 % specials.len()] } else { f32::from_bits(next()) };
        let mut kps = Vec::new();
        for i in 0..300 {
            let mut k = KeyPoint::new(float(i), float(i + 1), float(i + 2));
            (k.angle, k.response) = (float(i + 3), float(i + 4));
            (k.octave, k.class_id) = (i as i32 % 9 - 1, [-1, 0, i32::MAX, i32::MIN][i % 4]);
            kps.push(k);
        }
        let desc: Vec<Descriptor> = (0..300).map(|i| std::array::from_fn(|j| (i * 31 + j * 7) as u8)).collect();
        let frames = [
            None,
            Some(FrameInfo { topic: None, index: 0, time_ns: 0, stamp_ns: None }),
            Some(FrameInfo {
                topic: Some("/cam/\"left\"\u{1}é".into()),
                index: 7,
                time_ns: u64::MAX,
                stamp_ns: Some(5),
            }),
            Some(FrameInfo { topic: Some(String::new()), index: 1, time_ns: 2, stamp_ns: None }),
            Some(FrameInfo { topic: None, index: 1, time_ns: 2, stamp_ns: Some(3) }),
        ];
        let names = ["frames/000000.png", "a \"quoted\"\\path\twith\u{7f}\u{1f} and ünïcode.jpg", ""];
        for (n, frame) in frames.iter().enumerate() {
            let image = Path::new(names[n % names.len()]);
            for (nk, nd) in [(0, 0), (1, 1), (2, 0), (0, 3), (300, 300), (5, 2)] {
                let (k, d) = (&kps[..nk], &desc[..nd]);
                let got = frame_features_json(image, frame.as_ref(), 3840, 7, k, d);
                assert_eq!(
                    got,
                    serde_pretty(image, frame.as_ref(), k, d),
                    "{nk} keypoints, {nd} descriptors, {frame:?}"
                );
            }
        }
    }

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> =
            std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        v.sort();
        v
    }

    #[test]
    fn write_atomic_replaces_the_file_with_the_mode_of_a_plain_create() {
        let dir = tempfile::tempdir().unwrap();
        let (p, plain) = (dir.path().join("a.json"), dir.path().join("plain"));
        write_atomic(&p, b"first").unwrap();
        write_atomic(&p, b"second").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"second");
        std::fs::write(&plain, b"").unwrap();
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
            assert_eq!(mode(&p), mode(&plain));
        }
        assert_eq!(names(dir.path()), ["a.json", "plain"]);
    }

    #[test]
    fn every_failure_leaves_no_temporary_file_and_the_old_content() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("x.json");
        // nothing there yet: a failing writer creates nothing
        let quota = std::io::Error::from(std::io::ErrorKind::QuotaExceeded);
        let e = write_atomic_with(&p, |f| f.write_all(&[7; 5000]).and(Err(quota))).unwrap_err();
        assert!(is_disk_full(&e), "{e}");
        assert!(e.to_string().contains("x.json"), "{e}");
        assert!(names(dir.path()).is_empty(), "{:?}", names(dir.path()));
        // an old file stays whole after a failure half-way through the new one
        write_atomic(&p, b"old").unwrap();
        for kind in [std::io::ErrorKind::StorageFull, std::io::ErrorKind::PermissionDenied] {
            let e = write_atomic_with(&p, |f| f.write_all(b"ne").and(Err(kind.into()))).unwrap_err();
            assert_eq!(is_disk_full(&e), kind == std::io::ErrorKind::StorageFull);
            assert_eq!(std::fs::read(&p).unwrap(), b"old");
            assert_eq!(names(dir.path()), ["x.json"]);
        }
        // the rename fails (a directory is in the way): the temporary file goes too
        let d = dir.path().join("d.json");
        std::fs::create_dir(&d).unwrap();
        std::fs::write(d.join("inside"), b"").unwrap();
        let e = write_atomic(&d, b"data").unwrap_err();
        assert!(!is_disk_full(&e) && e.to_string().contains("d.json"), "{e}");
        assert_eq!(names(dir.path()), ["d.json", "x.json"]);
        // no directory to write in
        assert!(write_atomic(&dir.path().join("missing/y.json"), b"").is_err());
        assert_eq!(names(dir.path()), ["d.json", "x.json"]);
    }

    #[test]
    fn temporary_names_hide_the_file_and_carry_the_process_id() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("frame.json");
        let mut seen = String::new();
        write_atomic_with(&p, |_| {
            seen = names(dir.path()).concat();
            Ok(())
        })
        .unwrap();
        let prefix = format!(".frame.json.{}-", std::process::id());
        assert!(seen.starts_with(&prefix) && seen.ends_with(TMP_SUFFIX), "{seen}");
        assert_eq!(seen.len(), prefix.len() + 6 + TMP_SUFFIX.len(), "{seen}");
    }

    #[test]
    fn hex_matches_format_for_every_byte() {
        for b in 0..=255u8 {
            let d = [b; 32];
            assert_eq!(hex(&d), format!("{b:02x}").repeat(32));
        }
        let d: [u8; 32] = std::array::from_fn(|i| (i * 37 + 11) as u8);
        assert_eq!(hex(&d), d.iter().map(|b| format!("{b:02x}")).collect::<String>());
    }
}
