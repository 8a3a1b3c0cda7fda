#!/usr/bin/env bash
# Runs the cargo-fuzz targets of fuzz/ (issue 8), each for a fixed time, and
# records executions and CPU time. CI does not run this: CI replays the
# inputs kept in tests/data/regress/<target>/ (tests/reliability.rs).
#
#   bash scripts/fuzz.sh [SECONDS_PER_TARGET] [TARGET...]
#
# Targets: decode_detect, cpu_pipeline, cpu_vs_gpu (default: all three, one
# after the other). Needs nightly Rust and cargo-fuzz (`cargo install
# cargo-fuzz`); cpu_vs_gpu needs a GPU adapter (WGPU_ADAPTER_NAME=llvmpipe for
# Mesa's software Vulkan, the default here). Runs at low priority (NICE=19).
# Each target starts from the inputs in tests/data/regress/<target>/ (seeds
# and every crash found so far) plus its own corpus in fuzz/corpus/<target>/.
# A crash stops that target; its input is in fuzz/artifacts/<target>/: fix
# it, copy the input into tests/data/regress/<target>/ and run again.
#
# Output: fuzz/logs/<target>.log (libFuzzer's log) and one line per run
# appended to fuzz/logs/runs.tsv:
#   date  target  seconds(wall)  cpu_seconds(user+sys)  executions  exit  crash_file
set -uo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")/../fuzz"
secs="${1:-600}"
shift || true
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(decode_detect cpu_pipeline cpu_vs_gpu)
nice_level="${NICE:-19}"

export WGPU_ADAPTER_NAME="${WGPU_ADAPTER_NAME:-llvmpipe}"
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-$(mktemp -d)}"
# lavapipe: one rasterizer thread is enough for tiny frames, and keeps the
# fuzzer to about one core
export LP_NUM_THREADS="${LP_NUM_THREADS:-1}"
export RAYON_NUM_THREADS="${RAYON_NUM_THREADS:-1}"
# leaks in the Vulkan driver are not ours
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=0}"

nice -n "$nice_level" cargo +nightly fuzz build >/dev/null 2>&1 \
    || nice -n "$nice_level" cargo +nightly fuzz build || exit 2

mkdir -p logs
[ -f logs/runs.tsv ] || printf 'date\ttarget\twall_s\tcpu_s\texecutions\texit\tcrash\n' > logs/runs.tsv
status=0
for t in "${targets[@]}"; do
    mkdir -p "corpus/$t" "artifacts/$t"
    cp -n ../tests/data/regress/"$t"/* "corpus/$t/" 2>/dev/null || true
    extra=()
    case "$t" in
        decode_detect) extra=(-max_len=65536) ;;
        cpu_pipeline) extra=(-max_len=8192) ;;
        cpu_vs_gpu) extra=(-max_len=2048) ;;
    esac
    # crash-, leak-, oom- and timeout- files are failures; slow-unit- files
    # (over 10 s, usually the sanitizer's cost) are only reported
    findings() { ls "artifacts/$t" | grep -E '^(crash|leak|oom|timeout)-' ; }
    before=$(findings | wc -l)
    start=$(date +%s)
    # /usr/bin/time: CPU seconds of the fuzzer and everything it runs
    /usr/bin/time -f '%U %S' -o "logs/$t.time" \
        nice -n "$nice_level" cargo +nightly fuzz run "$t" "corpus/$t" -- \
        -max_total_time="$secs" -timeout=120 -rss_limit_mb=4096 -print_final_stats=1 "${extra[@]}" \
        > "logs/$t.log" 2>&1
    code=$?
    wall=$(( $(date +%s) - start ))
    cpu=$(awk '{printf "%.0f", $1 + $2}' "logs/$t.time" 2>/dev/null | tail -1)
    execs=$(grep -o 'stat::number_of_executed_units: [0-9]*' "logs/$t.log" | awk '{print $2}' | tail -1)
    if [ -z "$execs" ]; then  # killed by a crash: the last progress line
        execs=$(grep -oE '^#[0-9]+' "logs/$t.log" | tail -1 | tr -d '#')
    fi
    crash=""
    if [ "$(findings | wc -l)" -gt "$before" ]; then
        crash=$(ls -t "artifacts/$t" | grep -E '^(crash|leak|oom|timeout)-' | head -1)
        status=1
    fi
    printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$(date -u +%FT%TZ)" "$t" "$wall" "${cpu:-?}" "${execs:-?}" "$code" "${crash:--}" \
        | tee -a logs/runs.tsv
done
exit $status
