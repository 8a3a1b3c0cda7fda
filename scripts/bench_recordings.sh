#!/usr/bin/env bash
# Throughput of `lfast detect` on a bag of the 51 KITTI seq01 frames against
# the PNG folder, whole process (start-up, reading, decoding, detection,
# JSON writing), on the CPU: the issue-41 target is at least 0.9x the folder.
#
#   bash scripts/bench_recordings.sh [ROUNDS]      (default 9)
#
# The bags are written by python/tests/bags.py (Python's mcap +
# mcap-ros2-support): sensor_msgs/msg/Image mono8, and CompressedImage holding
# the PNG files' own bytes. The three inputs run in turn, ROUNDS times; the
# medians of wall and CPU (user + sys) time are printed with the ratios
# folder / bag (above 1: the bag is faster). Needs target/release/lfast (or
# $CARGO_TARGET_DIR's) and ../shared/data.
set -euo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")/.."
rounds=${1:-9}
lfast=${CARGO_TARGET_DIR:-target}/release/lfast
kitti=../shared/data/kitti/seq01_000000-000050/image_0
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cargo build --release --quiet --bin lfast
python3 - "$kitti" "$work" <<'PY'
import sys
from pathlib import Path
sys.path.insert(0, "python/tests")
import cv2
import bags
kitti, work = Path(sys.argv[1]), Path(sys.argv[2])
files = sorted(kitti.glob("*.png"))
frames = [cv2.imread(str(f), cv2.IMREAD_GRAYSCALE) for f in files]
bags.write_ros2(work / "mono8.mcap", [("/kitti/image", "sensor_msgs/msg/Image",
    [(bags.log_time(i), bags.image_msg(g, "mono8", i)) for i, g in enumerate(frames)])])
bags.write_ros2(work / "png.mcap", [("/kitti/image", "sensor_msgs/msg/CompressedImage",
    [(bags.log_time(i), bags.compressed_msg(f.read_bytes(), "png", i)) for i, f in enumerate(files)])])
PY
echo "commit $(git rev-parse --short HEAD 2>/dev/null || echo unknown), $(date -u +%Y-%m-%dT%H:%MZ), $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg), $rounds rounds"
for r in $(seq "$rounds"); do
    for v in folder mono8 png; do
        case $v in folder) in=$kitti ;; *) in=$work/$v.mcap ;; esac
        rm -rf "$work/out"
        /usr/bin/time -f "$v %e %U %S" -a -o "$work/times" "$lfast" detect "$in" --out "$work/out" --backend cpu --quiet > /dev/null
    done
done
awk '
    { wall[$1] = wall[$1] " " $2; cpu[$1] = cpu[$1] " " ($3 + $4) }
    function median(s,    a, n, i, j, t) {
        n = split(s, a, " ")
        for (i = 1; i <= n; i++) for (j = i + 1; j <= n; j++) if (a[j] < a[i]) { t = a[i]; a[i] = a[j]; a[j] = t }
        return n % 2 ? a[(n + 1) / 2] : (a[n / 2] + a[n / 2 + 1]) / 2
    }
    END {
        fw = median(wall["folder"]); fc = median(cpu["folder"])
        printf "%-28s %8s %8s %16s\n", "input (51 frames)", "wall s", "cpu s", "throughput x"
        printf "%-28s %8.2f %8.2f %16s\n", "PNG folder", fw, fc, "1 (reference)"
        split("mono8 png", v, " ")
        name["mono8"] = "bag, Image mono8"; name["png"] = "bag, CompressedImage png"
        for (i = 1; i <= 2; i++) {
            w = median(wall[v[i]]); c = median(cpu[v[i]])
            printf "%-28s %8.2f %8.2f %16.2f\n", name[v[i]], w, c, fw / w
        }
    }' "$work/times"
