"""A first run of the Python package on a headless machine prints nothing of Mesa's.

With the variable unset, libwayland prints ``error: XDG_RUNTIME_DIR is invalid or
not set in the environment.`` when Mesa's device selection layer connects to a
Wayland display, which it does for a Vulkan instance that enables the Wayland
surface extension. lfast's instance leaves the window-system extensions out
(src/gpu/context.rs), so nothing is printed and the environment is left as it
is, as for the ``lfast`` binary (tests/first_run.rs).
"""

from __future__ import annotations

import os
import subprocess
import sys

from conftest import IMAGES

SCRIPT = """
import os, sys, cv2, lfast
det = lfast.Detector(backend=sys.argv[2])
kps, desc = det.detectAndCompute(cv2.imread(sys.argv[1], cv2.IMREAD_COLOR), None)
assert len(kps) > 0 and desc.shape == (len(kps), 32)
print(det.backend, len(kps), os.environ.get("XDG_RUNTIME_DIR", "-"))
"""


def run_fresh(env_extra: dict, backend: str = "auto") -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k not in ("XDG_RUNTIME_DIR", "WGPU_ADAPTER_NAME", "WGPU_BACKEND")}
    env.update(env_extra)
    return subprocess.run(
        [sys.executable, "-c", SCRIPT, str(IMAGES[0]), backend], env=env, capture_output=True, text=True, timeout=300
    )


def test_import_and_detect_print_nothing_without_xdg_runtime_dir():
    r = run_fresh({})
    assert r.returncode == 0, r.stderr
    assert r.stderr == "", f"stderr of a first run: {r.stderr!r}"
    backend, n, runtime_dir = r.stdout.split()
    assert backend == "cpu" and int(n) > 0
    assert runtime_dir == "-", "the process environment is not changed"


def test_lavapipe_by_name_prints_nothing_without_xdg_runtime_dir():
    # the GPU path opened on Mesa's software adapter, as CI does (REQUIRE_GPU=1)
    if os.environ.get("REQUIRE_GPU") != "1":
        import pytest

        pytest.skip("REQUIRE_GPU=1 is not set (CI sets it and installs lavapipe)")
    r = run_fresh({"WGPU_ADAPTER_NAME": "llvmpipe"}, backend="gpu")
    assert r.returncode == 0, r.stderr
    assert r.stderr == "", f"stderr of a first run on lavapipe: {r.stderr!r}"
    backend, n, runtime_dir = r.stdout.split()
    assert backend.startswith("gpu") and int(n) > 0 and runtime_dir == "-", r.stdout


def test_a_valid_xdg_runtime_dir_is_left_alone(tmp_path):
    r = run_fresh({"XDG_RUNTIME_DIR": str(tmp_path)})
    assert r.returncode == 0, r.stderr
    assert r.stdout.split()[2] == str(tmp_path)
    assert r.stderr == ""
