"""Shared fixtures of the Python package's tests (run by .ci/run).

The reference is the `lfast` command-line tool of the same checkout: its JSON
output for the bundled images must equal the package's results bit for bit.
"""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import sys

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "scripts"))
from lfast_data import data_dir, in_ci, note_skip  # noqa: E402  (scripts/ is on the path now)

DATA = REPO / "tests" / "data"
#: The real data: $LFAST_TEST_DATA, else ../shared/data (scripts/lfast_data.py).
SHARED = data_dir()
#: The bundled images (tests/data/regress holds deliberately broken files).
IMAGES = sorted(DATA.glob("*.png"))
KITTI = SHARED / "kitti" / "seq01_000000-000050" / "image_0"
IN_CI = in_ci()


def lfast_bin() -> Path:
    """The CLI of this checkout (built by `cargo build --release` when missing)."""
    env = os.environ.get("LFAST_BIN")
    if env:
        return Path(env)
    target = Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target"))
    exe = target / "release" / "lfast"
    if not exe.exists():
        subprocess.run(
            ["cargo", "build", "--release", "--locked", "--bin", "lfast"], cwd=REPO, check=True
        )
    return exe


@pytest.fixture(scope="package")
def cli() -> Path:
    return lfast_bin()


@pytest.fixture(scope="package")
def cli_json(cli: Path, tmp_path_factory: pytest.TempPathFactory) -> dict:
    """`lfast detect tests/data/*.png --backend cpu` as {image name: parsed JSON}."""
    out = tmp_path_factory.mktemp("cli")
    subprocess.run(
        [str(cli), "detect", *map(str, IMAGES), "--out", str(out), "--backend", "cpu", "--quiet"],
        check=True,
    )
    return {p.name: json.loads((out / (p.stem + ".json")).read_text()) for p in IMAGES}


def cli_arrays(features: dict) -> tuple[np.ndarray, np.ndarray]:
    """The CLI's JSON as (N x 7 float32 keypoints, N x 32 uint8 descriptors)."""
    kps = np.array(
        [
            [k["pt"][0], k["pt"][1], k["size"], k["angle"], k["response"], k["octave"], k["class_id"]]
            for k in features["keypoints"]
        ],
        dtype=np.float32,
    ).reshape(-1, 7)
    desc = np.array([list(bytes.fromhex(d)) for d in features["descriptors"]], dtype=np.uint8).reshape(-1, 32)
    return kps, desc


def kitti_frames(n: int) -> list[Path]:
    """The first n KITTI frames of the test data (CI provides them)."""
    frames = sorted(KITTI.glob("*.png"))[:n]
    if len(frames) < n:
        if IN_CI:
            pytest.fail(f"{KITTI}: fewer than {n} frames (CI must provide the test data)")
        note_skip(f"pytest {os.environ.get('PYTEST_CURRENT_TEST', '').split(' ')[0]}", KITTI)
        pytest.skip(f"{KITTI} not present (LFAST_TEST_DATA or ../shared/data)")
    return frames
