//! Results owned by the library: keypoints with `cv::KeyPoint`'s layout,
//! descriptors, and 8-bit planes, each freed by one call.

use lfast::{Descriptor, KeyPoint};

/// A keypoint with the fields, order and meaning of OpenCV's `cv::KeyPoint`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LfastKeyPoint {
    /// Column in input-image pixels.
    pub x: f32,
    /// Row in input-image pixels.
    pub y: f32,
    /// Neighbourhood diameter in input-image pixels (31 * scale of its level).
    pub size: f32,
    /// Orientation in degrees, [0, 360).
    pub angle: f32,
    /// Ranking strength.
    pub response: f32,
    /// Pyramid level.
    pub octave: i32,
    /// -1 (unused, as OpenCV's detectors leave it).
    pub class_id: i32,
}

impl From<&KeyPoint> for LfastKeyPoint {
    fn from(k: &KeyPoint) -> Self {
        let KeyPoint { pt, size, angle, response, octave, class_id } = *k;
        LfastKeyPoint { x: pt.x, y: pt.y, size, angle, response, octave, class_id }
    }
}

impl From<&LfastKeyPoint> for KeyPoint {
    fn from(k: &LfastKeyPoint) -> Self {
        KeyPoint {
            pt: [k.x, k.y].into(),
            size: k.size,
            angle: k.angle,
            response: k.response,
            octave: k.octave,
            class_id: k.class_id,
        }
    }
}

/// Keypoints and descriptors owned by the library; free with `lfast_features_free`.
#[repr(C)]
#[derive(Debug)]
pub struct LfastFeatures {
    /// `count` keypoints, or NULL when `count` is 0.
    pub keypoints: *const LfastKeyPoint,
    /// `count * 32` bytes, row `i` (bytes `32 i .. 32 i + 31`) describing
    /// keypoint `i`; NULL when `count` is 0 or no descriptors were asked for.
    pub descriptors: *const u8,
    /// Number of keypoints.
    pub count: usize,
}

/// An 8-bit single-channel image owned by the library (`width` bytes a row,
/// no padding); free with `lfast_plane_free`.
#[repr(C)]
#[derive(Debug)]
pub struct LfastPlane {
    /// `width * height` bytes.
    pub data: *const u8,
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
}

/// The allocation behind an `LfastFeatures*`: the public struct first, so the
/// pointer handed out is the box's.
#[repr(C)]
struct FeaturesBox {
    public: LfastFeatures,
    kps: Vec<LfastKeyPoint>,
    desc: Vec<u8>,
}

#[repr(C)]
struct PlaneBox {
    public: LfastPlane,
    data: Vec<u8>,
}

pub(crate) fn features(kps: &[KeyPoint], desc: Option<&[Descriptor]>) -> *mut LfastFeatures {
    let kps: Vec<LfastKeyPoint> = kps.iter().map(Into::into).collect();
    let desc: Vec<u8> = desc.map(|d| d.as_flattened().to_vec()).unwrap_or_default();
    let public = LfastFeatures {
        keypoints: if kps.is_empty() { std::ptr::null() } else { kps.as_ptr() },
        descriptors: if desc.is_empty() { std::ptr::null() } else { desc.as_ptr() },
        count: kps.len(),
    };
    // moving the Vecs into the box keeps their heap buffers where they are
    Box::into_raw(Box::new(FeaturesBox { public, kps, desc })).cast()
}

pub(crate) fn plane(p: lfast::Plane<u8>) -> *mut LfastPlane {
    let public = LfastPlane { data: p.data.as_ptr(), width: p.width, height: p.height };
    Box::into_raw(Box::new(PlaneBox { public, data: p.data })).cast()
}

/// Frees features returned by the library (NULL is ignored).
///
/// # Safety
/// `features` is NULL or a pointer the library returned, freed once.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lfast_features_free(features: *mut LfastFeatures) {
    if !features.is_null() {
        // SAFETY: the pointer came from Box::into_raw of a FeaturesBox
        drop(unsafe { Box::from_raw(features.cast::<FeaturesBox>()) });
    }
}

/// Frees a plane returned by the library (NULL is ignored).
///
/// # Safety
/// `plane` is NULL or a pointer the library returned, freed once.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn lfast_plane_free(plane: *mut LfastPlane) {
    if !plane.is_null() {
        // SAFETY: the pointer came from Box::into_raw of a PlaneBox
        drop(unsafe { Box::from_raw(plane.cast::<PlaneBox>()) });
    }
}
