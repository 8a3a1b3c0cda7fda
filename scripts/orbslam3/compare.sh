#!/usr/bin/env bash
# The extractor comparison of docs/orbslam.md, end to end: builds both
# ORB-SLAM3 variants (cached), then runs each extractor RUNS times on
#   KITTI 00 frames 0-199, monocular;
#   KITTI 00 frames 0-99, stereo (the shared excerpt has right images for those);
#   KITTI 01 frames 0-50, monocular, with a vocabulary trained without seq01;
#   KITTI 00 frames 0-199, monocular again, paced at 10 Hz (upstream's
#   real-time pacing, for reference: machine-dependent);
# and prints the summary table (also OUT/summary.{md,csv,json}).
#
#   scripts/orbslam3/compare.sh [OUT_DIR] [RUNS]      (defaults: orbslam3-results, 5)
#
# LFAST_TEST_DATA: the shared data directory (default ../shared/data beside
# the checkout). Other variables: see build.sh and run.sh.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
data="${LFAST_TEST_DATA:-$root/../shared/data}"
# The whole run sits in a function, read before it starts: editing this file
# while it runs does not derail it.
main() {
    out="${1:-orbslam3-results}"
    runs="${2:-5}"

    case "$out" in -h | --help) sed -n '2,/^set -euo/p' "${BASH_SOURCE[0]}" | sed '$d; s/^# \{0,1\}//'; exit 0 ;; esac
    seq00="$data/kitti/seq00_000000-000199"
    seq01="$data/kitti/seq01_000000-000050"
    for d in "$seq00" "$seq01"; do [ -d "$d" ] || { echo "compare.sh: error: no $d (set LFAST_TEST_DATA)" >&2; exit 1; }; done

    mkdir -p "$out"
    {
        echo "date: $(date -u +%Y-%m-%dT%H:%MZ)"
        echo "lfast commit: $(git -C "$root" rev-parse --short HEAD 2> /dev/null || echo unknown)"
        echo "machine: $(lscpu 2> /dev/null | sed -n 's/^Model name: *//p' | head -1), $(nproc) CPUs"
    } | tee "$out/machine.txt"

    "$here/build.sh" --variant both
    "$here/run.sh" "$seq00" --sensor mono --extractor both --runs "$runs" --out "$out" > /dev/null
    "$here/run.sh" "$seq00" --sensor stereo --frames 0-99 --extractor both --runs "$runs" --out "$out" > /dev/null
    "$here/run.sh" "$seq01" --sensor mono --extractor both --runs "$runs" --out "$out" \
        --vocabulary without-seq01 > /dev/null
    "$here/run.sh" "$seq00" --sensor mono --pace realtime --extractor both --runs "$runs" --out "$out" > /dev/null
    python3 "$here/results.py" summary "$out"
}

main "$@"; exit
