#!/usr/bin/env bash
# Builds lfast's C ABI and installs it for C and C++ programs:
#
#   capi/install.sh [PREFIX]          (default /usr/local; run as a user who may write there)
#
# PREFIX/lib/liblfast.so.0.1.0 (+ liblfast.so.0, liblfast.so), PREFIX/lib/liblfast.a,
# PREFIX/include/lfast/{lfast.h,lfast.hpp,lfast_opencv.hpp,orbextractor.hpp},
# PREFIX/lib/cmake/lfast/ (find_package(lfast) -> lfast::lfast, lfast::lfast_static)
# PREFIX/lib/pkgconfig/lfast.pc, and ORB-SLAM3's drop-in header
# PREFIX/share/lfast/orbslam/ORBextractor.h. Needs cargo; the C++ headers need
# C++11 or later (C++17 is their target), the OpenCV ones OpenCV 4 (docs/cpp.md).
set -euo pipefail

prefix="${1:-/usr/local}"
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(dirname "$here")"
target="${CARGO_TARGET_DIR:-$root/target}"
version="$(sed -n 's/^version = "\(.*\)"$/\1/p' "$here/Cargo.toml" | head -1)"
minor="$(echo "$version" | cut -d. -f2)"
# What Rust's standard library needs from the system when liblfast.a is linked
# (`cargo rustc -p lfast-capi --crate-type staticlib -- --print native-static-libs`).
native_libs="gcc_s util rt pthread m dl c"

cargo build --release --locked -p lfast-capi --manifest-path "$root/Cargo.toml"

lib="$prefix/lib"
install -d "$lib/cmake/lfast" "$lib/pkgconfig" "$prefix/include/lfast"
# the libraries without their debug sections (the build keeps them in target/)
strip_copy() {
    if command -v objcopy > /dev/null; then objcopy --strip-debug "$1" "$2"; else cp "$1" "$2"; fi
}
strip_copy "$target/release/liblfast_capi.so" "$lib/liblfast.so.$version"
chmod 755 "$lib/liblfast.so.$version"
ln -sfn "liblfast.so.$version" "$lib/liblfast.so.0"
ln -sfn "liblfast.so.0" "$lib/liblfast.so"
strip_copy "$target/release/liblfast_capi.a" "$lib/liblfast.a"
chmod 644 "$lib/liblfast.a"
install -m 644 "$here"/include/lfast/*.h "$here"/include/lfast/*.hpp "$prefix/include/lfast/"
# ORB-SLAM3's drop-in include/ORBextractor.h (docs/orbslam.md)
install -d "$prefix/share/lfast/orbslam"
install -m 644 "$here/orbslam/ORBextractor.h" "$prefix/share/lfast/orbslam/"

flags=""
for l in $native_libs; do flags="$flags -l$l"; done
sed "s|@NATIVE_STATIC_LIBS@|${native_libs// /;}|" "$here/cmake/lfastConfig.cmake" > "$lib/cmake/lfast/lfastConfig.cmake"
sed "s|@VERSION@|$version|; s|@MINOR@|$minor|g" "$here/cmake/lfastConfigVersion.cmake" \
    > "$lib/cmake/lfast/lfastConfigVersion.cmake"
sed "s|@PREFIX@|$prefix|; s|@VERSION@|$version|; s|@NATIVE_STATIC_LIBS_FLAGS@|${flags# }|" "$here/cmake/lfast.pc" \
    > "$lib/pkgconfig/lfast.pc"
# the dynamic loader's cache, when installing system-wide
if [ "$(id -u)" = 0 ] && command -v ldconfig > /dev/null; then ldconfig; fi
echo "installed lfast $version under $prefix (CMake: find_package(lfast); pkg-config: lfast)"
