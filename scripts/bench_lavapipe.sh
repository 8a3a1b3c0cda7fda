#!/usr/bin/env bash
# The whole process on lavapipe against the CPU path (BENCHMARKS.md "lavapipe"):
# `lfast detect DIR` with `--backend cpu`, then with `--backend gpu` on Mesa's
# llvmpipe, for one build or two alternated. Each round times the CPU run of the
# first build, then the GPU runs, A before B in odd rounds and B before A in even
# ones: on the 2-vCPU VM the second GPU run of a round measured ~3.6% faster than
# the first whichever build it was, so a fixed order favours one build.
#
#   scripts/bench_lavapipe.sh ROUNDS DIR LFAST_A [LFAST_B]
#
# Prints a line per round (seconds; the GPU runs over the round's CPU run) and the
# medians; with two builds, the median over the rounds of B's GPU time over A's.
set -euo pipefail
[ $# -ge 3 ] || { sed -n '2,12p' "$0" | sed 's/^# \{0,1\}//'; exit 2; }
rounds=$1 dir=$2 a=$3 b=${4:-}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
secs() { # seconds of one run of "$@", its output discarded
    local t0 t1
    t0=$(date +%s.%N)
    "$@" >/dev/null 2>&1 || { echo "failed: $*" >&2; exit 1; }
    t1=$(date +%s.%N)
    awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.3f\n", b - a }'
}
gpu() { WGPU_BACKEND=vulkan WGPU_ADAPTER_NAME=llvmpipe secs "$1" detect "$dir" --backend gpu --out "$out/gpu" --quiet; }
for r in $(seq "$rounds"); do
    c=$(secs "$a" detect "$dir" --backend cpu --out "$out/cpu" --quiet)
    if [ -z "$b" ]; then
        ga=$(gpu "$a") gb=0
    elif [ $((r % 2)) = 1 ]; then
        ga=$(gpu "$a") gb=$(gpu "$b")
    else
        gb=$(gpu "$b") ga=$(gpu "$a")
    fi
    echo "$r $c $ga $gb"
done | awk -v two="${b:+1}" '
    function median(v, n,   i, j, t) {
        for (i = 2; i <= n; i++) for (j = i; j > 1 && v[j-1] > v[j]; j--) { t = v[j]; v[j] = v[j-1]; v[j-1] = t }
        return n % 2 ? v[(n+1)/2] : (v[n/2] + v[n/2+1]) / 2
    }
    {
        n++; ra[n] = $3 / $2; rb[n] = two ? $4 / $2 : 0; p[n] = two ? $4 / $3 : 0
        if (two) printf "round %d: cpu %.3f s, A %.3f s (%.2fx), B %.3f s (%.2fx)\n", $1, $2, $3, ra[n], $4, rb[n]
        else printf "round %d: cpu %.3f s, gpu %.3f s (%.2fx)\n", $1, $2, $3, ra[n]
    }
    END {
        if (two) printf "median: A %.2fx, B %.2fx; B / A per round %.3f\n", median(ra, n), median(rb, n), median(p, n)
        else printf "median: %.2fx\n", median(ra, n)
    }'
