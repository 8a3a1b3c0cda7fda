#!/usr/bin/env python3
"""Times lfast's CPU pipeline against OpenCV on the same frames, in one run.

Ours: runs `cargo run --release --example bench_frames -- --repeats R FILES...`
(or a prebuilt bench_frames binary given with --bin) and reads its JSON.
Theirs: cv2.Canny(img, 100, 200) and cv2.ORB_create(2000).detectAndCompute(img, None)
on the same frames, with the same scheme: frames decoded once (not timed), one
warm-up pass over the whole list, then R timed passes; each pass gives ms per
frame; reported are the median and the minimum over the R passes. OpenCV keeps
its default thread count (cv2.setNumThreads is not called); lfast uses rayon's
default (one thread per core).

Ratios printed (ours / theirs, of the medians and of the minima; lower is better;
the target applies to the median ratio):
  improved-Canny edges          / cv2.Canny            target <= 1.0
  L-FAST + ORB detect_and_compute / cv2 ORB(2000)      target <= 0.5
  our ORB baseline (2000)       / cv2 ORB(2000)        target <= 1.0
  whole process: `lfast detect DIR --backend cpu` (decode, detect, describe,
  write JSON) / a Python loop of cv2.imread + ORB(2000).detectAndCompute
                                                       target <= 0.5

descriptor="opencv" (lfast::ORBextractor's descriptor: OpenCV's pyramid, blur
and rotated rBRIEF) on cv2 ORB(2000)'s own keypoints, those its compute() keeps,
/ cv2 ORB(2000).compute on the same keypoints     target <= 1.0

Two more pairs, without a target, split L-FAST+ORB into the parts OpenCV also
has, for the floor analysis in BENCHMARKS.md:
  improved Canny on each of the 8 pyramid levels / cv2.Canny(100, 200) on an
      8-level pyramid of the same sizes (both pyramids built before timing)
  describe our keypoints (lfast compute(): pyramid, blur, orientation, rBRIEF)
      / cv2 ORB(2000).compute on its own keypoints (pyramid, blur, rBRIEF)
and the floor line compares the L-FAST+ORB target (0.5 x cv2 ORB(2000)) with
OpenCV's own Canny over the 8 levels: an L-FAST front end built from OpenCV's
fastest primitives would spend that on its edge maps alone.

The whole-process row runs the CLI binary (--lfast-bin, default
target/release/lfast) over the frames' directory into a fresh temporary
directory, R times after one warm-up, and reads the wall time of each run;
OpenCV's side loops over the same files, imread (grayscale) + ORB(2000)
detectAndCompute, in this process (interpreter start-up not counted). Both
give ms per frame. --no-cli skips the row.

Default frames: the 51 KITTI frames of $LFAST_TEST_DATA (default ../shared/data)/kitti/seq01_000000-000050/image_0.
Requires: pip install opencv-python-headless numpy.

Usage: python3 scripts/bench_opencv.py [--repeats R] [--bin PATH [--commit REV]] [--json-out FILE] [FILES...]
"""

import argparse
import datetime
import json
import os
import platform
import statistics
import subprocess
import shutil
import sys
import tempfile
import time
from pathlib import Path

import cv2
from lfast_data import data_dir

ROOT = Path(__file__).resolve().parent.parent
KITTI_DIR = data_dir() / "kitti" / "seq01_000000-000050" / "image_0"

# (our method, OpenCV method, label, target ratio or None)
PAIRS = [
    ("edges", "cv2_canny", "improved Canny edges / cv2.Canny(100, 200)", 1.0),
    ("lfast_detect_and_compute", "cv2_orb2000", "L-FAST+ORB detect_and_compute / cv2 ORB(2000)", 0.5),
    ("orb_baseline", "cv2_orb2000", "our ORB baseline (2000) / cv2 ORB(2000)", 1.0),
    ("cli_detect_cpu", "cv2_imread_orb2000", "lfast detect DIR --backend cpu / cv2 imread+ORB loop", 0.5),
    ("edges_pyramid", "cv2_canny_pyramid", "improved Canny, 8 levels / cv2.Canny, 8 levels", None),
    ("describe", "cv2_orb_compute", "describe own keypoints / cv2 ORB compute", None),
    ("describe_opencv", "cv2_orb_compute", 'descriptor="opencv" / cv2 compute, same keypoints', 1.0),
]

# The default pyramid (Config: 8 levels, scale 1.2), sizes round(W / s^l) as SPEC 10.
N_LEVELS, SCALE = 8, 1.2


def pyramid(img):
    h, w = img.shape
    levels = [img]
    for lv in range(1, N_LEVELS):
        s = SCALE**lv
        size = (max(1, round(w / s)), max(1, round(h / s)))
        levels.append(cv2.resize(levels[-1], size, interpolation=cv2.INTER_LINEAR))
    return levels


