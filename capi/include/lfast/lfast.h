/* lfast C ABI. Generated from capi/src by cbindgen: do not edit.
 * Regenerate: LFAST_BLESS=1 cargo run --release -p lfast-capi-header
 * SPDX-License-Identifier: MIT OR Apache-2.0 */

#ifndef LFAST_H
#define LFAST_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
/* Thread safety: an LfastDetector may be used from several threads at once;
 * it must not be freed while a call on it runs. lfast_last_error() is per
 * thread. Results (LfastFeatures, LfastPlane) belong to the caller until freed. */

// What a call returned. `LFAST_STATUS_OK` is 0; on any other value
// `lfast_last_error()` says what was wrong, and no output was written.
typedef enum {
  // Success.
  LFAST_STATUS_OK = 0,
  // A required pointer argument was NULL.
  LFAST_STATUS_NULL_POINTER = 1,
  // An image, mask, keypoint or enum value is invalid (empty, stride smaller
  // than a row, unknown pixel format, mask of another size, keypoint outside
  // the image...).
  LFAST_STATUS_INVALID_ARGUMENT = 2,
  // A configuration field is out of range, or the TOML text does not parse.
  LFAST_STATUS_INVALID_CONFIG = 3,
  // A file could not be read or decoded.
  LFAST_STATUS_IO = 4,
  // The GPU could not run the request (no adapter, device lost, out of
  // memory, over a device limit).
  LFAST_STATUS_GPU = 5,
  // The request is not available in this build or on this backend.
  LFAST_STATUS_UNSUPPORTED = 6,
  // An internal error (a Rust panic) was caught; the detector stays usable.
  LFAST_STATUS_PANIC = 7,
  // Any other library error.
  LFAST_STATUS_OTHER = 8,
} LfastStatus;

// Which path runs: values of the `backend` argument of `lfast_detector_new`.
typedef enum {
  // A hardware GPU when one opens (or the adapter `WGPU_ADAPTER_NAME`
  // names), else the CPU.
  LFAST_BACKEND_AUTO = 0,
  // The GPU or an error.
  LFAST_BACKEND_GPU = 1,
  // The CPU reference path.
  LFAST_BACKEND_CPU = 2,
} LfastBackend;

// Which descriptor `lfast::Config::descriptor` computes.
typedef enum {
  // lfast's rBRIEF (SPEC 11), CPU == GPU.
  LFAST_DESCRIPTOR_KIND_LFAST = 0,
  // Bit for bit OpenCV ORB `compute()`'s on the same keypoints; CPU only.
  LFAST_DESCRIPTOR_KIND_OPENCV = 1,
} LfastDescriptorKind;

// Values of `LfastConfig.mode` (SPEC 8).
typedef enum {
  // Every edge pixel on the circle is a `t_i` (the paper's steps literally).
  LFAST_MODE_PAPER = 0,
  // Runs of consecutive edge pixels on the circle are one branch each.
  LFAST_MODE_BRANCH = 1,
} LfastMode;

// Layout of the pixels of an `LfastImage`, in OpenCV's channel order.
typedef enum {
  // One 8-bit channel (`CV_8UC1`).
  LFAST_PIXEL_FORMAT_GRAY8 = 0,
  // One 16-bit channel in native byte order (`CV_16UC1`).
  LFAST_PIXEL_FORMAT_GRAY16 = 1,
  // Blue, green, red, 8 bits each (`CV_8UC3`).
  LFAST_PIXEL_FORMAT_BGR8 = 2,
  // Blue, green, red, 16 bits each (`CV_16UC3`).
  LFAST_PIXEL_FORMAT_BGR16 = 3,
  // Blue, green, red, alpha, 8 bits each (`CV_8UC4`); alpha is ignored.
  LFAST_PIXEL_FORMAT_BGRA8 = 4,
  // Blue, green, red, alpha, 16 bits each (`CV_16UC4`); alpha is ignored.
  LFAST_PIXEL_FORMAT_BGRA16 = 5,
} LfastPixelFormat;

// The detector behind an `LfastDetector*`.
typedef struct LfastDetector LfastDetector;

