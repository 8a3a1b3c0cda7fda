"""The GIL is released while lfast works, so Python threads run frames in parallel."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
import threading
import time

import numpy as np
import pytest

import lfast
from conftest import kitti_frames


def test_python_runs_while_a_frame_is_processed():
    """While one thread is inside an lfast call, another runs Python code.

    The switch interval is raised to 30 s, so the interpreter never takes the
    GIL from a thread that holds it: were the GIL held during the call, the
    main thread could not run until the worker had returned and cleared its
    flag, and would never see it set. With the GIL released, the main thread
    runs while the worker is inside the call (a fraction of a second of CPU,
    against microseconds for the main thread's checks). No timing is compared.
    """
    rng = np.random.default_rng(5)
    big = np.kron((rng.random((256, 256)) * 255).astype(np.uint8), np.ones((4, 4), np.uint8))
    det = lfast.Detector(backend="cpu")
    started, inside = threading.Event(), threading.Event()
    seen = []

    def work():
        inside.set()
        started.set()  # never cleared: the main thread cannot miss it
        try:
            det.detectAndCompute(big)
        finally:
            inside.clear()

    old = sys.getswitchinterval()
    sys.setswitchinterval(30.0)
    try:
        t = threading.Thread(target=work)
        t.start()
        assert started.wait(timeout=60)
        time.sleep(0.05)  # let the worker enter the native call
        for _ in range(20):
            total = sum(range(1000))  # pure Python: needs the GIL
            seen.append(inside.is_set() and total == 499500)
            time.sleep(0.001)
        t.join(timeout=120)
    finally:
        sys.setswitchinterval(old)
    assert any(seen), "no Python code ran while lfast worked: the GIL was not released"


# Two threads against one: each call uses one core (RAYON_NUM_THREADS=1), so
# what is measured is whether Python threads overlap their calls.
POOL = textwrap.dedent(
    """
    import json, sys, time
    from concurrent.futures import ThreadPoolExecutor
    import lfast
    import numpy as np
    # each frame enlarged 2x (2482 x 752): enough work per call that thread
    # start-up and scheduling noise are small against it
    frames = [np.kron(lfast.imread(p), np.ones((2, 2), np.uint8)) for p in sys.argv[1:]]
    det = lfast.Detector(backend="cpu")
    for f in frames[:2]:
        det.detectAndCompute(f)          # warm up
    def serial():
        return [len(det.detectAndCompute(f)[0]) for f in frames]
    def pool():
        with ThreadPoolExecutor(2) as ex:
            return [len(k) for k, _ in ex.map(det.detectAndCompute, frames)]
    best = {"serial": 1e9, "pool": 1e9}
    for _ in range(3):
        for name, fn in (("serial", serial), ("pool", pool)):
            t = time.perf_counter()
            n = fn()
            best[name] = min(best[name], time.perf_counter() - t)
            best[name + "_n"] = n
    print(json.dumps(best))
    """
)


def test_two_thread_pool_over_8_frames_is_faster_than_a_serial_loop():
    if (os.cpu_count() or 1) < 2:
        pytest.skip("one core: nothing to run in parallel")
    frames = kitti_frames(8)
    env = dict(os.environ, RAYON_NUM_THREADS="1")
    r = subprocess.run(
        [sys.executable, "-c", POOL, *map(str, frames)], env=env, capture_output=True, text=True, timeout=600
    )
    assert r.returncode == 0, r.stderr
    t = json.loads(r.stdout)
    print(f"8 KITTI frames: serial {t['serial']:.3f} s, 2-thread pool {t['pool']:.3f} s "
          f"({t['serial'] / t['pool']:.2f}x)")
    assert t["pool_n"] == t["serial_n"]  # same results
    assert t["pool"] < t["serial"], t
