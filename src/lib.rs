//! # lfast — the L-FAST feature detector
//!
//! An improved adaptive Canny edge detector, a corner test on its edge map
//! (L-FAST), ORB descriptors and an image pyramid, after Lu et al., Sensors
//! 2022, 22(19) 7127, with every open choice fixed by SPEC.md and
//! docs/algorithm.md. This crate's CPU path ([`cpu`]) is the reference the GPU
//! passes are checked against bit for bit.
#![warn(missing_docs)]

pub mod baseline;
pub mod cli;
pub mod config;
pub mod cpu;
mod detector;
pub mod error;
pub mod eval;
pub mod frontend;
pub mod image;
pub mod io;
mod keypoint;
pub mod rng;
pub mod spec;
#[doc(hidden)]
pub mod testing;
pub mod gpu;
pub mod vo;

pub use config::{Config, Mode};
pub use detector::{Backend, Detector};
pub use error::{Error, Result};
pub use image::{GrayView, Plane};
pub use keypoint::{Descriptor, KeyPoint, hamming};
/// The wgpu this crate is built against, so embedders use the same version.
pub use wgpu;
