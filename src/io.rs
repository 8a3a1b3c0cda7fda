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
    d.iter().map(|b| format!("{b:02x}")).collect()
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