def time_passes(frames, repeats, fn):
    """One warm-up pass, then `repeats` timed passes; ms per frame of each pass."""
    count = 0
    for img in frames:
        count += fn(img)
    per_frame = []
    for _ in range(repeats):
        t = time.perf_counter()
        for img in frames:
            fn(img)
        per_frame.append((time.perf_counter() - t) * 1e3 / len(frames))
    return per_frame, count / len(frames)


def summary(per_frame, mean_count, count_name):
    return {
        "median_ms": statistics.median(per_frame),
        "min_ms": min(per_frame),
        "passes_ms": per_frame,
        count_name: mean_count,
    }


def cv2_keypoints(files, path):
    """cv2 ORB(2000)'s keypoints of each frame, those its compute() keeps, as
    [x, y, size, angle, response, octave] rows in `path` (bench_frames
    --keypoints): describe_opencv describes exactly what cv2_orb_compute does."""
    orb = cv2.ORB_create(2000)
    rows = []
    for f in files:
        img = cv2.imread(str(f), cv2.IMREAD_GRAYSCALE)
        kps, _ = orb.compute(img, orb.detect(img, None))
        rows.append([[k.pt[0], k.pt[1], k.size, k.angle, k.response, k.octave] for k in kps])
    path.write_text(json.dumps(rows))


def run_ours(files, repeats, binary, keypoints):
    if binary:
        cmd = [str(binary)]
    else:
        cmd = ["cargo", "run", "--quiet", "--release", "--example", "bench_frames", "--"]
    cmd += ["--repeats", str(repeats), "--keypoints", str(keypoints)] + [str(f) for f in files]
    print("running:", " ".join(cmd[:8]), f"... ({len(files)} files)", file=sys.stderr)
    out = subprocess.run(cmd, cwd=ROOT, check=True, stdout=subprocess.PIPE, text=True).stdout
    return json.loads(out)


def run_opencv(files, repeats):
    frames = []
    for f in files:
        img = cv2.imread(str(f), cv2.IMREAD_GRAYSCALE)
        if img is None:
            raise SystemExit(f"cannot read {f}")
        frames.append(img)
    orb = cv2.ORB_create(2000)
    canny_t, canny_n = time_passes(frames, repeats, lambda img: int(cv2.countNonZero(cv2.Canny(img, 100, 200))))
    orb_t, orb_n = time_passes(frames, repeats, lambda img: len(orb.detectAndCompute(img, None)[0]))
    pyramids = [pyramid(img) for img in frames]
    canny_p_t, canny_p_n = time_passes(
        pyramids, repeats, lambda p: sum(int(cv2.countNonZero(cv2.Canny(lv, 100, 200))) for lv in p)
    )
    with_kps = [(img, orb.detect(img, None)) for img in frames]
    compute_t, compute_n = time_passes(with_kps, repeats, lambda fk: len(orb.compute(fk[0], fk[1])[0]))
    return {
        "cv2_canny": summary(canny_t, canny_n, "mean_edge_pixels"),
        "cv2_orb2000": summary(orb_t, orb_n, "mean_keypoints"),
        "cv2_canny_pyramid": summary(canny_p_t, canny_p_n, "mean_edge_pixels"),
        "cv2_orb_compute": summary(compute_t, compute_n, "mean_keypoints"),
    }


def run_cli(files, repeats, binary):
    """Wall time of `lfast detect DIR --backend cpu` over the frames' directory (one warm-up run)."""
    dirs = {Path(f).resolve().parent for f in files}
    if len(dirs) != 1 or len(list(next(iter(dirs)).glob("*.png"))) != len(files):
        raise SystemExit("the whole-process row needs the frames to be all the PNGs of one directory (or pass --no-cli)")
    src = next(iter(dirs))
    cmd = [str(binary), "detect", str(src), "--backend", "cpu", "--quiet", "--format", "json"]
    print("running:", " ".join(cmd), file=sys.stderr)
    per_frame = []
    n_kp = None
    for i in range(repeats + 1):
        out = Path(tempfile.mkdtemp(prefix="lfast_bench_"))
        try:
            t = time.perf_counter()
            subprocess.run(cmd + ["--out", str(out)], cwd=ROOT, check=True, stdout=subprocess.DEVNULL)
            dt = (time.perf_counter() - t) * 1e3 / len(files)
            if i == 0:
                n_kp = sum(len(json.loads(p.read_text()).get("keypoints", [])) for p in out.glob("*.json"))
            else:
                per_frame.append(dt)
        finally:
            shutil.rmtree(out, ignore_errors=True)
    return summary(per_frame, n_kp / len(files), "mean_keypoints")


def run_opencv_loop(files, repeats):
    """A Python loop of cv2.imread + ORB(2000).detectAndCompute over the files (one warm-up pass)."""
    orb = cv2.ORB_create(2000)

    def one_pass():
        n = 0
        for f in files:
            img = cv2.imread(str(f), cv2.IMREAD_GRAYSCALE)
            n += len(orb.detectAndCompute(img, None)[0])
        return n

    n = one_pass()
    per_frame = []
    for _ in range(repeats):
        t = time.perf_counter()
        one_pass()
        per_frame.append((time.perf_counter() - t) * 1e3 / len(files))
    return summary(per_frame, n / len(files), "mean_keypoints")


