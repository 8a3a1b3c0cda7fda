"""docs/scale-out.md: the Dask example on a local cluster of 2 workers writes
the same files, byte for byte, as `lfast detect` on the same folder."""

from __future__ import annotations

import importlib.util
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from conftest import IMAGES, REPO, kitti_frames

EXAMPLE = REPO / "python" / "examples" / "dask_detect.py"
DOC = REPO / "docs" / "scale-out.md"
FORMATS = ["json", "csv", "npy", "yaml"]


def load_example():
    spec = importlib.util.spec_from_file_location("dask_detect", EXAMPLE)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_the_page_shows_the_tested_script():
    blocks = re.findall(r"```python\n(.*?)```", DOC.read_text(), re.S)
    assert EXAMPLE.read_text() in blocks


def tree(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def test_dask_local_cluster_equals_cli(cli, tmp_path, monkeypatch):
    distributed = pytest.importorskip("dask.distributed")
    frames = tmp_path / "frames"
    (frames / "kitti").mkdir(parents=True)
    for p in IMAGES:
        shutil.copy(p, frames / p.name)
    for p in kitti_frames(4):
        shutil.copy(p, frames / "kitti" / p.name)
    # the example imports `lfast` in the workers: run them from the test's directory
    monkeypatch.chdir(tmp_path)
    mod = load_example()
    jobs = mod.list_frames("frames")
    assert len(jobs) == len(IMAGES) + 4
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        assert len(client.scheduler_info()["workers"]) == 2
        n = mod.run("frames", "out_dask", client, FORMATS, "cpu", [("n_features", 1500)])
        # every worker built one shared detector and used it for all its tasks
        built = client.run(lambda: __import__("lfast").shared_detector.cache_info().currsize)
        assert sorted(built.values()) in ([1, 1], [0, 1]), built
    assert n > 0
    subprocess.run(
        [str(cli), "detect", "frames", "--out", "out_cli", "--format", ",".join(FORMATS),
         "--backend", "cpu", "--n-features", "1500", "--quiet"],
        check=True,
    )
    a, b = tree(tmp_path / "out_dask"), tree(tmp_path / "out_cli")
    assert sorted(a) == sorted(b)
    assert len(a) == 5 * len(jobs)
    assert "kitti/000000.json" in a
    for name in a:
        assert a[name] == b[name], name


def test_example_command_line(cli, tmp_path, monkeypatch):
    """The script's own command line (a local cluster) on two frames."""
    import sys

    frames = tmp_path / "f"
    frames.mkdir()
    for p in IMAGES[:2]:
        shutil.copy(p, frames / p.name)
    monkeypatch.chdir(tmp_path)
    r = subprocess.run([sys.executable, str(EXAMPLE), "f", "o", "--workers", "2", "--format", "json",
                        "mode=paper"], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    subprocess.run([str(cli), "detect", "f", "--out", "c", "--mode", "paper", "--backend", "cpu", "--quiet"],
                   check=True)
    assert tree(tmp_path / "o") == tree(tmp_path / "c")