// Every parameter of the detector, as `lfast::Config` (docs/algorithm.md);
// `lfast_config_default()` gives the defaults.
typedef struct {
  // Noise factor of the flagged median (SPEC 1), in [0.0001, 100].
  double delta;
  // Local-threshold spread alpha in hundredths (SPEC 5), 0..=99.
  uint32_t alpha_pct;
  // An `LfastMode` value (SPEC 8).
  int32_t mode;
  // Neighbours of a non-edge `q_i` that must be edge for it to support p, 1..=8.
  uint32_t support;
  // Branch mode: tolerance of the straight-line test, 0..=7.
  uint32_t straight_tol;
  // Corners are tested only this far (pixels) from every side, 7..=1024.
  uint32_t border;
  // Corner NMS half-window r, (2r+1)^2 square, 0..=32.
  uint32_t nms_radius;
  // Pyramid levels, 1..=32 (1 = no pyramid).
  uint32_t n_levels;
  // Pyramid scale between levels, in (1, 4].
  double scale_factor;
  // Keypoint cap over all levels, 0 = no cap.
  uint32_t n_features;
  // With a cap: spread keypoints with ORB-SLAM's quadtree instead of taking the strongest.
  bool distribution;
  // Orientation bins of the descriptor (0 = continuous angle), 0..=360.
  uint32_t orientation_bins;
  // An `LfastDescriptorKind` value.
  int32_t descriptor;
  // Beyond the paper: each corner moves to the Harris maximum within this many
  // pixels (0 = stays on its edge pixel), 0..=16; at most `nms_radius / 2` is used.
  uint32_t snap_radius;
  // Beyond the paper: a candidate whose Harris response is not above 0 (an
  // edge, in Harris and Stephens' sense) is no corner.
  bool reject_edges;
  // Beyond the paper, with a cap: a level whose L-FAST corners fall short of
  // its quota is topped up with FAST-9 corners found cell by cell at this
  // threshold (ORB-SLAM's `iniThFAST`), `class_id` 1; 0 = off, else
  // `fill_fast_min..=255`. CPU only.
  uint32_t fill_fast_ini;
  // The fill's FAST threshold in a cell where `fill_fast_ini` found nothing
  // (ORB-SLAM's `minThFAST`): 0 with the fill off, else `1..=fill_fast_ini`.
  uint32_t fill_fast_min;
} LfastConfig;

// A borrowed image: `height` rows of `width` pixels, row `y` starting at
// `data + y * stride` bytes. The buffer must hold `stride * (height - 1)`
// bytes plus one row of pixels, and stay valid during the call.
typedef struct {
  // First byte of the first row.
  const void *data;
  // Pixels per row, >= 1.
  uint32_t width;
  // Rows, >= 1.
  uint32_t height;
  // Bytes from the start of one row to the next, >= `width` times the pixel size.
  size_t stride;
  // An `LfastPixelFormat` value.
  int32_t format;
} LfastImage;

// A keypoint with the fields, order and meaning of OpenCV's `cv::KeyPoint`.
typedef struct {
  // Column in input-image pixels.
  float x;
  // Row in input-image pixels.
  float y;
  // Neighbourhood diameter in input-image pixels (31 * scale of its level).
  float size;
  // Orientation in degrees, [0, 360).
  float angle;
  // Ranking strength.
  float response;
  // Pyramid level.
  int32_t octave;
  // -1 (unused, as OpenCV's detectors leave it).
  int32_t class_id;
} LfastKeyPoint;

// Keypoints and descriptors owned by the library; free with `lfast_features_free`.
typedef struct {
  // `count` keypoints, or NULL when `count` is 0.
  const LfastKeyPoint *keypoints;
  // `count * 32` bytes, row `i` (bytes `32 i .. 32 i + 31`) describing
  // keypoint `i`; NULL when `count` is 0 or no descriptors were asked for.
  const uint8_t *descriptors;
  // Number of keypoints.
  size_t count;
} LfastFeatures;

// An 8-bit single-channel image owned by the library (`width` bytes a row,
// no padding); free with `lfast_plane_free`.
typedef struct {
  // `width * height` bytes.
  const uint8_t *data;
  // Columns.
  uint32_t width;
  // Rows.
  uint32_t height;
} LfastPlane;

