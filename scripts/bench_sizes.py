#!/usr/bin/env python3
"""Time per pixel and peak memory of lfast (CPU and lavapipe) and cv2 ORB over image sizes.

Sizes (WxH, default): 640x480, 1241x376 (KITTI), 1920x1080, 3840x2160, 4000x3000.
Two kinds of frames per size, four frames each, real texture throughout:
  homography  img1 of the four Oxford scenes (graf, boat, bikes, leuven), read
              as grayscale and resized to WxH with cv2.INTER_CUBIC. The aspect
              ratio is not kept: the scenes are stretched (or squeezed) to the
              size, so that every frame has exactly W*H pixels.
  kitti       mosaics of the 51 KITTI seq01 frames (1241x376 gray): tiles laid
              in reading order, consecutive frames, as many as cover WxH, then
              cropped to WxH at the top left. Mosaic j (0..3) starts at frame
              13*j (0, 13, 26, 39, one quarter of the sequence apart) and wraps
              around after frame 50; at 1241x376 each mosaic is that one frame
              unchanged, at 4000x3000 it takes 4x8 = 32 frames.
The frames are generated deterministically into --images DIR (kept and reused
when present) or a temporary folder (removed afterwards), as lossless PNG, or
JPEG of quality 95 with --format jpg.

Each measure is a child process of its own, started by GNU /usr/bin/time
(whose %M is the child's peak RSS), its CPU time (user + sys) read with
os.wait4, its wall time around it:
  lfast cpu       `lfast detect FILES --out TMP --backend cpu --quiet --jobs N`
  lfast lavapipe  the same with --backend gpu, WGPU_ADAPTER_NAME=llvmpipe and
                  LP_NUM_THREADS=N (Mesa's software Vulkan); when it cannot run
                  (no Vulkan, no llvmpipe) its rows say n/a and why. --no-gpu
                  skips it.
  cv2 ORB(2000)   `python3 -c ...`: cv2.setNumThreads(N), then a loop of
                  cv2.imread(f, cv2.IMREAD_GRAYSCALE) and
                  cv2.ORB_create(2000).detectAndCompute(img, None) over FILES.
N is --threads (default: os.cpu_count()), passed to both explicitly. lfast
detects several frames at once in its pool of N threads; the cv2 loop takes
one frame after the other (OpenCV parallelises inside a frame, where it can).
All are whole processes: start-up (the interpreter and `import cv2`; the
Vulkan instance and pipelines for lavapipe), reading, decoding, detection and,
for lfast, JSON writing count. lfast runs with its default configuration,
which has no keypoint cap (its count grows with the pixels, 4-9k at 1920x1080)
where cv2 keeps 2000: the keypoints column says how much each one described.
Each tool runs on the four frames of a size and
kind (FILES: 4 frames) and on the first alone (1 frame): the difference shows
the fixed start-up cost and the memory of one frame against a batch.

Reported per measure: wall and CPU time per frame (the median of --repeats
runs), ns per pixel (wall per frame / W*H), the peak RSS (the maximum over the
runs) in MB (10^6 bytes) and in bytes per pixel (/ W*H; a 4-frame batch holds
several frames at once), and keypoints per frame. The repeats are interleaved
(run r of every measure of a size and kind before run r+1); each tool runs
once, untimed, on the smallest frame first (page cache, Mesa's shader cache).

Writes a Markdown table to stdout and, with --out DIR, DIR/sizes.csv (times in
seconds, the header lines as `#` comments), DIR/sizes.md and DIR/sizes.png: ns per pixel (4-frame batch) and peak
RSS bytes per pixel (one frame alone) against megapixels, one line per tool
and kind. Frames from $LFAST_TEST_DATA (default ../shared/data): without them
the script says what is missing and exits 0 (in CI, an error).
Requires: numpy, opencv-python-headless, matplotlib; GNU time (/usr/bin/time).

Usage: python3 scripts/bench_sizes.py [--bin PATH] [--sizes WxH,...] [--repeats R]
           [--threads N] [--no-gpu] [--images DIR] [--format png|jpg] [--out DIR]
"""

