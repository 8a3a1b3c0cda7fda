#!/usr/bin/env bash
# Builds ORB-SLAM3 v1.0 headless in two variants for the extractor comparison
# of docs/orbslam.md: "orbslam3" (its own ORBextractor) and "lfast"
# (lfast::ORBextractor through the three edits of docs/orbslam.md).
#
#   scripts/orbslam3/build.sh [--variant orbslam3|lfast|both] [--jobs N]
#
# Everything is built under a prefix and cached there; a second call with
# nothing changed returns in seconds. When lfast's sources change (capi/,
# src/, shaders/, Cargo.*), lfast is reinstalled and only the lfast variant's
# files that include its header are recompiled.
#
# Environment:
#   ORBSLAM3_PREFIX  build and cache prefix (default ~/.cache/lfast/orbslam3)
#   ORB_SLAM3_SRC    a local git repository (bare or not) holding commit
#                    $ORB_SLAM3_COMMIT, or a plain source tree of it;
#                    default: a clone of github.com/geoeo/ORB_SLAM3_V1.0
#   PANGOLIN_SRC     the same for Pangolin v0.9.5 (github.com/stevenlovegrove/Pangolin)
#   JOBS             parallel compile jobs (default 2: Optimizer.cc alone
#                    needs 3.6 GB and > 5 min)
#   CARGO_TARGET_DIR cargo's target directory for lfast (as capi/install.sh)
#   ORBSLAM3_NO_APT=1  only check the Debian packages, never install them
#
# Needs: Debian 12 or similar (the apt packages below are installed when
# missing, as root or through sudo), cargo (rustup; lfast needs Rust >= 1.90),
# and GitHub unless ORB_SLAM3_SRC and PANGOLIN_SRC are given. The first build
# takes ~20-25 min of wall time at -j2; the second variant reuses, through
# ccache, every object file that does not include ORBextractor.h.
#
# Result (PREFIX/bin): orbslam3_kitti-orbslam3, orbslam3_kitti-lfast (the
# KITTI driver of kitti_driver.cc against each variant), train_vocabulary,
# and with both variants bench_extractor (the two extractors outside SLAM).
#
# ORB-SLAM3 is GPLv3: these builds, lfast linked in or not, are GPLv3 programs.
# The patches applied are in scripts/orbslam3/patches/, one file per change,
# each with its first line saying why.
set -euo pipefail

ORB_SLAM3_COMMIT=4452a3c4ab75b1cde34e5505a36ec3f9edcdc4c4 # ORB-SLAM3 v1.0
ORB_SLAM3_URL=https://github.com/geoeo/ORB_SLAM3_V1.0.git # same commit, small repository
PANGOLIN_COMMIT=2e86fc08a2eb071ccc685c081d7e85db936ecb24  # Pangolin v0.9.5
PANGOLIN_URL=https://github.com/stevenlovegrove/Pangolin.git
# What the build reads from ORB-SLAM3 (the vocabulary, examples and the
# large IMU files are not needed, and mirrors may lack the large ones).
ORB_SLAM3_PATHS=(CMakeLists.txt LICENSE include src Thirdparty/DBoW2 Thirdparty/g2o Thirdparty/Sophus)
APT_PACKAGES=(git ca-certificates cmake ninja-build g++ make pkg-config ccache python3
    libopencv-dev libeigen3-dev libboost-serialization-dev libssl-dev
    libepoxy-dev libgl1-mesa-dev libegl1-mesa-dev)

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
prefix="${ORBSLAM3_PREFIX:-$HOME/.cache/lfast/orbslam3}"
jobs="${JOBS:-2}"
variants=(orbslam3 lfast)

die() { echo "build.sh: error: $*" >&2; exit 1; }
log() { echo "== $*" >&2; }
usage() { sed -n '2,/^set -euo/p' "${BASH_SOURCE[0]}" | sed '$d; s/^# \{0,1\}//'; }

while [ $# -gt 0 ]; do
    case "$1" in
        --variant)
            [ $# -ge 2 ] || die "--variant needs orbslam3, lfast or both"
            case "$2" in
                orbslam3 | lfast) variants=("$2") ;;
                both) variants=(orbslam3 lfast) ;;
                *) die "--variant: '$2' is not orbslam3, lfast or both" ;;
            esac
            shift 2 ;;
        --jobs)
            [[ "${2:-}" =~ ^[1-9][0-9]*$ ]] || die "--jobs needs a positive integer"
            jobs="$2"; shift 2 ;;
        -h | --help) usage; exit 0 ;;
        *) die "unknown argument '$1' (see --help)" ;;
    esac
