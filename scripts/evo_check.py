#!/usr/bin/env python3
"""Cross-checks `lfast ate` against evo (pip install evo), and writes the ATE test vector.

  python3 scripts/evo_check.py check GT EST [GT EST ...] [--lfast BIN] [--tol 1e-4]
      For each pair and each alignment (none, se3 = evo_ape -a, sim3 = evo_ape -as), computes
      evo's APE (translation part) and `lfast ate --json`, and compares every statistic
      (rmse, mean, median, std, min, max, sse). Exits 1 when any differs by more than --tol.

  python3 scripts/evo_check.py vector SEQ_DIR [--frames 20] [--lfast BIN] [--out tests/data/ate]
      Runs `lfast vo` on the first N frames of SEQ_DIR without its poses.txt (our estimate from
      the images alone, unit steps: nothing of KITTI's ground truth is in it), pairs it with a synthetic ground truth of N poses (KITTI
      poses may not be committed), and writes OUT/gt.txt, OUT/est.txt and OUT/expected.json
      with evo's numbers: the test vector of tests/vo.rs.

evo's command-line equivalent: evo_ape kitti GT EST -a   (and -as for Sim(3)).
"""

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile

STATS = ["rmse", "mean", "median", "std", "min", "max", "sse"]
ALIGNS = {"none": (False, False), "se3": (True, False), "sim3": (True, True)}
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def evo_stats(gt, est, align, scale):
    from evo.core import metrics
    from evo.main_ape import ape
    from evo.tools import file_interface

    ref = file_interface.read_kitti_poses_file(gt)
    traj = file_interface.read_kitti_poses_file(est)
    r = ape(ref, traj, metrics.PoseRelation.translation_part, align=align, correct_scale=scale)
    return {k: float(r.stats[k]) for k in STATS}


def lfast_stats(binary, gt, est, align):
    out = subprocess.run([binary, "ate", gt, est, "--align", align, "--json"], check=True, capture_output=True, text=True)
    return json.loads(out.stdout)["stats"]


def check(args):
    if len(args.files) % 2:
        sys.exit("check: give GT EST pairs")
    worst = 0.0
    for gt, est in zip(args.files[::2], args.files[1::2]):
        for name, (align, scale) in ALIGNS.items():
            e = evo_stats(gt, est, align, scale)
            ours = lfast_stats(args.lfast, gt, est, name)
            diff = max(abs(e[k] - ours[k]) for k in STATS)
            worst = max(worst, diff)
            print(f"{est} [{name:>4}]: evo rmse {e['rmse']:.6f}, lfast rmse {ours['rmse']:.6f}, "
                  f"max |difference| over {len(STATS)} statistics {diff:.2e} m")
    print(f"largest difference {worst:.2e} m (tolerance {args.tol:g})")
    if worst > args.tol:
        sys.exit(1)


def synthetic_gt(n):
    """A car-like path: ~1.2 m steps, a slow left-then-right turn, a small vertical bob."""
    lines, x, z = [], 0.0, 0.0
    for i in range(n):
        th = 0.35 * math.sin(i / 12.0)  # heading about y
        c, s = math.cos(th), math.sin(th)
        y = 0.04 * math.sin(i / 3.0)
        lines.append(f"{c!r} 0.0 {s!r} {x!r} 0.0 1.0 0.0 {y!r} {-s!r} 0.0 {c!r} {z!r}")
        x += 1.2 * s
        z += 1.2 * c
    return "\n".join(lines) + "\n"


def vector(args):
    os.makedirs(args.out, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        # a copy of the sequence without poses.txt: nothing of the ground truth reaches the estimate
        seq = os.path.join(tmp, "seq")
        os.makedirs(seq)
        os.symlink(os.path.abspath(os.path.join(args.seq, "image_0")), os.path.join(seq, "image_0"))
        os.symlink(os.path.abspath(os.path.join(args.seq, "calib.txt")), os.path.join(seq, "calib.txt"))
        subprocess.run([args.lfast, "vo", seq, "--features", "lfast", "--frames", str(args.frames),
                        "--backend", "cpu", "--out", tmp, "--quiet"], check=True)
        with open(os.path.join(tmp, "trajectory.txt")) as f:
            est = f.read()
    gt_path, est_path = os.path.join(args.out, "gt.txt"), os.path.join(args.out, "est.txt")
    with open(gt_path, "w") as f:
        f.write(synthetic_gt(args.frames))
    with open(est_path, "w") as f:
        f.write(est)
    import evo
    expected = {
        "about": "evo's APE (translation part) of est.txt against gt.txt; est.txt is `lfast vo --features lfast "
                 f"--frames {args.frames}` on KITTI seq01 frames 0-{args.frames - 1} without poses.txt (unit steps), "
                 "gt.txt is synthetic (scripts/evo_check.py synthetic_gt). Regenerate with "
                 "`python3 scripts/evo_check.py vector SEQ_DIR`.",
        "evo_version": evo.__version__,
        "commands": {"none": "evo_ape kitti gt.txt est.txt", "se3": "evo_ape kitti gt.txt est.txt -a",
                     "sim3": "evo_ape kitti gt.txt est.txt -as"},
    }
    for name, (align, scale) in ALIGNS.items():
        expected[name] = evo_stats(gt_path, est_path, align, scale)
    with open(os.path.join(args.out, "expected.json"), "w") as f:
        json.dump(expected, f, indent=2)
        f.write("\n")
    print(json.dumps({k: expected[k] for k in ALIGNS}, indent=2))


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--lfast", default=os.path.join(ROOT, "target", "release", "lfast"))
    sub = p.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("check")
    c.add_argument("files", nargs="+")
    c.add_argument("--tol", type=float, default=1e-4)
    v = sub.add_parser("vector")
    v.add_argument("seq")
    v.add_argument("--frames", type=int, default=20)
    v.add_argument("--out", default=os.path.join(ROOT, "tests", "data", "ate"))
    args = p.parse_args()
    check(args) if args.cmd == "check" else vector(args)


if __name__ == "__main__":
    main()