def git_commit():
    try:
        rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, check=True,
                             stdout=subprocess.PIPE, text=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=ROOT, check=True,
                               stdout=subprocess.PIPE, text=True).stdout.strip()
        return rev + ("+dirty" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def cpu_model():
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("files", nargs="*", type=Path, help="image files (default: the 51 KITTI seq01 frames)")
    ap.add_argument("--repeats", "-r", type=int, default=5, help="timed passes over the list (default 5)")
    ap.add_argument("--bin", type=Path, help="prebuilt bench_frames binary (default: cargo run --release)")
    ap.add_argument("--lfast-bin", type=Path, default=ROOT / "target" / "release" / "lfast",
                    help="the CLI for the whole-process row (default target/release/lfast)")
    ap.add_argument("--no-cli", action="store_true", help="skip the whole-process row")
    ap.add_argument("--json-out", type=Path, help="also write all numbers to this JSON file")
    ap.add_argument("--commit", help="what the measured binary was built from (default: this checkout's "
                    "`git rev-parse --short HEAD`, +dirty if it has uncommitted changes)")
    args = ap.parse_args()
    if args.repeats < 1:
        ap.error("--repeats must be >= 1")

    files = args.files or sorted(KITTI_DIR.glob("*.png"))
    if not files:
        raise SystemExit(f"no frames given and none found in {KITTI_DIR} (LFAST_TEST_DATA or ../shared/data absent?)")

    load_before = os.getloadavg()
    with tempfile.TemporaryDirectory() as tmp:
        kps_json = Path(tmp) / "cv2_keypoints.json"
        cv2_keypoints(files, kps_json)
        ours = run_ours(files, args.repeats, args.bin, kps_json)
    theirs = run_opencv(files, args.repeats)
    methods = dict(ours["methods"], **theirs)
    if not args.no_cli:
        if not args.lfast_bin.exists():
            raise SystemExit(f"{args.lfast_bin} not found: cargo build --release, or --lfast-bin PATH, or --no-cli")
        methods["cli_detect_cpu"] = run_cli(files, args.repeats, args.lfast_bin)
        methods["cv2_imread_orb2000"] = run_opencv_loop(files, args.repeats)

    print(f"\n{len(files)} frames {ours['sizes']}, {args.repeats} timed passes after 1 warm-up; "
          f"lfast {ours['threads']} rayon threads, OpenCV {cv2.__version__} with {cv2.getNumThreads()} threads; "
          f"load average {load_before[0]:.2f} before, {os.getloadavg()[0]:.2f} after")
    print(f"\n{'method':36} {'median ms/frame':>16} {'min ms/frame':>13} {'mean count':>11}")
    for name, m in methods.items():
        count = m.get("mean_keypoints", m.get("mean_edge_pixels"))
        print(f"{name:36} {m['median_ms']:16.2f} {m['min_ms']:13.2f} {count:11.1f}")

    ratios = {}
    print(f"\n{'ratio ours / OpenCV':50} {'median':>7} {'min':>7} {'target':>7}")
    for ours_name, cv_name, label, target in PAIRS:
        if ours_name not in methods:
            continue
        r = methods[ours_name]["median_ms"] / methods[cv_name]["median_ms"]
        r_min = methods[ours_name]["min_ms"] / methods[cv_name]["min_ms"]
        ratios[ours_name + "/" + cv_name] = {"ratio": r, "ratio_min": r_min, "target": target, "label": label}
        verdict = "" if target is None else ("  met" if r <= target else "  NOT met")
        print(f"{label:50} {r:7.2f} {r_min:7.2f} {('<= %.1f' % target) if target else '-':>7}{verdict}")

    orb_ms = methods["cv2_orb2000"]["median_ms"]
    canny_p = methods["cv2_canny_pyramid"]["median_ms"]
    floor = {"target_ms": 0.5 * orb_ms, "cv2_canny_pyramid_ms": canny_p, "fraction_of_orb": canny_p / orb_ms}
    print(f"\nfloor: the L-FAST+ORB target is 0.5 x {orb_ms:.2f} = {0.5 * orb_ms:.2f} ms/frame; "
          f"cv2.Canny alone over the 8 levels takes {canny_p:.2f} ms ({canny_p / orb_ms:.2f} of cv2 ORB(2000))")

    if args.json_out:
        report = {
            "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
            "commit": args.commit or git_commit(),
            "cpu": cpu_model(),
            "frames": [str(f) for f in files],
            "repeats": args.repeats,
            "lfast_threads": ours["threads"],
            "opencv_version": cv2.__version__,
            "opencv_threads": cv2.getNumThreads(),
            "loadavg_before": load_before,
            "loadavg_after": os.getloadavg(),
            "methods": methods,
            "ratios": ratios,
            "floor": floor,
        }
        args.json_out.parent.mkdir(parents=True, exist_ok=True)
        args.json_out.write_text(json.dumps(report, indent=2) + "\n")
        print(f"\nwrote {args.json_out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
