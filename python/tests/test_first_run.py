"""A first run of the Python package on a headless machine prints nothing of Mesa's.

Mesa's Vulkan drivers (lavapipe among them) print ``error: XDG_RUNTIME_DIR is
invalid or not set in the environment.`` while a backend is chosen when the
variable is unset. ``import lfast`` points it at a private temporary directory
first (python/lfast/__init__.py), as the ``lfast`` binary does (tests/first_run.rs).
"""

from __future__ import annotations

import os
import subprocess
import sys

from conftest import IMAGES

SCRIPT = """
import os, sys, cv2, lfast
det = lfast.Detector(backend="auto")
kps, desc = det.detectAndCompute(cv2.imread(sys.argv[1], cv2.IMREAD_COLOR), None)
assert len(kps) > 0 and desc.shape == (len(kps), 32)
print(det.backend, len(kps), os.environ["XDG_RUNTIME_DIR"])
"""


def run_fresh(env_extra: dict) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k not in ("XDG_RUNTIME_DIR", "WGPU_ADAPTER_NAME", "WGPU_BACKEND")}
    env.update(env_extra)
    return subprocess.run(
        [sys.executable, "-c", SCRIPT, str(IMAGES[0])], env=env, capture_output=True, text=True, timeout=300
    )


def test_import_and_detect_print_nothing_without_xdg_runtime_dir():
    r = run_fresh({})
    assert r.returncode == 0, r.stderr
    assert r.stderr == "", f"stderr of a first run: {r.stderr!r}"
    backend, n, runtime_dir = r.stdout.split()
    assert backend == "cpu" and int(n) > 0
    assert os.path.isabs(runtime_dir) and "lfast-runtime-" in runtime_dir
    assert not os.path.exists(runtime_dir), "the private directory is removed at exit"


def test_a_valid_xdg_runtime_dir_is_left_alone(tmp_path):
    r = run_fresh({"XDG_RUNTIME_DIR": str(tmp_path)})
    assert r.returncode == 0, r.stderr
    assert r.stdout.split()[2] == str(tmp_path)
    assert r.stderr == ""
