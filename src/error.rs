//! The crate's typed error. Every fallible public function returns [`Result`].

use std::path::PathBuf;

/// Everything that can go wrong in lfast, each variant naming what was wrong.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A configuration value is out of its valid range.
    #[error("invalid config: `{field}` {reason}")]
    InvalidConfig {
        /// The name of the field, as spelled in the TOML file.
        field: &'static str,
        /// What is wrong with it.
        reason: String,
    },
    /// A configuration file could not be parsed.
    #[error("config file {path}: {message}")]
    ConfigParse {
        /// The file.
        path: PathBuf,
        /// The parser's message.
        message: String,
    },
    /// The image cannot be processed (empty, too large, inconsistent buffer).
    #[error("invalid image ({width}x{height}): {reason}")]
    InvalidImage {
        /// Width as given.
        width: u32,
        /// Height as given.
        height: u32,
        /// What is wrong with it.
        reason: String,
    },
    /// The mask does not have the image's size.
    #[error("mask is {mask_width}x{mask_height} but the image is {width}x{height}")]
    MaskSize {
        /// Mask width.
        mask_width: u32,
        /// Mask height.
        mask_height: u32,
        /// Image width.
        width: u32,
        /// Image height.
        height: u32,
    },
    /// A caller-supplied keypoint cannot be described.
    #[error("keypoint {index}: {reason}")]
    InvalidKeypoint {
        /// Index in the slice that was passed.
        index: usize,
        /// What is wrong with it.
        reason: String,
    },
    /// Reading or writing a file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// Decoding or encoding an image file failed.
    #[error("{path}: {source}")]
    Image {
        /// The file.
        path: PathBuf,
        /// The codec's error.
        #[source]
        source: image::ImageError,
    },
    /// The ORB pattern table is malformed.
    #[error("ORB pattern, line {line}: {reason}")]
    Pattern {
        /// 1-based line number.
        line: usize,
        /// What is wrong with it.
        reason: String,
    },
    /// No GPU adapter matched (none present, or none named as asked).
    #[error("no GPU adapter: {reason}")]
    NoAdapter {
        /// What was looked for and what was found.
        reason: String,
    },
    /// The frame needs more than the device's limits allow.
    #[error("GPU limits: {reason}")]
    GpuLimits {
        /// Which limit, what was needed.
        reason: String,
    },
    /// The GPU ran out of memory.
    #[error("GPU out of memory: {reason}")]
    GpuOutOfMemory {
        /// What was being allocated.
        reason: String,
    },
    /// The device was lost (driver reset, `Device::destroy`, removal).
    #[error("GPU device lost: {reason}")]
    DeviceLost {
        /// The driver's message.
        reason: String,
    },
    /// Any other GPU failure (device request refused, validation, mapping).
    #[error("GPU error: {reason}")]
    Gpu {
        /// The message.
        reason: String,
    },
    /// A recording (an MCAP file, a video) cannot be read, or cannot be read
    /// further: the reason says where reading stopped.
    #[error("{path}: {reason}")]
    Recording {
        /// The file.
        path: PathBuf,
        /// What is wrong, and where.
        reason: String,
    },
    /// A recorded message does not hold what its type says (it ends early).
    #[error("malformed message: {reason}")]
    Message {
        /// The field where it went wrong.
        reason: String,
    },
    /// The requested combination is not available on this backend.
    #[error("not supported: {reason}")]
    Unsupported {
        /// What and why.
        reason: String,
    },
}

/// `Result` with the crate's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
