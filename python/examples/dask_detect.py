"""Detect L-FAST features in a folder of frames on a Dask cluster, writing the
files `lfast detect DIR --out OUT --format ...` writes (docs/scale-out.md).

    python dask_detect.py FRAMES_DIR OUT_DIR [--scheduler tcp://host:8786]
        [--format json,npy] [--backend cpu] [--workers 2] [config=value ...]

Without --scheduler, a local cluster of --workers processes runs the job.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import lfast

# the extensions `lfast detect` takes from a directory (src/cli/inputs.rs)
EXTENSIONS = {".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".pgm", ".ppm", ".pnm", ".pbm"}


def list_frames(folder: str) -> list[tuple[str, str]]:
    """(input path, output name without suffix) of every image under `folder`,
    named as `lfast detect` names them: the path below the folder without its
    extension; hidden files and folders are skipped."""
    jobs = []
    for dirpath, dirnames, filenames in os.walk(folder):
        dirnames[:] = sorted(d for d in dirnames if not d.startswith("."))
        for name in sorted(filenames):
            if name.startswith(".") or Path(name).suffix.lower() not in EXTENSIONS:
                continue
            path = os.path.join(dirpath, name)
            rel = os.path.relpath(path, folder)
            jobs.append((path, os.path.splitext(rel)[0]))
    return jobs


def process(job: tuple[str, str], out: str, formats: tuple, backend: str, config: tuple) -> int:
    """One frame: read, detect, write; returns the keypoint count."""
    path, rel = job
    # one detector per worker process (GPU context, buffers), built by its first task
    det = lfast.shared_detector(backend, **dict(config))
    return lfast.detect_file(det, path, os.path.join(out, rel), formats)


def run(folder: str, out: str, client, formats=("json",), backend="cpu", config=()) -> int:
    """Maps `process` over the frames on `client`; returns the total keypoint count."""
    jobs = list_frames(folder)
    futures = client.map(process, jobs, out=out, formats=tuple(formats), backend=backend,
                         config=tuple(sorted(config)), pure=False)
    return sum(client.gather(futures))


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("folder")
    ap.add_argument("out")
    ap.add_argument("--scheduler", help="address of a running Dask scheduler")
    ap.add_argument("--workers", type=int, default=2, help="local cluster size (without --scheduler)")
    ap.add_argument("--format", default="json", help="comma-separated: json, csv, npy, yaml")
    ap.add_argument("--backend", default="cpu", choices=["auto", "cpu", "gpu"])
    ap.add_argument("config", nargs="*", help="Detector keywords, e.g. n_features=2000 mode=paper")
    a = ap.parse_intermixed_args(argv)
    config = []
    for kv in a.config:
        k, _, v = kv.partition("=")
        config.append((k, v if k == "mode" else (v.lower() == "true" if k == "distribution" else float(v) if "." in v else int(v))))

    from dask.distributed import Client, LocalCluster

    if a.scheduler:
        client = Client(a.scheduler)
    else:
        client = Client(LocalCluster(n_workers=a.workers, threads_per_worker=1, processes=True))
    with client:
        n = run(a.folder, a.out, client, a.format.split(","), a.backend, config)
    print(f"{n} keypoints", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
