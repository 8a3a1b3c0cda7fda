//! SPEC geometry shared by the CPU path ([`crate::cpu`]) and the GPU path
//! ([`crate::gpu`]): everything both compute from the config and the frame
//! size alone, defined once so a coefficient can never drift between them.
//!
//! - [`windows`]: the SPEC 5 window grid (origins, sizes, nearest window per row/column).
//! - [`quotas`]: SPEC 9 per-level quotas of `n_features`.
//! - [`mask`]: the level masks and the distance kept from a mask's boundary.
//! - [`pattern`]: the SPEC 11 ORB test pattern and its rotated tables.
//! - [`angle`]: the SPEC 11 orientation disc, angle and integer angle bins.
//! - [`keypoint`]: keypoint position <-> level pixel.
//! - [`matching`]: the matcher's options and result types (CPU and GPU matchers).
//!
//! Level sizes and scales are [`Config::level_sizes`](crate::Config::level_sizes)
//! and [`Config::level_scale`](crate::Config::level_scale).
//! Nothing here touches pixels of a frame except [`mask::level_mask`].

pub mod angle;
pub mod keypoint;
pub mod mask;
pub mod matching;
pub mod pattern;
pub mod quotas;
pub mod windows;

pub use keypoint::{
    LFAST_CENTRE, OPENCV_CENTRE, SUBPIXEL, SUBPIXEL_MAX, keypoint_at, keypoint_at_sub, keypoint_level_pixel,
    level_pixel, level_subpixel,
};
pub use mask::{level_mask, mask_radius};
pub use quotas::level_quotas;
pub use windows::{WindowLayout, cell_cuts, nearest_windows, window_origins};
