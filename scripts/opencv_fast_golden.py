#!/usr/bin/env python3
"""Golden keypoints of OpenCV's FAST-9 for tests/fast_opencv.rs.

Writes tests/data/fast_opencv/<name>.json: a JSON list of [x, y, response], in
OpenCV's order, of cv::FAST(gray, threshold=20, nonmaxSuppression=true,
TYPE_9_16) (in Python: cv2.FastFeatureDetector_create(20, True, TYPE_9_16)).

Inputs, relative to the crate root:
  - tests/data/{camera_cc0_v0.18plus,coins,text,chessboard_GRAY}.png
    (CC0 images from scikit-image, copied from ../shared/data/standard/cc0/);
  - ../shared/data/kitti/seq01_000000-000050/image_0/{000000,000020}.png
    (written as kitti_seq01_<frame>.json; only the derived keypoints are kept,
    the KITTI frames are never copied into the repository). Skipped with a
    message when ../shared is absent.

Gray conversion is the crate's (SPEC 0): 16-bit -> v >> 8, colour ->
Y = (19596 R + 38470 G + 7470 B + 32768) >> 16 (= cv2.cvtColor BGR2GRAY in
OpenCV 4.x and 5.x), alpha ignored; the formula is applied here and checked
against cv2.cvtColor. Requires: pip install opencv-python-headless numpy.

Usage: python3 scripts/opencv_fast_golden.py [--check]
  --check: compare with the files already there instead of writing them.
"""

import json
import sys
from pathlib import Path

import cv2
import numpy as np
from lfast_data import data_dir, in_ci, note_skip

THRESHOLD = 20
NONMAX = True

ROOT = Path(__file__).resolve().parent.parent
OUT_DIR = ROOT / "tests" / "data" / "fast_opencv"
CC0 = ["camera_cc0_v0.18plus", "coins", "text", "chessboard_GRAY"]
KITTI_DIR = data_dir() / "kitti" / "seq01_000000-000050" / "image_0"
KITTI_FRAMES = ["000000", "000020"]


def load_gray(path: Path) -> np.ndarray:
    img = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if img is None:
        raise SystemExit(f"cannot read {path}")
    if img.dtype == np.uint16:
        img = (img >> 8).astype(np.uint8)
    if img.dtype != np.uint8:
        raise SystemExit(f"{path}: unsupported sample type {img.dtype}")
    if img.ndim == 2:
        return img
    # cv2.imread gives BGR(A).
    b, g, r = (img[:, :, c].astype(np.uint32) for c in range(3))
    gray = ((19596 * r + 38470 * g + 7470 * b + 32768) >> 16).astype(np.uint8)
    cv_gray = cv2.cvtColor(np.ascontiguousarray(img[:, :, :3]), cv2.COLOR_BGR2GRAY)
    if not np.array_equal(gray, cv_gray):
        raise SystemExit(f"{path.name}: cv2.cvtColor differs from the SPEC 0 luma on {(gray != cv_gray).sum()} pixels")
    return gray


def fast_keypoints(gray: np.ndarray) -> list:
    det = cv2.FastFeatureDetector_create(THRESHOLD, NONMAX, cv2.FastFeatureDetector_TYPE_9_16)
    rows = []
    for kp in det.detect(gray):
        x, y = kp.pt
        assert x == int(x) and y == int(y), kp.pt
        assert (kp.size, kp.angle, kp.octave, kp.class_id) == (7.0, -1.0, 0, -1)
        assert kp.response == int(kp.response), kp.response
        rows.append([int(x), int(y), int(kp.response)])
    return rows


def main() -> int:
    check = "--check" in sys.argv[1:]
    inputs = [(name, ROOT / "tests" / "data" / f"{name}.png") for name in CC0]
    for frame in KITTI_FRAMES:
        path = KITTI_DIR / f"{frame}.png"
        if path.exists():
            inputs.append((f"kitti_seq01_{frame}", path))
        elif in_ci():
            print(f"error: {path} is missing, and CI must have the test data")
            return 1
        else:
            note_skip(f"opencv_fast_golden.py kitti_seq01_{frame}", path)

    OUT_DIR.mkdir(parents=True, exist_ok=True)
    failed = False
    print(f"OpenCV {cv2.__version__}, threshold {THRESHOLD}, nonmax {NONMAX}")
    for name, path in inputs:
        rows = fast_keypoints(load_gray(path))
        out = OUT_DIR / f"{name}.json"
        text = "[\n" + ",\n".join(json.dumps(r) for r in rows) + "\n]\n"
        if check:
            same = out.exists() and json.loads(out.read_text()) == rows
            failed |= not same
            print(f"{name}: {len(rows)} keypoints, {'same' if same else 'DIFFERENT'}")
        else:
            out.write_text(text)
            print(f"{name}: {len(rows)} keypoints -> {out.relative_to(ROOT)}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
