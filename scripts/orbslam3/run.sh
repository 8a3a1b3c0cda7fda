#!/usr/bin/env bash
# Runs ORB-SLAM3 on a KITTI-format sequence with its own extractor and/or
# lfast's, N times each, scores every run and prints a summary table.
#
#   scripts/orbslam3/run.sh SEQ_DIR --sensor mono|stereo --extractor orbslam3|lfast|both
#                           --runs N --out DIR [--frames FIRST-LAST]
#                           [--pace lockstep|free|realtime] [--gt POSES]
#                           [--vocabulary default|without-seq01]
#
# SEQ_DIR: image_0/NNNNNN.png (+ image_1/ for stereo), calib.txt (rows P0, P1),
# times.txt (10 Hz when absent), poses.txt (ground truth, one row per frame of
# image_0; or --gt). The ORB-SLAM3 settings are generated from calib.txt
# (results.py settings), the rest as ORB-SLAM3's KITTI00-02.yaml.
#
# --pace lockstep (default): the next frame is fed only when LocalMapping and
#   LoopClosing have done the work the last one gave them, so that results
#   do not depend on the machine's speed (kitti_driver.cc). Monocular KITTI
#   fails with --pace free (see docs/orbslam.md).
#
# Per run, DIR/SENSOR-EXTRACTOR/runK/: frames.csv (per frame: state,
# keypoints, extraction and tracking ms, tracked or not), trajectory.txt
# (KITTI poses of the tracked frames) + trajectory_frames.txt, lost_frames.txt,
# gt_tracked.txt, ate.json (lfast ate), summary.json, run.json (all of it,
# with the vocabulary and the lfast commit), log.txt. DIR/summary.{md,csv,json}
# summarise every run under DIR (also those of earlier calls).
#
# ATE: `lfast ate GT EST --align sim3` (mono) or `se3` (stereo) over the
# frames tracked in the final map; frames of maps that were reset count as
# not tracked. Builds what it needs first (build.sh, cached; the lfast CLI
# with cargo unless LFAST_BIN names it); the vocabulary: vocabulary.sh
# (ORBVOC=PATH to use your own).
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
prefix="${ORBSLAM3_PREFIX:-$HOME/.cache/lfast/orbslam3}"

die() { echo "run.sh: error: $*" >&2; exit 1; }
usage() { sed -n '2,/^set -euo/p' "${BASH_SOURCE[0]}" | sed '$d; s/^# \{0,1\}//'; }

