#!/usr/bin/env bash
# Instructions per detect_and_compute, counted by valgrind's cachegrind: a
# cost measure that does not move with the load of a shared machine (the
# wall-clock ratios of bench_frames do; see BENCHMARKS.md). Instructions are
# not time (vector width, cache misses and branch mispredictions weigh
# differently), so quote it beside timings, never instead of them.
#
#   scripts/bench_instructions.sh [-n FRAMES] BENCH_FRAMES_BIN [BENCH_FRAMES_BIN ...]
#
# Each BENCH_FRAMES_BIN is a build of examples/bench_frames.rs (for example
# target/release/examples/bench_frames, or one built at another commit). Each
# runs on one thread over the first FRAMES (default 5) KITTI frames of
# ../shared, once with --repeats 1 and once with --repeats 3; half the
# difference is the instructions of one pass over the frames, without
# loading, decoding and the first call's allocations. Prints that count per
# frame for each binary and its ratio to the first.
set -euo pipefail
frames=5
if [[ "${1:-}" == "-n" ]]; then
    frames=$2
    shift 2
fi
if [[ $# -lt 1 ]]; then
    sed -n '2,16p' "$0" | sed 's/^# \{0,1\}//'
    exit 2
fi
command -v valgrind >/dev/null || { echo "valgrind is not installed (apt-get install valgrind)" >&2; exit 2; }
here=$(cd "$(dirname "$0")/.." && pwd)
data=${LFAST_TEST_DATA:-$here/../shared/data}
mapfile -t files < <(ls "$data"/kitti/seq01_000000-000050/image_0/*.png | head -n "$frames")
[[ ${#files[@]} -gt 0 ]] || { echo "no KITTI frames under $data/kitti (LFAST_TEST_DATA or ../shared/data)" >&2; exit 2; }

count() { # BIN REPEATS -> instructions of the whole run
    RAYON_NUM_THREADS=1 valgrind --tool=cachegrind --cache-sim=no --cachegrind-out-file=/dev/null \
        "$1" --repeats "$2" --only lfast_detect_and_compute "${files[@]}" 2>&1 >/dev/null |
        sed -n 's/.*I *refs: *//p' | tr -d ,
}

first=""
for bin in "$@"; do
    [[ -x "$bin" ]] || { echo "$bin is not an executable" >&2; exit 2; }
    one=$(count "$bin" 1)
    three=$(count "$bin" 3)
    per_frame=$(( (three - one) / 2 / ${#files[@]} ))
    first=${first:-$per_frame}
    python3 -c "print('%-60s %12d instructions/frame  %.3fx' % ('$bin', $per_frame, $per_frame / $first))"
done
