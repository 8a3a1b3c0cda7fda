#!/usr/bin/env python3
"""Golden descriptors of OpenCV's ORB compute() for tests/opencv_descriptor.rs.

Writes tests/data/orb_opencv/<name>.json for tests/data/{coins,text}.png
(grayscale): a JSON list of [x, y, angle, octave, descriptor hex] with
cv2.ORB_create(nfeatures=300)'s keypoints as detect() returns them and the
descriptors compute() gives them (cv2 keeps them all: ORB's own keypoints
lie 31 pixels inside). x, y and angle are written as exact float32 values.
Requires: pip install opencv-python-headless numpy (5.0.0.93 made them).

Usage: python3 scripts/opencv_orb_golden.py [--check]
  --check: compare with the files already there instead of writing them.
"""

import json
import sys
from pathlib import Path

import cv2

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "tests" / "data" / "orb_opencv"


def golden(path):
    img = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    orb = cv2.ORB_create(nfeatures=300)
    kps = orb.detect(img, None)
    kept, desc = orb.compute(img, kps)
    assert len(kept) == len(kps), "ORB's own keypoints are all kept"
    return [[float(k.pt[0]), float(k.pt[1]), float(k.angle), int(k.octave), d.tobytes().hex()]
            for k, d in zip(kept, desc)]


def main():
    check = "--check" in sys.argv[1:]
    OUT.mkdir(parents=True, exist_ok=True)
    bad = 0
    for name in ["coins", "text"]:
        rows = golden(ROOT / "tests" / "data" / f"{name}.png")
        text = json.dumps(rows, separators=(",", ":")) + "\n"
        out = OUT / f"{name}.json"
        if check:
            same = out.exists() and out.read_text() == text
            print(f"{out.relative_to(ROOT)}: {'same' if same else 'DIFFERENT'}")
            bad += not same
        else:
            out.write_text(text)
            print(f"wrote {out.relative_to(ROOT)} ({len(rows)} keypoints)")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