# The whole run sits in a function, read before it starts: editing this file
# while it runs does not derail it.
main() {
    seq="" sensor="" extractors=() runs="" out="" frames="" pace=lockstep gt="" vocab_set=default
    while [ $# -gt 0 ]; do
        case "$1" in
            --sensor) sensor="${2:-}"; shift 2 || die "--sensor needs mono or stereo" ;;
            --extractor)
                case "${2:-}" in
                    orbslam3 | lfast) extractors=("$2") ;;
                    both) extractors=(orbslam3 lfast) ;;
                    *) die "--extractor: '${2:-}' is not orbslam3, lfast or both" ;;
                esac
                shift 2 ;;
            --runs) runs="${2:-}"; shift 2 || die "--runs needs a number" ;;
            --out) out="${2:-}"; shift 2 || die "--out needs a directory" ;;
            --frames) frames="${2:-}"; shift 2 || die "--frames needs FIRST-LAST" ;;
            --pace) pace="${2:-}"; shift 2 || die "--pace needs lockstep, free or realtime" ;;
            --gt) gt="${2:-}"; shift 2 || die "--gt needs a poses file" ;;
            --vocabulary) vocab_set="${2:-}"; shift 2 || die "--vocabulary needs default or without-seq01" ;;
            -h | --help) usage; exit 0 ;;
            -*) die "unknown option '$1' (see --help)" ;;
            *) [ -z "$seq" ] || die "one SEQ_DIR only ('$seq', then '$1')"; seq="$1"; shift ;;
        esac
    done
    [ -n "$seq" ] || die "no SEQ_DIR (see --help)"
    [ -d "$seq/image_0" ] || die "$seq has no image_0/"
    [ -f "$seq/calib.txt" ] || die "$seq has no calib.txt"
    case "$sensor" in mono) align=sim3 ;; stereo) align=se3 ;; *) die "--sensor must be mono or stereo" ;; esac
    [ "$sensor" = mono ] || [ -d "$seq/image_1" ] || die "stereo needs $seq/image_1/"
    [ ${#extractors[@]} -gt 0 ] || die "--extractor orbslam3, lfast or both is required"
    [[ "$runs" =~ ^[1-9][0-9]*$ ]] || die "--runs needs a positive number"
    [ -n "$out" ] || die "--out DIR is required"
    case "$pace" in lockstep | free | realtime) ;; *) die "--pace: '$pace' is not lockstep, free or realtime" ;; esac
    case "$vocab_set" in
        default) vocab_args=() ;;
        without-seq01) vocab_args=(--without-seq01) ;;
        *) die "--vocabulary: '$vocab_set' is not default or without-seq01" ;;
    esac
    range=()
    if [ -n "$frames" ]; then
        [[ "$frames" =~ ^([0-9]+)-([0-9]+)$ ]] || die "--frames: '$frames' is not FIRST-LAST"
        range=(--first "${BASH_REMATCH[1]}" --last "${BASH_REMATCH[2]}")
    fi
    gt="${gt:-$seq/poses.txt}"
    [ -f "$gt" ] || die "no ground truth $gt (--gt POSES)"
    seq="$(cd "$seq" && pwd)"
    seq_name="$(basename "$seq")"

    # what the runs need, each cached: seconds when nothing changed
    for ext in "${extractors[@]}"; do "$here/build.sh" --variant "$ext" >&2; done
    voc="$("$here/vocabulary.sh" "${vocab_args[@]}")"
    if [ -f "$voc.info" ]; then
        voc_desc="$(head -1 "$voc.info")"
    else
        voc_desc="$(basename "$voc"), sha256 $(sha256sum "$voc" | cut -c1-12)"
    fi
    if [ -z "${LFAST_BIN:-}" ]; then
        command -v cargo > /dev/null || die "cargo is needed to build the lfast CLI (or set LFAST_BIN)"
        (cd "$root" && cargo build --release --locked --bin lfast >&2)
        LFAST_BIN="${CARGO_TARGET_DIR:-$root/target}/release/lfast"
    fi
    [ -x "$LFAST_BIN" ] || die "no lfast CLI at $LFAST_BIN"
    commit="$(git -C "$root" rev-parse --short HEAD 2> /dev/null || echo unknown)"
    git -C "$root" diff --quiet HEAD -- capi src shaders 2> /dev/null || commit="$commit+changes"

    mkdir -p "$out"
    settings="$out/settings-$seq_name-$sensor.yaml"
    python3 "$here/results.py" settings "$seq" --sensor "$sensor" > "$settings"
    frames_label="${frames:-all}"
    # one directory per case: sequence, sensor, frames, pacing (when not lockstep), extractor
    case_name="$seq_name-$sensor-$frames_label"
    [ "$pace" = lockstep ] || case_name="$case_name-$pace"

    # the extractors take turns, run by run, so that a change in the machine's
    # load falls on both
    declare -A next
    for ext in "${extractors[@]}"; do
        group="$out/$case_name-$ext"
        mkdir -p "$group"
        # numbering continues after the runs already there
        k=0
        while [ -e "$group/run$((k + 1))" ]; do k=$((k + 1)); done
        next[$ext]=$((k + 1))
    done
    for ((i = 0; i < runs; i++)); do
        for ext in "${extractors[@]}"; do
            k=${next[$ext]}
            next[$ext]=$((k + 1))
            d="$out/$case_name-$ext/run$k"
            mkdir -p "$d"
            echo "== $case_name $ext run $k" >&2
            t0=$(date +%s%N)
            status=0
            "$prefix/bin/orbslam3_kitti-$ext" "$voc" "$settings" "$seq" "$d" --sensor "$sensor" \
                --pace "$pace" "${range[@]}" > "$d/log.txt" 2>&1 || status=$?
            wall_ms=$((($(date +%s%N) - t0) / 1000000))
            [ "$status" = 0 ] || echo "run.sh: the driver exited with $status (see $d/log.txt)" >&2
            python3 "$here/results.py" score "$d" --gt "$gt" --lfast "$LFAST_BIN" --align "$align" \
                --meta "sequence=$seq_name" --meta "frames_range=$frames_label" --meta "extractor=$ext" \
                --meta "run=$k" --meta "vocabulary=$voc_desc" --meta "lfast_commit=$commit" \
                --meta "driver_status=$status" --meta "wall_ms=$wall_ms"
            python3 "$here/results.py" brief "$d" >&2
        done
    done

    python3 "$here/results.py" summary "$out"
}

main "$@"; exit
