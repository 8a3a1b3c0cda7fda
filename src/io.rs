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
}

/// Lower-case hex of a descriptor, byte 0 first.
///
/// ```
/// let mut d = [0u8; 32];
/// d[0] = 0xa5;
/// assert!(lfast::io::hex(&d).starts_with("a500"));
/// ```
pub fn hex(d: &Descriptor) -> String {
    const DIGITS: &[u8; 16] = b"0123456789abcdef";
    let mut s = String::with_capacity(2 * d.len());
    for &b in d {
        s.push(DIGITS[(b >> 4) as usize] as char);
        s.push(DIGITS[(b & 15) as usize] as char);
    }
    s
}

/// The JSON text of one image's features.
pub fn features_json(image: &Path, width: u32, height: u32, kps: &[KeyPoint], desc: &[Descriptor]) -> String {
    let f = Features {
        image: image.display().to_string(),
        width,
        height,
        keypoints: kps.to_vec(),
        descriptors: desc.iter().map(hex).collect(),
    };
    serde_json::to_string_pretty(&f).expect("features always serialise")
}

/// Writes `bytes` to `path` through a temporary file in the same directory and
/// a rename, so an interrupted run never leaves a partial file.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let io = |source| Error::Io { path: path.to_path_buf(), source };
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp = dir.join(format!(".{name}.{}.tmp", std::process::id()));
    let mut f = std::fs::File::create(&tmp).map_err(io)?;
    f.write_all(bytes).and_then(|_| f.sync_all()).map_err(io)?;
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        io(e)
    })
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
    #[test]
    fn hex_matches_format_for_every_byte() {
        for b in 0..=255u8 {
            let d = [b; 32];
            assert_eq!(super::hex(&d), format!("{b:02x}").repeat(32));
        }
        let d: [u8; 32] = std::array::from_fn(|i| (i * 37 + 11) as u8);
        assert_eq!(super::hex(&d), d.iter().map(|b| format!("{b:02x}")).collect::<String>());
    }
}
