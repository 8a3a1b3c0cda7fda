#!/usr/bin/env python3
"""Held-out Oxford-format scenes from the CC0 images (docs/quality.md).

Each source image becomes one scene: img1 is the image, img2..img6 are warps
of it by known homographies of growing strength (rotation, zoom, perspective),
the last two also with an exposure change (gamma, gain) and the last with
Gaussian noise, so that `lfast eval repeatability --data OUT` and
`scripts/quality_diag.py --data OUT` score detectors on data that no default
was tuned on.

    python3 scripts/quality_synth.py OUT [--src ../shared/data/standard/cc0]
"""
import argparse
import os

import cv2
import numpy as np
from lfast_data import data_dir

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
IMAGES = ["astronaut", "brick", "camera_cc0_v0.18plus", "coins", "motorcycle_left"]


def homography(w, h, angle_deg, zoom, persp):
    """About the image centre: rotation, zoom, then a perspective tilt."""
    c = np.array([[1, 0, -w / 2], [0, 1, -h / 2], [0, 0, 1]], float)
    a = np.deg2rad(angle_deg)
    r = np.array([[zoom * np.cos(a), -zoom * np.sin(a), 0], [zoom * np.sin(a), zoom * np.cos(a), 0], [0, 0, 1]])
    p = np.array([[1, 0, 0], [0, 1, 0], [persp / w, 0.5 * persp / h, 1]])
    return np.linalg.inv(c) @ p @ r @ c


STEPS = [  # angle, zoom, perspective, gamma, gain, noise sigma
    (5, 1.05, 0.05, 1.0, 1.0, 0),
    (12, 1.15, 0.10, 1.0, 1.0, 0),
    (20, 0.85, 0.15, 1.0, 1.0, 0),
    (-15, 1.25, 0.20, 0.6, 1.0, 0),
    (30, 0.9, 0.10, 1.0, 0.55, 3),
]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out")
    ap.add_argument("--src", default=str(data_dir() / "standard" / "cc0"))
    a = ap.parse_args()
    rng = np.random.default_rng(2026)
    for name in IMAGES:
        img = cv2.imread(os.path.join(a.src, name + ".png"), cv2.IMREAD_GRAYSCALE)
        d = os.path.join(a.out, name)
        os.makedirs(d, exist_ok=True)
        cv2.imwrite(os.path.join(d, "img1.png"), img)
        h, w = img.shape
        for k, (ang, zoom, persp, gamma, gain, sigma) in enumerate(STEPS, start=2):
            H = homography(w, h, ang, zoom, persp)
            out = cv2.warpPerspective(img, H, (w, h), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT_101)
            out = 255.0 * (out / 255.0) ** gamma * gain
            if sigma:
                out = out + rng.normal(0, sigma, out.shape)
            cv2.imwrite(os.path.join(d, f"img{k}.png"), np.clip(np.rint(out), 0, 255).astype(np.uint8))
            np.savetxt(os.path.join(d, f"H1to{k}p"), H / H[2, 2])
    print(f"{len(IMAGES)} scenes x {len(STEPS)} pairs in {a.out}")


if __name__ == "__main__":
    main()
