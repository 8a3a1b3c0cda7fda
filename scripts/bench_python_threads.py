#!/usr/bin/env python3
"""Thread-pool speed-up of the Python package: a serial loop against a pool.

    python3 scripts/bench_python_threads.py [--frames 8] [--threads 2] [--repeats 5] [--scale 2]

Each call runs on one core (RAYON_NUM_THREADS=1 is set before lfast loads),
so what is measured is whether Python threads overlap their calls, which
needs the GIL released during the work. The KITTI frames of ../shared/data
are enlarged `--scale` times so a call is long against thread start-up.
Prints the best of `--repeats` runs of each, and their ratio. A benchmark,
not a test: these machines are shared and noisy (python/tests/test_threads.py
checks the overlap itself without timing it).
"""

from __future__ import annotations

import argparse
import os
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

os.environ["RAYON_NUM_THREADS"] = "1"

import numpy as np  # noqa: E402

import lfast  # noqa: E402
from lfast_data import data_dir  # noqa: E402

KITTI = data_dir() / "kitti" / "seq01_000000-000050" / "image_0"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=8)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--scale", type=int, default=2)
    ap.add_argument("--dir", type=Path, default=KITTI, help="folder of frames (default: KITTI seq01)")
    a = ap.parse_args()
    paths = sorted(a.dir.glob("*.png"))[: a.frames]
    if not paths:
        raise SystemExit(f"no .png frames in {a.dir}")
    frames = [np.kron(lfast.imread(str(p)), np.ones((a.scale, a.scale), np.uint8)) for p in paths]
    det = lfast.Detector(backend="cpu")
    for f in frames[:2]:
        det.detectAndCompute(f)  # warm up

    def serial():
        return [len(det.detectAndCompute(f)[0]) for f in frames]

    def pool():
        with ThreadPoolExecutor(a.threads) as ex:
            return [len(k) for k, _ in ex.map(det.detectAndCompute, frames)]

    best = {"serial": float("inf"), "pool": float("inf")}
    counts = {}
    for _ in range(a.repeats):
        for name, fn in (("serial", serial), ("pool", pool)):
            t = time.perf_counter()
            counts[name] = fn()
            best[name] = min(best[name], time.perf_counter() - t)
    if counts["serial"] != counts["pool"]:
        raise SystemExit(f"the pool's keypoint counts differ from the serial loop's: {counts}")
    h, w = frames[0].shape
    print(
        f"{len(frames)} frames {w}x{h}, best of {a.repeats}: serial {best['serial']:.3f} s, "
        f"{a.threads}-thread pool {best['pool']:.3f} s ({best['serial'] / best['pool']:.2f}x), "
        f"{os.cpu_count()} cores"
    )


if __name__ == "__main__":
    main()