import argparse
import csv
import datetime
import io
import json
import os
import shlex
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np
from lfast_data import data_dir, in_ci, note_skip

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_SIZES = "640x480,1241x376,1920x1080,3840x2160,4000x3000"
SCENES = ["graf", "boat", "bikes", "leuven"]
KITTI_SEQ = Path("kitti") / "seq01_000000-000050" / "image_0"
N_FRAMES = 4
KITTI_STRIDE = 13  # first frame of mosaic j: 13 * j
TIME = "/usr/bin/time"  # GNU time
TOOLS = ["lfast cpu", "lfast lavapipe", "cv2 ORB(2000)"]

CV2_CHILD = r"""
import sys
import cv2
cv2.setNumThreads(int(sys.argv[1]))
orb = cv2.ORB_create(2000)
n = 0
for f in sys.argv[2:]:
    img = cv2.imread(f, cv2.IMREAD_GRAYSCALE)
    if img is None:
        sys.exit(f"cannot read {f}")
    n += len(orb.detectAndCompute(img, None)[0])
print(n)
"""


def parse_sizes(text):
    sizes = []
    for item in text.split(","):
        try:
            w, h = (int(v) for v in item.strip().lower().split("x"))
        except ValueError:
            raise argparse.ArgumentTypeError(f"{item!r}: expected WxH, e.g. 640x480") from None
        if w < 32 or h < 32:
            raise argparse.ArgumentTypeError(f"{item!r}: at least 32x32")
        sizes.append((w, h))
    return sizes


# ---- frames ----------------------------------------------------------------

def homography_frames(data, w, h):
    for scene in SCENES:
        img = cv2.imread(str(data / "homography" / scene / "img1.png"), cv2.IMREAD_GRAYSCALE)
        if img is None:
            raise SystemExit(f"cannot read {data / 'homography' / scene / 'img1.png'}")
        yield scene, cv2.resize(img, (w, h), interpolation=cv2.INTER_CUBIC)


