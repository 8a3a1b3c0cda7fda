"""Where the real test data lives, for the scripts and the Python tests.

The data of ../shared/README.md (KITTI frames, the paper's standard images, the
Oxford homography scenes) is never committed. It is read from the folder named
by ``LFAST_TEST_DATA``, else from ``../shared/data`` beside the checkout;
``scripts/fetch_test_data.sh DIR`` downloads it into DIR. A check that finds
its data missing skips with :func:`note_skip`, which also appends a line to the
file named by ``LFAST_SKIP_LOG`` when set (``.ci/run`` counts them), except in
CI (``CI`` set), where missing data is an error.
"""

from __future__ import annotations

import os
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def data_dir() -> Path:
    """``$LFAST_TEST_DATA``, else ``../shared/data`` beside the checkout."""
    env = os.environ.get("LFAST_TEST_DATA", "")
    return Path(env) if env else ROOT.parent / "shared" / "data"


def in_ci() -> bool:
    """Whether ``CI`` is set, as CI machines set it: missing data is then an error."""
    return os.environ.get("CI", "").lower() not in ("", "0", "false", "no")


def note_skip(what: str, missing: Path) -> None:
    """Says that ``what`` is skipped because ``missing`` is absent, and logs it."""
    line = f"{what}: {missing} not found"
    print(f"skipping {line} (LFAST_TEST_DATA or ../shared/data; scripts/fetch_test_data.sh DIR gets it)")
    log = os.environ.get("LFAST_SKIP_LOG")
    if log:
        with open(log, "a", encoding="utf-8") as f:
            f.write(line + "\n")
