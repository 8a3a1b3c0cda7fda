//! # lfast — the L-FAST feature detector
//!
//! An improved adaptive Canny edge detector, a corner test on its edge map
//! (L-FAST), ORB descriptors and an image pyramid, after Lu et al., Sensors
//! 2022, 22(19) 7127, with every choice the paper leaves open fixed by the
//! project's specification; "SPEC n" in these docs names its stage n, and the
//! package's `docs/algorithm.md` describes every stage. This crate's CPU path
//! ([`cpu`]) is the reference the GPU passes are checked against bit for bit.
//!
//! ```
//! use lfast::{Backend, Config, Detector};
//! let det = Detector::new(Config { n_features: 500, ..Default::default() }, Backend::Cpu)?;
//! let img = lfast::Plane::<u8>::new(64, 48); // a camera frame: lfast::GrayView::new(w, h, stride, &bytes)
//! let (keypoints, descriptors) = det.detect_and_compute(img.view(), None)?;
//! assert_eq!(keypoints.len(), descriptors.len());
//! # Ok::<(), lfast::Error>(())
//! ```
//!
//! ## Cargo features
//!
//! - `gpu` (default): the wgpu compute path ([`gpu`], [`Backend::Gpu`]).
//!   Without it, [`Backend::Auto`] runs on the CPU and [`Backend::Gpu`] is an
//!   [`Error::Unsupported`].
//! - `cli` (default): the `lfast` command-line tool; implies `eval` and `vo`.
//! - `eval`: the detector evaluation suites (`eval` module).
//! - `vo`: monocular visual odometry on KITTI (`vo` module).
//! - `recordings`: frames from MCAP files and videos (`recording` module;
//!   the `mcap` crate, and the `ffmpeg` program at run time for video).
//!
//! `default-features = false` is the library alone (no clap, plotters,
//! indicatif or nalgebra); `features = ["gpu"]` adds the GPU path.
//!
//! ## License
//!
//! MIT OR Apache-2.0. The package's `NOTICE` lists third-party material (the
//! rBRIEF sampling pattern as published with OpenCV).
#![warn(missing_docs)]

pub mod baseline;
#[cfg(feature = "cli")]
pub mod cli;
pub mod config;
pub mod cpu;
mod detector;
pub mod error;
#[cfg(feature = "eval")]
pub mod eval;
#[cfg(feature = "vo")]
pub mod frontend;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod image;
pub mod io;
mod keypoint;
#[cfg(feature = "recordings")]
pub mod recording;
pub mod rng;
pub mod spec;
mod stream;
#[cfg(feature = "gpu")]
#[doc(hidden)]
pub mod testing;
#[cfg(feature = "vo")]
pub mod vo;

pub use config::{Config, DescriptorKind, Mode};
pub use detector::{Backend, Detector};
pub use error::{Error, Result};
pub use image::{GrayView, Plane};
pub use keypoint::{Descriptor, KeyPoint, hamming};
pub use stream::{Done, FrameStream};
/// The wgpu this crate is built against, so embedders use the same version.
#[cfg(feature = "gpu")]
pub use wgpu;
