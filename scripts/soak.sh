#!/usr/bin/env bash
# Soak: the detector over many frames in one process, on the CPU and on the GPU
# (lavapipe unless WGPU_ADAPTER_NAME says otherwise), with the resident memory
# and the frame rate sampled 100 times along each run (examples/soak.rs).
# Fails (exit 1) when the memory is not flat: the mean RSS of the last 10% of
# the samples more than 5% above the mean of the first 10%.
#
#   bash scripts/soak.sh [--frames N] [--gpu-frames M] [--size WxH] [--image FILE] [--cpu-only|--gpu-only]
#   bash scripts/soak.sh --bag [--frames N] [--size WxH] [--image FILE]
#
# --bag: the same N windows as sensor_msgs/msg/Image messages in an MCAP file
# (examples/soak.rs --write-bag), then `lfast detect BAG --format mcap
# --backend cpu --jobs 1` over it, its VmRSS sampled every half second; the
# same 5% test, with the second tenth of the samples as the start (the first
# holds the start-up). Samples in $SOAK_DIR/bag.tsv; the bag and the output are
# removed afterwards.
#
# Defaults: 100000 CPU frames, 10000 GPU frames, 160x120 windows of
# tests/data/camera_cc0_v0.18plus.png, one rayon thread (frames this small gain
# nothing from more on a shared machine; set RAYON_NUM_THREADS to change it).
# The samples go to $SOAK_DIR (default target/soak)/{cpu,gpu}.tsv. Too long for
# CI; `--frames 2000 --gpu-frames 200` is a quick check of the script itself.
set -euo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")/.."
frames=100000
gpu_frames=10000
size=160x120
image=tests/data/camera_cc0_v0.18plus.png
runs="cpu gpu"
while [ $# -gt 0 ]; do
    case "$1" in
        --bag) runs=bag; shift ;;
        --frames) frames=$2; shift 2 ;;
        --gpu-frames) gpu_frames=$2; shift 2 ;;
        --size) size=$2; shift 2 ;;
        --image) image=$2; shift 2 ;;
        --cpu-only) runs=cpu; shift ;;
        --gpu-only) runs=gpu; shift ;;
        *) echo "usage: $0 [--frames N] [--gpu-frames M] [--size WxH] [--image FILE] [--cpu-only|--gpu-only|--bag]" >&2; exit 2 ;;
    esac
done
out=${SOAK_DIR:-target/soak}
mkdir -p "$out"
export RAYON_NUM_THREADS=${RAYON_NUM_THREADS:-1}
export WGPU_BACKEND=${WGPU_BACKEND:-vulkan}
export WGPU_ADAPTER_NAME=${WGPU_ADAPTER_NAME:-llvmpipe}
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-$(mktemp -d)}

cargo build --release --quiet --example soak
target=${CARGO_TARGET_DIR:-target}
bin=$target/release/examples/soak
echo "commit $(git rev-parse --short HEAD 2>/dev/null || echo unknown), $(date -u +%Y-%m-%dT%H:%MZ), $(nproc) cores, RAYON_NUM_THREADS=$RAYON_NUM_THREADS"

# Prints the run's figures from its TSV; exits non-zero when the memory grew.
check() {
    awk -F'\t' -v run="$1" '
        NR == 1 { next }
        { n++; f[n] = $1; t[n] = $2; rss[n] = $3; fps[n] = $4 }
        END {
            if (n < 10) { printf "%s: only %d samples\n", run, n; exit 1 }
            k = int(n / 10)
            for (i = 1; i <= k; i++) { a += rss[i]; b += rss[n - k + i] }
            a /= k; b /= k
            lo = hi = fps[1]; mx = rss[1]
            for (i = 1; i <= n; i++) {
                if (fps[i] < lo) lo = fps[i]; if (fps[i] > hi) hi = fps[i]; if (rss[i] > mx) mx = rss[i]
            }
            growth = 100 * (b - a) / a
            printf "%s: %d frames in %.1f s, %.1f frames/s (samples %.1f .. %.1f); RSS first 10%% %.0f KiB, last 10%% %.0f KiB (%+.2f%%), max %d KiB\n",
                run, f[n], t[n], f[n] / t[n], lo, hi, a, b, growth, mx
            if (b > 1.05 * a) { printf "%s: memory grew by more than 5%%\n", run; exit 1 }
        }' "$out/$1.tsv"
}

# --bag: lfast detect over an MCAP file of $frames messages, RSS sampled from outside
if [ "$runs" = bag ]; then
    cargo build --release --quiet --bin lfast
    bag="$out/soak.mcap"
    "$bin" --write-bag "$bag" --frames "$frames" --size "$size" "$image"
    echo "==> bag: $(du -h "$bag" | cut -f1), $frames messages of $size; target/release/lfast detect $bag --format mcap --backend cpu --jobs 1 --quiet"
    rm -rf "$out/bag_out"
    t0=$(date +%s.%N)
    "$target/release/lfast" detect "$bag" --out "$out/bag_out" --format mcap --backend cpu --jobs 1 --quiet &
    pid=$!
    printf 'seconds\trss_kib\n' > "$out/bag.tsv"
    while kill -0 "$pid" 2> /dev/null; do
        rss=$(awk '/^VmRSS:/ { print $2 }' "/proc/$pid/status" 2> /dev/null || true)
        [ -n "$rss" ] && awk -v a="$t0" -v b="$(date +%s.%N)" -v r="$rss" 'BEGIN { printf "%.1f\t%s\n", b - a, r }' >> "$out/bag.tsv"
        sleep 0.5
    done
    wait "$pid"
    awk -F'\t' '
        NR == 1 { next }
        { n++; t[n] = $1; rss[n] = $2 }
        END {
            if (n < 20) { printf "bag: only %d samples\n", n; exit 1 }
            k = int(n / 10)
            for (i = 1; i <= k; i++) { a += rss[k + i]; b += rss[n - k + i] }
            a /= k; b /= k; mx = 0
            for (i = 1; i <= n; i++) if (rss[i] > mx) mx = rss[i]
            printf "bag: %.1f s; RSS second 10%% of the samples %.0f KiB, last 10%% %.0f KiB (%+.2f%%), max %d KiB\n", t[n], a, b, 100 * (b - a) / a, mx
            if (b > 1.05 * a) { print "bag: memory grew by more than 5%"; exit 1 }
        }' "$out/bag.tsv"
    status=$?
    ls -l "$out/bag_out"
    rm -rf "$bag" "$out/bag_out"
    exit $status
fi

status=0
for run in $runs; do
    if [ "$run" = cpu ]; then
        n=$frames
        echo "==> CPU: $bin --backend cpu --frames $n --size $size $image"
    else
        n=$gpu_frames
        echo "==> GPU ($WGPU_BACKEND, $WGPU_ADAPTER_NAME): $bin --backend gpu --frames $n --size $size $image"
    fi
    "$bin" --backend "$run" --frames "$n" --samples 100 --size "$size" "$image" > "$out/$run.tsv"
    check "$run" || status=1
done
exit $status