done

mkdir -p "$prefix"/{src,build,bin,stamps}
prefix="$(cd "$prefix" && pwd)"

# ---------------------------------------------------------------- packages
ensure_packages() {
    if ! command -v dpkg-query > /dev/null; then
        log "no dpkg: not checking packages; needed: ${APT_PACKAGES[*]} (or their equivalents)"
        return
    fi
    local missing=() p
    for p in "${APT_PACKAGES[@]}"; do
        dpkg-query -W -f='${Status}' "$p" 2> /dev/null | grep -q "install ok installed" || missing+=("$p")
    done
    [ ${#missing[@]} -eq 0 ] && return
    [ "${ORBSLAM3_NO_APT:-0}" = 1 ] && die "missing Debian packages: ${missing[*]}"
    local sudo=()
    if [ "$(id -u)" != 0 ]; then
        command -v sudo > /dev/null || die "missing Debian packages (${missing[*]}); install them as root"
        sudo=(sudo)
    fi
    log "installing ${missing[*]}"
    "${sudo[@]}" apt-get update -q
    DEBIAN_FRONTEND=noninteractive "${sudo[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
}

# ---------------------------------------------------------------- sources
# repo_for NAME URL SRC: a git directory holding the pinned commit, or the
# plain source tree SRC (printed as "tree:DIR").
repo_for() {
    local name="$1" url="$2" src="$3" commit="$4"
    if [ -n "$src" ]; then
        [ -d "$src" ] || die "$name source '$src' is not a directory"
        if git -C "$src" rev-parse --git-dir > /dev/null 2>&1; then
            local gd
            gd="$(cd "$src" && cd "$(git rev-parse --git-dir)" && pwd)"
            git --git-dir="$gd" cat-file -e "$commit^{commit}" 2> /dev/null ||
                die "$name repository $src does not hold commit $commit"
            echo "$gd"
        else
            echo "tree:$(cd "$src" && pwd)"
        fi
        return
    fi
    local gd="$prefix/src/$name.git"
    if [ ! -d "$gd" ]; then
        log "cloning $url"
        # blobs over 4 MiB (vocabulary, IMU logs) are not needed: leave them out
        git clone -q --bare --filter=blob:limit=4m "$url" "$gd.tmp" || die "could not clone $url (set ${name^^}_SRC to a local copy)"
        mv "$gd.tmp" "$gd"
    fi
    if ! git --git-dir="$gd" cat-file -e "$commit^{commit}" 2> /dev/null; then
        git --git-dir="$gd" fetch -q origin || die "could not fetch $url"
        git --git-dir="$gd" cat-file -e "$commit^{commit}" 2> /dev/null || die "$url has no commit $commit"
    fi
    echo "$gd"
}

# extract REPO COMMIT DEST PATH...: the files under PATHs at COMMIT into DEST.
# Reads only their blobs (through a temporary index), so a repository that
# lacks other, large blobs still serves; a needed blob that is missing is an
# error naming it.
extract() {
    local repo="$1" commit="$2" dest="$3"
    shift 3
    mkdir -p "$dest"
    if [[ "$repo" == tree:* ]]; then
        log "copying ${repo#tree:} (a plain tree: commit $commit not checked)"
        (cd "${repo#tree:}" && tar -cf - "$@") | tar -xf - -C "$dest"
        return
    fi
    local missing
    missing="$(git --git-dir="$repo" ls-tree -r "$commit" -- "$@" | awk '$2 == "blob" {print $3}' |
        git --git-dir="$repo" cat-file --batch-check | awk '$2 == "missing" {print $1}')"
    [ -z "$missing" ] || die "$repo lacks blobs needed at $commit: $(echo "$missing" | head -3 | tr '\n' ' ')"
    local idx
    idx="$(mktemp)"
    rm -f "$idx"
    GIT_INDEX_FILE="$idx" git --git-dir="$repo" read-tree "$commit"
    GIT_INDEX_FILE="$idx" git --git-dir="$repo" --work-tree="$dest" ls-files -z -- "$@" |
        GIT_INDEX_FILE="$idx" xargs -0 git --git-dir="$repo" --work-tree="$dest" checkout-index --prefix="$dest/" --
    rm -f "$idx"
}

# a short hash of the files' contents and names (not their directory)
hash_files() { sha256sum "$@" | sed 's|  .*/|  |' | sha256sum | cut -c1-16; }
stamp_ok() { [ -f "$prefix/stamps/$1" ] && [ "$(cat "$prefix/stamps/$1")" = "$2" ]; }
stamp_set() { echo "$2" > "$prefix/stamps/$1"; }

# ---------------------------------------------------------------- ccache
# One cache for both variants; paths are rewritten relative to the build
# directory (base_dir), and both variants have the same layout, so a source
# that does not include ORBextractor.h compiles once.
export CCACHE_DIR="$prefix/ccache"
export CCACHE_BASEDIR="$prefix/build"
export CCACHE_NOHASHDIR=1
export CCACHE_MAXSIZE="${CCACHE_MAXSIZE:-4G}"
launcher=(-DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)

# ---------------------------------------------------------------- Pangolin
build_pangolin() {
    local flags=(-DCMAKE_BUILD_TYPE=Release -DBUILD_TOOLS=OFF -DBUILD_EXAMPLES=OFF -DBUILD_TESTS=OFF
        -DBUILD_PANGOLIN_PYTHON=OFF -DBUILD_PANGOLIN_FFMPEG=OFF -DBUILD_PANGOLIN_LIBOPENEXR=OFF
        -DBUILD_PANGOLIN_LIBDC1394=OFF -DBUILD_PANGOLIN_LIBTIFF=OFF -DBUILD_PANGOLIN_LIBRAW=OFF
        -DBUILD_PANGOLIN_LIBJPEG=OFF -DBUILD_PANGOLIN_LIBPNG=OFF -DBUILD_PANGOLIN_LZ4=OFF
        -DBUILD_PANGOLIN_ZSTD=OFF -DBUILD_PANGOLIN_V4L=OFF -DBUILD_PANGOLIN_REALSENSE=OFF
        -DBUILD_PANGOLIN_REALSENSE2=OFF -DBUILD_PANGOLIN_OPENNI=OFF -DBUILD_PANGOLIN_OPENNI2=OFF
        -DBUILD_PANGOLIN_LIBUVC=OFF -DBUILD_PANGOLIN_DEPTHSENSE=OFF -DBUILD_PANGOLIN_PLEORA=OFF
        -DBUILD_PANGOLIN_TELICAM=OFF
        # headless: offscreen EGL only, never X11 (Wayland needs packages not installed here)
        -DCMAKE_DISABLE_FIND_PACKAGE_X11=ON)
    local key
    key="$PANGOLIN_COMMIT $(echo "${flags[*]}" | sha256sum | cut -c1-16)"
    if stamp_ok pangolin "$key" && [ -f "$prefix/pangolin/lib/cmake/Pangolin/PangolinConfig.cmake" ]; then
        return
    fi
    log "Pangolin $PANGOLIN_COMMIT"
    local repo src="$prefix/build/pangolin-src"
    repo="$(repo_for pangolin "$PANGOLIN_URL" "${PANGOLIN_SRC:-}" "$PANGOLIN_COMMIT")"
    rm -rf "$src" "$prefix/build/pangolin" "$prefix/pangolin"
    extract "$repo" "$PANGOLIN_COMMIT" "$src" .
    cmake -S "$src" -B "$prefix/build/pangolin" -G Ninja "${flags[@]}" "${launcher[@]}" \
        -DCMAKE_INSTALL_PREFIX="$prefix/pangolin" > "$prefix/build/pangolin.cmake.log" 2>&1 ||
        die "Pangolin's cmake failed: $prefix/build/pangolin.cmake.log"
    ninja -C "$prefix/build/pangolin" -j "$jobs" install > "$prefix/build/pangolin.ninja.log" 2>&1 ||
        die "Pangolin's build failed: $prefix/build/pangolin.ninja.log"
    stamp_set pangolin "$key"
}

# ---------------------------------------------------------------- lfast
lfast_hash() {
    (cd "$root" && git ls-files -z -co --exclude-standard -- capi src shaders data/orb_bit_pattern_31.txt \
        Cargo.toml Cargo.lock build.rs ':!capi/tests' | sort -z | xargs -0 sha256sum) | sha256sum | cut -c1-16
}

install_lfast() {
    local key
    key="$(lfast_hash)"
    if stamp_ok lfast "$key" && [ -f "$prefix/lfast/lib/cmake/lfast/lfastConfig.cmake" ]; then
        return
    fi
    command -v cargo > /dev/null || die "cargo is needed to build lfast (https://rustup.rs)"
    log "lfast (sources $key) into $prefix/lfast"
    "$root/capi/install.sh" "$prefix/lfast" >&2
    stamp_set lfast "$key"
}

# ---------------------------------------------------------------- ORB-SLAM3
# docs/orbslam.md's three edits, on a patched tree.
lfast_edits() {
    local t="$1"
    python3 - "$t/CMakeLists.txt" << 'EOF'
import sys
p = sys.argv[1]
s = open(p).read()
def once(old, new):
    global s
    if s.count(old) != 1:
        sys.exit("ORB-SLAM3's CMakeLists.txt: expected one '%s'" % old.strip())
    s = s.replace(old, new)
once("find_package(Pangolin REQUIRED)\n", "find_package(Pangolin REQUIRED)\nfind_package(lfast REQUIRED)\n")
once("src/ORBextractor.cc\n", "")
once("-lboost_serialization\n", "-lboost_serialization\nlfast::lfast\n")
open(p, "w").write(s)
EOF
}

# The variant's source tree: the pinned commit, the patches, and for lfast
# the edits; rebuilt only when one of them changes.
prepare_tree() {
    local v="$1" t="$prefix/build/$1/ORB_SLAM3"
    local key
    key="$ORB_SLAM3_COMMIT $(hash_files "$here"/patches/*.patch)"
    [ "$v" = lfast ] && key="$key $(declare -f lfast_edits | sha256sum | cut -c1-16)"
    if stamp_ok "tree-$v" "$key" && [ -f "$t/CMakeLists.txt" ]; then
        return
    fi
    log "ORB-SLAM3 source tree for $v"
    local repo
    repo="$(repo_for orb_slam3 "$ORB_SLAM3_URL" "${ORB_SLAM3_SRC:-}" "$ORB_SLAM3_COMMIT")"
    rm -rf "$prefix/build/$v"
    extract "$repo" "$ORB_SLAM3_COMMIT" "$t" "${ORB_SLAM3_PATHS[@]}"
    local p
    for p in "$here"/patches/*.patch; do
        patch -s -p1 -d "$t" --no-backup-if-mismatch < "$p" || die "patch $(basename "$p") does not apply"
    done
    [ "$v" = lfast ] && lfast_edits "$t"
    stamp_set "tree-$v" "$key"
}

build_variant() {
    local v="$1" t="$prefix/build/$1/ORB_SLAM3"
    local key deps=()
    key="$(cat "$prefix/stamps/tree-$v") $(cat "$prefix/stamps/pangolin") $(hash_files "$here"/CMakeLists.txt "$here"/*.cc)"
    if [ "$v" = lfast ]; then
        key="$key $(cat "$prefix/stamps/lfast")"
        deps=(-Dlfast_DIR="$prefix/lfast/lib/cmake/lfast")
        # edit 2 of docs/orbslam.md: lfast's drop-in header (copied only when
        # it changed, so that ninja recompiles nothing otherwise)
        cmp -s "$prefix/lfast/share/lfast/orbslam/ORBextractor.h" "$t/include/ORBextractor.h" ||
            cp "$prefix/lfast/share/lfast/orbslam/ORBextractor.h" "$t/include/ORBextractor.h"
    fi
    if stamp_ok "build-$v" "$key" && [ -x "$prefix/bin/orbslam3_kitti-$v" ]; then
        log "$v: up to date"
        return
    fi
    log "ORB-SLAM3 ($v extractor), -j$jobs"
    local logs="$prefix/build/$v"
    # DBoW2 has its own CMake project (g2o is a subdirectory of ORB-SLAM3's);
    # Sophus is header-only and not built (its tests do not build with gcc 12).
    cmake -S "$t/Thirdparty/DBoW2" -B "$t/Thirdparty/DBoW2/build" -G Ninja -DCMAKE_BUILD_TYPE=Release \
        "${launcher[@]}" > "$logs/dbow2.log" 2>&1 || die "DBoW2's cmake failed: $logs/dbow2.log"
    ninja -C "$t/Thirdparty/DBoW2/build" -j "$jobs" >> "$logs/dbow2.log" 2>&1 || die "DBoW2's build failed: $logs/dbow2.log"
    cmake -S "$t" -B "$t/build" -G Ninja -DCMAKE_BUILD_TYPE=Release "${launcher[@]}" \
        -DPangolin_DIR="$prefix/pangolin/lib/cmake/Pangolin" "${deps[@]}" > "$logs/cmake.log" 2>&1 ||
        die "ORB-SLAM3's cmake failed: $logs/cmake.log"
    ninja -C "$t/build" -j "$jobs" > "$logs/ninja.log" 2>&1 || die "ORB-SLAM3's build failed: $logs/ninja.log"
    # the driver (and, once, the vocabulary trainer) against this build
    for_source "$prefix/build/$v/driver" "$here"
    cmake -S "$here" -B "$prefix/build/$v/driver" -G Ninja -DCMAKE_BUILD_TYPE=Release "${launcher[@]}" \
        -DORB_SLAM3_DIR="$t" -DPangolin_DIR="$prefix/pangolin/lib/cmake/Pangolin" \
        -DVARIANT="$v" "${deps[@]}" > "$logs/driver.log" 2>&1 || die "the driver's cmake failed: $logs/driver.log"
    ninja -C "$prefix/build/$v/driver" -j "$jobs" >> "$logs/driver.log" 2>&1 || die "the driver's build failed: $logs/driver.log"
    install -m 755 "$prefix/build/$v/driver/orbslam3_kitti" "$prefix/bin/orbslam3_kitti-$v"
    if [ "$v" = orbslam3 ]; then
        install -m 755 "$prefix/build/$v/driver/train_vocabulary" "$prefix/bin/train_vocabulary"
    fi
    stamp_set "build-$v" "$key"
}

# for_source DIR SRC: DIR, emptied first when it is a CMake build of another
# source folder (a moved checkout or a second clone; cmake refuses those)
for_source() {
    local d="$1" src="$2"
    if [ -f "$d/CMakeCache.txt" ] && ! grep -qxF "CMAKE_HOME_DIRECTORY:INTERNAL=$src" "$d/CMakeCache.txt"; then
        rm -rf "$d"
    fi
    mkdir -p "$d"
}

# bench_extractor (bench_extractor.cpp): ORB-SLAM3's own ORBextractor,
# compiled from the orbslam3 tree, against the installed lfast's, timed
# outside SLAM on the same frames.
build_bench() {
    local t="$prefix/build/orbslam3/ORB_SLAM3" d="$prefix/build/bench" key
    key="$(cat "$prefix/stamps/tree-orbslam3") $(cat "$prefix/stamps/lfast") $(hash_files "$here"/CMakeLists.txt "$here"/bench_extractor.cpp)"
    if stamp_ok bench "$key" && [ -x "$prefix/bin/bench_extractor" ]; then
        return
    fi
    log "bench_extractor"
    for_source "$d" "$here"
    cmake -S "$here" -B "$d" -G Ninja -DCMAKE_BUILD_TYPE=Release "${launcher[@]}" -DBENCH_EXTRACTOR=ON \
        -DORB_SLAM3_DIR="$t" -Dlfast_DIR="$prefix/lfast/lib/cmake/lfast" > "$d/cmake.log" 2>&1 ||
        die "bench_extractor's cmake failed: $d/cmake.log"
    ninja -C "$d" -j "$jobs" > "$d/ninja.log" 2>&1 || die "bench_extractor's build failed: $d/ninja.log"
    install -m 755 "$d/bench_extractor" "$prefix/bin/bench_extractor"
    stamp_set bench "$key"
}

# The whole run sits in a function, read before it starts: editing this file
# while it builds does not derail it.
main() {
    start=$(date +%s)
    ensure_packages
    build_pangolin
    for v in "${variants[@]}"; do
        [ "$v" = lfast ] && install_lfast
        prepare_tree "$v"
        build_variant "$v"
    done
    [ "${#variants[@]}" = 2 ] && build_bench
    log "done in $(($(date +%s) - start)) s; ccache: $(ccache -s 2> /dev/null | grep -iE '^ *(hits|cache hit)' | head -1 | tr -s ' ' || true)"
    for v in "${variants[@]}"; do echo "$prefix/bin/orbslam3_kitti-$v"; done
}

main "$@"; exit
