//! `lfast vo` over a recording: the frames of an MCAP topic or a video, the
//! intrinsics from the `sensor_msgs/msg/CameraInfo` topic beside the images
//! (or `--calib`), the ground truth from `--poses`.

use super::{CliError, VoArgs};
use crate::recording::{Recording, Selection};
use crate::vo::kitti::{self, Calib};
use crate::vo::{Pose, VoError, VoOptions, VoRun};
use nalgebra::Matrix3x4;
use std::path::PathBuf;

/// A recording ready for runs: what to read, the intrinsics, the ground truth.
pub(super) struct Source {
    path: PathBuf,
    sel: Selection,
    calib: Calib,
    gt: Option<Vec<Pose>>,
}

/// P of a pinhole camera: `[fx 0 cx 0; 0 fy cy 0; 0 0 1 0]`.
fn pinhole(fx: f64, fy: f64, cx: f64, cy: f64) -> Calib {
    Calib { p0: Matrix3x4::new(fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0) }
}

fn usage(e: impl std::fmt::Display) -> CliError {
    CliError::Inputs(e.to_string())
}

impl Source {
    /// Opens the recording once to check it and find its intrinsics.
    pub(super) fn new(a: &VoArgs) -> Result<Self, CliError> {
        let range = a.frames.unwrap_or_default();
        let sel = Selection { topic: a.topic.clone(), frames: range, time: a.time.unwrap_or_default(), every: a.every };
        let rec = Recording::open(&a.seq_dir, &sel).map_err(usage)?;
        let calib = match &a.calib {
            Some(p) => kitti::read_calib(p).map_err(|e| usage(e.to_string()))?,
            None => match rec.camera_info().map_err(usage)? {
                Some((topic, info)) => {
                    // K of the image; P where K is not filled in
                    let (fx, fy, cx, cy) = if info.k[0] > 0.0 && info.k[4] > 0.0 {
                        (info.k[0], info.k[4], info.k[2], info.k[5])
                    } else {
                        (info.p[0], info.p[5], info.p[2], info.p[6])
                    };
                    if !(fx > 0.0 && fy > 0.0) {
                        return Err(usage(format!(
                            "{}: the CameraInfo on {topic} has no focal length (K and P are zero); give --calib FILE",
                            a.seq_dir.display()
                        )));
                    }
                    if !a.common.quiet {
                        println!(
                            "intrinsics from {topic}: fx {fx}, fy {fy}, cx {cx}, cy {cy} ({}x{})",
                            info.width, info.height
                        );
                    }
                    pinhole(fx, fy, cx, cy)
                }
                None => {
                    let what = match rec.topic() {
                        Some(t) => format!("no sensor_msgs/msg/CameraInfo topic beside {t}"),
                        None => "a video has no camera calibration".to_string(),
                    };
                    return Err(usage(format!(
                        "{}: {what}; give the intrinsics with --calib FILE (KITTI calib.txt: P0)",
                        a.seq_dir.display()
                    )));
                }
            },
        };
        let gt = match &a.poses {
            Some(p) => Some(kitti::read_poses(p).map_err(|e| usage(e.to_string()))?),
            None => None,
        };
        Ok(Source { path: a.seq_dir.clone(), sel, calib, gt })
    }

    /// One run over the recording.
    pub(super) fn run(&self, o: &VoOptions) -> Result<VoRun, VoError> {
        let rec = Recording::open(&self.path, &self.sel)?;
        let path = self.path.clone();
        let frames = rec.map(|p| {
            let stop =
                |e: crate::Error| VoError::Sequence { path: path.clone(), reason: super::super::report::reason(&e) };
            let p = p.map_err(stop)?;
            let d = p.decode().map_err(|e| VoError::Sequence {
                path: path.clone(),
                reason: format!("frame {}: {}", p.index, super::super::report::reason(&e)),
            })?;
            Ok((p.index as usize, format!("{:06}_{}", p.index, p.time_ns), d.image))
        });
        // the selection already took the range: the options' count is not applied twice
        let o = VoOptions { start: 0, frames: None, ..o.clone() };
        crate::vo::run_frames(&self.path, frames, self.calib, self.gt.as_deref(), &o)
    }
}