def kitti_frames(kitti, w, h):
    files = sorted(kitti.glob("*.png"))
    cache = {}

    def frame(i):
        if i not in cache:
            img = cv2.imread(str(files[i]), cv2.IMREAD_GRAYSCALE)
            if img is None:
                raise SystemExit(f"cannot read {files[i]}")
            cache[i] = img
        return cache[i]

    th, tw = frame(0).shape
    nx, ny = -(-w // tw), -(-h // th)
    for j in range(N_FRAMES):
        start = KITTI_STRIDE * j
        rows = [np.hstack([frame((start + y * nx + x) % len(files)) for x in range(nx)]) for y in range(ny)]
        yield f"kitti{start:02d}", np.vstack(rows)[:h, :w]


def make_frames(root, data, kind, size, fmt):
    """The four frames of `kind` at `size` under root/WxH/kind/, written unless present."""
    w, h = size
    folder = root / f"{w}x{h}" / kind
    gen = homography_frames(data, w, h) if kind == "homography" else kitti_frames(data / KITTI_SEQ, w, h)
    names = SCENES if kind == "homography" else [f"kitti{KITTI_STRIDE * j:02d}" for j in range(N_FRAMES)]
    paths = [folder / f"{n}.{fmt}" for n in names]
    if all(p.is_file() for p in paths):
        return paths
    folder.mkdir(parents=True, exist_ok=True)
    params = [cv2.IMWRITE_JPEG_QUALITY, 95] if fmt == "jpg" else [cv2.IMWRITE_PNG_COMPRESSION, 3]
    for (name, img), path in zip(gen, paths):
        assert img.shape == (h, w), (name, img.shape)
        tmp = path.with_name(path.stem + ".tmp." + fmt)
        if not cv2.imwrite(str(tmp), img, params):
            raise SystemExit(f"cannot write {tmp}")
        tmp.replace(path)
    return paths


# ---- measures --------------------------------------------------------------

def run_child(cmd, env):
    """Runs cmd; (exit code, wall s, cpu s, peak RSS bytes, stdout, stderr).

    The peak RSS is GNU time's %M: ru_maxrss of a child started from this
    process would count this process's own peak (Linux carries the high-water
    mark over exec), /usr/bin/time forks the command from a small process. CPU
    time (user + sys, with /usr/bin/time's own few ms) comes from os.wait4.
    """
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err, \
            tempfile.NamedTemporaryFile(mode="r") as rss:
        t = time.perf_counter()
        p = subprocess.Popen([TIME, "-f", "%M", "-o", rss.name] + cmd, stdout=out, stderr=err, env=env, cwd=ROOT)
        _, status, ru = os.wait4(p.pid, 0)
        wall = time.perf_counter() - t
        p.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        lines = rss.read().split()
        return (p.returncode, wall, ru.ru_utime + ru.ru_stime, int(lines[-1]) * 1024 if lines else 0,
                out.read().decode(errors="replace"), err.read().decode(errors="replace"))


class Tool:
    def __init__(self, name, args):
        self.name = name
        self.args = args
        self.unavailable = None  # the reason, once it cannot start at all
        env = dict(os.environ)
        if name == "lfast lavapipe":
            env["WGPU_ADAPTER_NAME"] = "llvmpipe"
            env["LP_NUM_THREADS"] = str(args.threads)
        self.env = env

    def command(self, files, out):
        if self.name == "cv2 ORB(2000)":
            return [sys.executable, "-c", CV2_CHILD, str(self.args.threads)] + [str(f) for f in files]
        backend = "gpu" if self.name == "lfast lavapipe" else "cpu"
        return ([str(self.args.bin), "detect"] + [str(f) for f in files]
                + ["--out", str(out), "--backend", backend, "--quiet", "--jobs", str(self.args.threads)])

    def run(self, files, want_count):
        """One run: (wall s, cpu s, peak RSS bytes, keypoints or None), or a str: why it failed."""
        out = Path(tempfile.mkdtemp(prefix="lfast_sizes_"))
        try:
            code, wall, cpu, rss, stdout, stderr = run_child(self.command(files, out), self.env)
            if code != 0:
                lines = [ln.strip() for ln in stderr.splitlines() if ln.strip()]
                reason = f"exit {code}: {lines[-1] if lines else 'no message'}"
                if code == 2 and self.name.startswith("lfast"):
                    self.unavailable = reason  # could not start: the same for every size
                return reason
            count = None
            if want_count:
                if self.name == "cv2 ORB(2000)":
                    count = int(stdout.split()[-1])
                else:
                    count = sum(len(json.loads(p.read_text()).get("keypoints", [])) for p in out.glob("*.json"))
            return wall, cpu, rss, count
        finally:
            shutil.rmtree(out, ignore_errors=True)


def measure(tools, size, kind, files, repeats):
    """Rows of one size and kind: every tool on the 4 frames and on the first alone."""
    w, h = size
    cases = [(t, fs) for t in tools for fs in (files, files[:1])]
    runs = {i: [] for i in range(len(cases))}
    failed = {}
    for r in range(repeats):
        for i, (tool, fs) in enumerate(cases):
            if i in failed:
                continue
            if tool.unavailable:
                failed[i] = tool.unavailable
                continue
            res = tool.run(fs, want_count=(r == 0))
            if isinstance(res, str):
                print(f"{tool.name}, {w}x{h} {kind}, {len(fs)} frame(s): {res}", file=sys.stderr)
                failed[i] = res
            else:
                runs[i].append(res)
    rows = []
    for i, (tool, fs) in enumerate(cases):
        row = {"width": w, "height": h, "megapixels": w * h / 1e6, "kind": kind, "tool": tool.name,
               "frames": len(fs), "repeats": len(runs[i])}
        if i in failed:
            row["status"] = "n/a: " + failed[i]
        else:
            n = len(fs)
            wall = statistics.median(r[0] for r in runs[i]) / n
            rss = max(r[2] for r in runs[i])
            row.update(status="ok", wall_s_per_frame=wall,
                       cpu_s_per_frame=statistics.median(r[1] for r in runs[i]) / n,
                       ns_per_pixel=wall * 1e9 / (w * h), peak_rss_mb=rss / 1e6,
                       rss_bytes_per_pixel=rss / (w * h), keypoints_per_frame=runs[i][0][3] / n)
        rows.append(row)
    return rows


# ---- report ----------------------------------------------------------------

CSV_FIELDS = ["width", "height", "megapixels", "kind", "tool", "frames", "repeats", "status",
              "wall_s_per_frame", "cpu_s_per_frame", "ns_per_pixel", "peak_rss_mb",
              "rss_bytes_per_pixel", "keypoints_per_frame"]


def markdown(rows):
    lines = ["| size | MP | kind | tool | frames | wall ms/frame | CPU ms/frame | ns/pixel | peak RSS MB "
             "| RSS B/pixel | keypoints/frame |",
             "|---|---:|---|---|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        head = f"| {r['width']}x{r['height']} | {r['megapixels']:.2f} | {r['kind']} | {r['tool']} | {r['frames']} |"
        if r["status"] != "ok":
            lines.append(head + f" {r['status'].replace('|', '/')} | | | | | |")
        else:
            lines.append(head + f" {r['wall_s_per_frame'] * 1e3:.1f} | {r['cpu_s_per_frame'] * 1e3:.1f} "
                         f"| {r['ns_per_pixel']:.1f} | {r['peak_rss_mb']:.0f} | {r['rss_bytes_per_pixel']:.1f} "
                         f"| {r['keypoints_per_frame']:.0f} |")
    return "\n".join(lines)


def plot(rows, path, title):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8))
    panels = [(axes[0], N_FRAMES, "ns_per_pixel", f"ns per pixel (wall, {N_FRAMES}-frame batch)"),
              (axes[1], 1, "rss_bytes_per_pixel", "peak RSS bytes per pixel (one frame alone)")]
    colors = {"lfast cpu": "C0", "lfast lavapipe": "C1", "cv2 ORB(2000)": "C2"}
    styles = {"homography": ("-", "o"), "kitti": ("--", "s")}
    for ax, frames, key, label in panels:
        for tool in TOOLS:
            for kind in styles:
                pts = sorted((r["megapixels"], r[key]) for r in rows
                             if r["tool"] == tool and r["kind"] == kind and r["frames"] == frames
                             and r["status"] == "ok")
                if pts:
                    ls, marker = styles[kind]
                    ax.plot(*zip(*pts), ls=ls, marker=marker, color=colors[tool], label=f"{tool}, {kind}")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("megapixels")
        ax.set_ylabel(label)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def git_commit():
    try:
        rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, check=True,
                             stdout=subprocess.PIPE, text=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=ROOT, check=True,
                               stdout=subprocess.PIPE, text=True).stdout.strip()
        return rev + ("+dirty" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def cpu_info():
    """(model, count) from lscpu."""
    model, count = "unknown", str(os.cpu_count())
    try:
        out = subprocess.run(["lscpu"], check=True, stdout=subprocess.PIPE, text=True,
                             env=dict(os.environ, LC_ALL="C")).stdout
        for line in out.splitlines():
            key, _, value = line.partition(":")
            if key.strip() == "Model name":
                model = value.strip()
            elif key.strip() == "CPU(s)":
                count = value.strip()
    except (OSError, subprocess.CalledProcessError):
        pass
    return model, count


def header(args, commit):
    model, count = cpu_info()
    try:
        version = subprocess.run([str(args.bin), "--version"], check=True, stdout=subprocess.PIPE,
                                 text=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        version = "lfast (version unknown)"
    return [
        f"date {datetime.datetime.now(datetime.timezone.utc).strftime('%Y-%m-%d %H:%M UTC')}, commit {commit}",
        f"CPU {model}, {count} CPUs; load average {os.getloadavg()[0]:.2f}",
        f"{version} ({args.bin}); OpenCV {cv2.__version__}; {args.threads} threads each; "
        f"runs per measure: {args.repeats} (median time, max RSS); {args.format.upper()} frames",
        f"command: {shlex.join([sys.executable] + sys.argv)}",
    ]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--bin", type=Path, default=ROOT / "target" / "release" / "lfast",
                    help="the lfast CLI (default target/release/lfast)")
    ap.add_argument("--sizes", type=parse_sizes, default=parse_sizes(DEFAULT_SIZES),
                    help=f"comma-separated WxH (default {DEFAULT_SIZES})")
    ap.add_argument("--repeats", "-r", type=int, default=3, help="runs per measure (default 3)")
    ap.add_argument("--threads", type=int, default=os.cpu_count(),
                    help="lfast --jobs, LP_NUM_THREADS and cv2.setNumThreads (default: os.cpu_count())")
    ap.add_argument("--no-gpu", action="store_true", help="skip lfast on lavapipe")
    ap.add_argument("--images", type=Path, help="keep the generated frames here and reuse them (default: a "
                    "temporary folder)")
    ap.add_argument("--format", choices=["png", "jpg"], default="png",
                    help="frame files: lossless PNG (default) or JPEG quality 95")
    ap.add_argument("--out", type=Path, help="write sizes.csv, sizes.md and sizes.png here")
    ap.add_argument("--commit", help="what the measured binary was built from (default: this checkout's "
                    "`git rev-parse --short HEAD`, +dirty if it has uncommitted changes)")
    args = ap.parse_args()
    if args.repeats < 1:
        ap.error("--repeats must be >= 1")
    if args.threads < 1:
        ap.error("--threads must be >= 1")
    args.bin = args.bin.resolve()  # the children run in the repository root
    if args.images:
        args.images = args.images.resolve()
    if not args.bin.exists():
        raise SystemExit(f"{args.bin} not found: cargo build --release, or --bin PATH")
    if not Path(TIME).is_file():
        raise SystemExit(f"{TIME} not found: apt-get install time (GNU time measures the peak RSS)")

    data = data_dir()
    needed = [data / "homography" / s / "img1.png" for s in SCENES] + [data / KITTI_SEQ / "000050.png"]
    missing = [p for p in needed if not p.is_file()]
    if missing:
        if in_ci():
            raise SystemExit(f"bench_sizes.py: {missing[0]} not found")
        note_skip("bench_sizes.py", missing[0])
        return 0

    tools = [Tool(name, args) for name in TOOLS if not (args.no_gpu and name == "lfast lavapipe")]
    lines = header(args, args.commit or git_commit())
    sizes = sorted(args.sizes, key=lambda s: s[0] * s[1])
    kinds = ["homography", "kitti"]
    rows = []
    with tempfile.TemporaryDirectory(prefix="lfast_sizes_img_") as tmp:
        images = args.images or Path(tmp)
        frames = {(s, k): make_frames(images, data, k, s, args.format) for s in sizes for k in kinds}
        for tool in tools:  # warm-up: page cache, Mesa's shader cache
            res = tool.run(frames[(sizes[0], kinds[0])][:1], want_count=False)
            if isinstance(res, str):
                print(f"{tool.name}, warm-up: {res}", file=sys.stderr)
        for s in sizes:
            for k in kinds:
                rows += measure(tools, s, k, frames[(s, k)], args.repeats)

    table = markdown(rows)
    text = "\n".join(lines) + "\n\n" + table + "\n"
    print(text)
    if args.out:
        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / "sizes.md").write_text(text)
        buf = io.StringIO()
        wr = csv.DictWriter(buf, fieldnames=CSV_FIELDS, lineterminator="\n")
        wr.writeheader()
        for r in rows:
            wr.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})
        (args.out / "sizes.csv").write_text("".join("# " + ln + "\n" for ln in lines) + buf.getvalue())
        plot(rows, args.out / "sizes.png", "\n".join(lines[:3]))
        print(f"wrote {args.out / 'sizes.csv'}, {args.out / 'sizes.md'}, {args.out / 'sizes.png'}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
