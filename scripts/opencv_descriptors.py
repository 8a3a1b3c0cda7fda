#!/usr/bin/env python3
"""How many lfast descriptor="opencv" descriptors equal cv2 ORB compute()'s.

For each image: (a) lfast's keypoints (detectAndCompute, descriptor="opencv")
described by cv2.ORB_create().compute(); (b) cv2 ORB's own keypoints described
by lfast compute(descriptor="opencv"). cv2 drops keypoints within 31 pixels of
the image border and may reorder by octave; lfast keeps every keypoint in
order, so rows are paired by (x, y, octave, angle).

    python3 scripts/opencv_descriptors.py [--kitti DIR] [--standard GLOB] [--tests GLOB]
"""

import argparse
import glob

import cv2
import numpy as np

import lfast
from lfast_data import data_dir


def key(k):
    return (k.pt[0], k.pt[1], k.octave, k.angle)


def compare(ref_kps, ref_desc, kps, desc):
    """(equal, compared, differing bits) over the keypoints cv2 kept."""
    if ref_desc is None:
        return 0, 0, 0
    row = {key(k): i for i, k in enumerate(kps)}
    eq = n = bits = 0
    for k, d in zip(ref_kps, ref_desc):
        i = row[key(k)]
        n += 1
        diff = int(np.unpackbits(np.bitwise_xor(d, desc[i])).sum())
        eq += diff == 0
        bits += diff
    return eq, n, bits


def run(paths):
    det = lfast.Detector(backend="cpu", descriptor="opencv")
    orb = cv2.ORB_create(nfeatures=2000)
    tot = np.zeros((2, 3), int)
    for p in paths:
        img = cv2.imread(p, cv2.IMREAD_GRAYSCALE)
        kps, desc = det.detectAndCompute(img)
        rk, rd = orb.compute(img, list(kps))
        tot[0] += compare(rk, rd, kps, desc)
        ok = orb.detect(img, None)
        ok, od = orb.compute(img, ok)
        _, ld = det.compute(img, ok)
        tot[1] += compare(ok, od, ok, ld)
    return tot


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kitti", default=str(data_dir() / "kitti" / "seq01_000000-000050" / "image_0"))
    ap.add_argument("--standard", default=str(data_dir() / "standard" / "*.png"))
    ap.add_argument("--tests", default="tests/data/*.png")
    a = ap.parse_args()
    sets = {
        "kitti": sorted(glob.glob(a.kitti + "/*.png")),
        "standard": sorted(glob.glob(a.standard)),
        "tests/data": sorted(glob.glob(a.tests)),
    }
    print("set         images  lfast kps -> cv2 compute          cv2 ORB kps -> lfast compute")
    for name, paths in sets.items():
        t = run(paths)
        cells = [f"{e}/{n} equal ({100.0 * e / max(n, 1):.3f}%), {b} bits off" for e, n, b in t]
        print(f"{name:<11} {len(paths):>6}  {cells[0]:<33} {cells[1]}")


if __name__ == "__main__":
    main()
