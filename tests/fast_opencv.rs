//! `baseline::fast::fast9(img, 20, true)` against OpenCV's
//! `cv::FAST(img, 20, true)` (TYPE_9_16): the same keypoints, in the same order,
//! with the same responses. Golden files: tests/data/fast_opencv/<name>.json,
//! lists of [x, y, response] written by scripts/opencv_fast_golden.py.

mod common;

use std::path::Path;

use lfast::baseline::fast::fast9;

const THRESHOLD: i32 = 20;

/// Compares FAST-9 on `image` with `tests/data/fast_opencv/<golden>.json`.
fn check(image: &Path, golden: &str) {
    let gray = lfast::image::load_gray(image).unwrap_or_else(|e| panic!("{}: {e}", image.display()));
    let golden_path = common::data("fast_opencv").join(format!("{golden}.json"));
    let text = std::fs::read_to_string(&golden_path).unwrap_or_else(|e| panic!("{}: {e}", golden_path.display()));
    let expected: Vec<[u32; 3]> =
        serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", golden_path.display()));

    let got = fast9(&gray, THRESHOLD, true);
    for kp in &got {
        assert_eq!((kp.size, kp.angle, kp.octave, kp.class_id), (7.0, -1.0, 0, -1), "{golden}: {kp:?}");
    }
    let got: Vec<[f32; 3]> = got.iter().map(|k| [k.pt.x, k.pt.y, k.response]).collect();
    let expected: Vec<[f32; 3]> = expected.iter().map(|r| r.map(|v| v as f32)).collect();

    if let Some(i) = got.iter().zip(&expected).position(|(g, e)| g != e) {
        panic!("{golden}: keypoint {i} differs: got {:?}, OpenCV {:?}", got[i], expected[i]);
    }
    assert_eq!(got.len(), expected.len(), "{golden}: keypoint count differs from OpenCV");
    println!("{golden}: {} keypoints match OpenCV", got.len());
}

#[test]
fn cc0_images_match_opencv() {
    for name in ["camera_cc0_v0.18plus", "coins", "text", "chessboard_GRAY"] {
        check(&common::data(&format!("{name}.png")), name);
    }
}

#[test]
fn kitti_frames_match_opencv() {
    for frame in ["000000", "000020"] {
        let Some(path) = common::shared(&format!("kitti/seq01_000000-000050/image_0/{frame}.png")) else { continue };
        check(&path, &format!("kitti_seq01_{frame}"));
    }
}
