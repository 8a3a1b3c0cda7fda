#!/usr/bin/env bash
# Downloads the test data that tests, benchmarks and scripts read (the layout of
# ../shared/data) from its public origins into DIR, and checks every file against
# scripts/test_data/manifest.tsv (size and sha256; a PNG also by its pixels)
# before moving it into place. A file that does not match is refused, deleted and
# named, and the script exits non-zero after doing what it can. Files already
# present and correct are not downloaded again.
#
#   scripts/fetch_test_data.sh DIR                 # all datasets with a public origin
#   scripts/fetch_test_data.sh DIR --only cc0,kitti-seq01
#   scripts/fetch_test_data.sh --check DIR         # verify DIR; no network
#   scripts/fetch_test_data.sh --list              # datasets, origins, licences
#
# Then: export LFAST_TEST_DATA=DIR (printed at the end).
# Options: --mirror URL (or LFAST_DATA_MIRROR=URL) replaces the scheme and host of
# every origin URL; --archives DIR reads archives already downloaded
# (data_odometry_gray.zip, graf.tar.gz, ...); --manifest FILE, --sources FILE.
# Origins, licences and what is derived: docs/development.md, "Test data".
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
if ! command -v python3 > /dev/null; then
    echo "error: python3 (3.8 or later) is needed to run $0" >&2
    exit 2
fi
exec python3 "$here/test_data/fetch.py" "$@"