#ifdef __cplusplus
extern "C" {
#endif // __cplusplus

// The library's version, e.g. "0.1.0" (a static string).
const char *lfast_version(void);

// The message of the last call that failed on this thread ("" before any
// failure). Valid until the next failing call on this thread.
const char *lfast_last_error(void);

// The default value of every configuration field.
LfastConfig lfast_config_default(void);

// Checks every field; the error names the first one out of range.
//
// # Safety
// `config` is NULL or points to an `LfastConfig`.
LfastStatus lfast_config_validate(const LfastConfig *config);

// Creates a detector with `config` (NULL = defaults) on `backend` (an
// `LfastBackend` value) and stores it in `*out`; free it with
// `lfast_detector_free`.
//
// # Safety
// `config` is NULL or points to an `LfastConfig`; `out` points to writable
// memory for a pointer.
LfastStatus lfast_detector_new(const LfastConfig *config, int32_t backend, LfastDetector **out);

// As `lfast_detector_new`, with the configuration as TOML text (the format
// of `lfast --config FILE`; missing fields take their defaults).
//
// # Safety
// `toml` is NULL or a NUL-terminated string; `out` as for `lfast_detector_new`.
LfastStatus lfast_detector_new_toml(const char *toml, int32_t backend, LfastDetector **out);

// Frees a detector (NULL is ignored). No call on it may be running.
//
// # Safety
// `detector` is NULL or a pointer from `lfast_detector_new*`, freed once.
void lfast_detector_free(LfastDetector *detector);

// Writes the detector's configuration to `*out`.
//
// # Safety
// `detector` as for `lfast_detector_free`; `out` points to an `LfastConfig`.
LfastStatus lfast_detector_config(const LfastDetector *detector, LfastConfig *out);

// "gpu" or "cpu": where the next frame runs (a static string), or NULL for
// a NULL detector.
//
// # Safety
// As `lfast_detector_config`.
const char *lfast_detector_backend(const LfastDetector *detector);

// Detects keypoints in `image`, only where `mask` (NULL = everywhere; 8-bit
// gray of the image's size) is nonzero, and stores them in `*out`
// (descriptors NULL). Order: response descending, then octave, y, x.
//
// # Safety
// `detector` as for `lfast_detector_free`; `image` and `mask` NULL or
// pointing to an `LfastImage` whose buffer holds what it describes; `out`
// points to writable memory for a pointer.
LfastStatus lfast_detect(const LfastDetector *detector,
                         const LfastImage *image,
                         const LfastImage *mask,
                         LfastFeatures **out);

// As `lfast_detect`, with the descriptors.
//
// # Safety
// As `lfast_detect`.
LfastStatus lfast_detect_and_compute(const LfastDetector *detector,
                                     const LfastImage *image,
                                     const LfastImage *mask,
                                     LfastFeatures **out);

// Descriptors of `count` given keypoints (from any detector) in `image`. A
// keypoint is described at its `octave`, with the orientation recomputed
// from the image, so lfast's own keypoints get the descriptors
// `lfast_detect_and_compute` gave them. `*out` holds the keypoints as given
// and their descriptors. A keypoint outside the image, or with an octave
// outside `0..n_levels`, is an `LFAST_STATUS_INVALID_ARGUMENT` naming it.
//
// # Safety
// As `lfast_detect`; `keypoints` points to `count` keypoints (or is NULL
// when `count` is 0).
LfastStatus lfast_compute(const LfastDetector *detector,
                          const LfastImage *image,
                          const LfastKeyPoint *keypoints,
                          size_t count,
                          LfastFeatures **out);

// The improved Canny edge map of `image` (255 = edge, 0 elsewhere), in `*out`.
//
// # Safety
// As `lfast_detect`.
LfastStatus lfast_edges(const LfastDetector *detector, const LfastImage *image, LfastPlane **out);

// Reads an image file as 8-bit gray exactly as `lfast detect` does (SPEC 0),
// into `*out`.
//
// # Safety
// `path` is NULL or a NUL-terminated string; `out` points to writable memory
// for a pointer.
LfastStatus lfast_imread(const char *path, LfastPlane **out);

// Frees features returned by the library (NULL is ignored).
//
// # Safety
// `features` is NULL or a pointer the library returned, freed once.
void lfast_features_free(LfastFeatures *features);

// Frees a plane returned by the library (NULL is ignored).
//
// # Safety
// `plane` is NULL or a pointer the library returned, freed once.
void lfast_plane_free(LfastPlane *plane);

#ifdef __cplusplus
}  // extern "C"
#endif  // __cplusplus

#endif  /* LFAST_H */
