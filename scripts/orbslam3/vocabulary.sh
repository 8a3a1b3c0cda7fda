#!/usr/bin/env bash
# Prints the path of the DBoW2 vocabulary for the ORB-SLAM3 runs, training it
# once (cached under the build prefix) when ORBVOC does not name one.
#
#   scripts/orbslam3/vocabulary.sh [--without-seq01]
#
# ORBVOC=PATH       use this vocabulary (e.g. ORB-SLAM3's Vocabulary/ORBvoc.txt)
# LFAST_TEST_DATA   the shared data directory (default ../shared/data beside
#                   the checkout)
# ORBSLAM3_PREFIX   as build.sh (default ~/.cache/lfast/orbslam3)
#
# ORBvoc.txt (ORB-SLAM3's, trained on a large image set) is an 140 MB
# download that is not reachable everywhere; the one trained here comes from
# images that are not test sequences: data/standard (+cc0), the homography
# scenes, and KITTI seq01's 51 frames (left out with --without-seq01, for
# runs that test seq01). Descriptors: cv::ORB::create(1000), which lfast's
# descriptor = "opencv" reproduces bit for bit, so the vocabulary serves both
# extractors. DBoW2: k = 10, L = 5, TF-IDF, L1 (see docs/orbslam.md for why).
# Beside a trained vocabulary, PATH.info says how it was made; its first line
# is what results tables quote.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
prefix="${ORBSLAM3_PREFIX:-$HOME/.cache/lfast/orbslam3}"
data="${LFAST_TEST_DATA:-$root/../shared/data}"
K=10
L=5
NFEATURES=1000

die() { echo "vocabulary.sh: error: $*" >&2; exit 1; }

with_seq01=1
for arg in "$@"; do
    case "$arg" in
        --without-seq01) with_seq01=0 ;;
        -h | --help) sed -n '2,/^set -euo/p' "${BASH_SOURCE[0]}" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
        *) die "unknown argument '$arg'" ;;
    esac
done

if [ -n "${ORBVOC:-}" ]; then
    [ -f "$ORBVOC" ] || die "ORBVOC=$ORBVOC is not a file"
    echo "$(cd "$(dirname "$ORBVOC")" && pwd)/$(basename "$ORBVOC")"
    exit 0
fi

trainer="$prefix/bin/train_vocabulary"
[ -x "$trainer" ] || die "$trainer is missing: run scripts/orbslam3/build.sh first"
[ -d "$data" ] || die "no data directory $data (set LFAST_TEST_DATA)"

list="$(mktemp)"
trap 'rm -f "$list"' EXIT
{
    ls "$data"/standard/*.png "$data"/standard/cc0/*.png
    ls "$data"/homography/*/img*.png
    if [ "$with_seq01" = 1 ]; then ls "$data"/kitti/seq01_000000-000050/image_0/*.png; fi
} > "$list" 2> /dev/null || true
n="$(wc -l < "$list")"
[ "$n" -gt 0 ] || die "no training images under $data"
set_name="std+cc0+homography"
if [ "$with_seq01" = 1 ]; then set_name="$set_name+kitti01"; fi
# the cache key: the images' contents and the recipe
key="$( (xargs sha256sum < "$list" | cut -c1-64; echo "$K $L $NFEATURES"; sha256sum "$trainer" | cut -c1-64) |
    sha256sum | cut -c1-12)"
voc="$prefix/vocabulary/ORBvoc-$set_name-k${K}L${L}-$key.txt"
if [ ! -s "$voc" ] || [ ! -f "$voc.info" ]; then
    mkdir -p "$prefix/vocabulary"
    echo "== training the vocabulary on $n images ($set_name)" >&2
    report="$("$trainer" "$list" "$voc.tmp" "$K" "$L" "$NFEATURES")" || die "training failed"
    report="${report% -> *}"
    mv "$voc.tmp" "$voc"
    sha="$(sha256sum "$voc" | cut -c1-12)"
    {
        echo "trained: $set_name, $n images, cv::ORB::create($NFEATURES), DBoW2 k=$K L=$L TF-IDF L1, sha256 $sha"
        echo "$report"
        cat "$list"
    } > "$voc.info"
fi
echo "$voc"
