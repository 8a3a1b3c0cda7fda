"""The GIL is released while lfast works, so Python threads run frames in parallel."""

from __future__ import annotations

import sys
import threading
import time

import numpy as np

import lfast
from conftest import kitti_frames


def test_python_runs_while_a_frame_is_processed():
    """While one thread is inside an lfast call, another runs Python code.

    The switch interval is raised to 30 s, so the interpreter never takes the
    GIL from a thread that holds it: were the GIL held during the call, the
    main thread could not run until the worker had returned and cleared its
    flag, and would never see it set. With the GIL released, the main thread
    gets the GIL back exactly when the worker enters the call (the worker holds
    it until then), so its first check runs while the call is in flight,
    however fast the call is: the checks do not wait first. No timing is compared.
    """
    rng = np.random.default_rng(5)
    big = np.kron((rng.random((256, 256)) * 255).astype(np.uint8), np.ones((8, 8), np.uint8))
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
        for _ in range(20):
            total = sum(range(1000))  # pure Python: needs the GIL
            seen.append(inside.is_set() and total == 499500)
            time.sleep(0.001)
        t.join(timeout=120)
    finally:
        sys.setswitchinterval(old)
    assert any(seen), "no Python code ran while lfast worked: the GIL was not released"


def test_two_calls_on_one_detector_run_at_once_and_match_a_serial_loop():
    """Two threads are inside lfast calls on one Detector at the same time.

    Each worker counts itself in (pure Python, under the GIL) just before its
    call and out just after. With the switch interval at 30 s the interpreter
    never takes the GIL from a running thread, so the second worker can only
    count itself in while the first is inside its call if that call released
    the GIL; a count of two is therefore seen only when both calls are in
    flight together. The frames each thread got back equal a serial loop's.
    No timing is compared: the pool's speed-up is a benchmark
    (scripts/bench_python_threads.py), not a test.
    """
    frames = [np.kron(lfast.imread(p), np.ones((2, 2), np.uint8)) for p in kitti_frames(4)]
    det = lfast.Detector(backend="cpu")
    serial = [det.detectAndCompute(f) for f in frames]
    lock = threading.Lock()
    state = {"in": 0, "most": 0}
    results = [None] * len(frames)

    def work(k):
        for i in range(k, len(frames), 2):
            with lock:
                state["in"] += 1
                state["most"] = max(state["most"], state["in"])
            try:
                results[i] = det.detectAndCompute(frames[i])
            finally:
                with lock:
                    state["in"] -= 1

    old = sys.getswitchinterval()
    sys.setswitchinterval(30.0)
    try:
        threads = [threading.Thread(target=work, args=(k,)) for k in range(2)]
        for t in threads:
            t.start()
        for t in threads:
            t.join(timeout=300)
    finally:
        sys.setswitchinterval(old)
    assert all(r is not None for r in results), "a worker thread did not finish"
    assert state["most"] == 2, "the two calls never overlapped: the GIL was held during a call"
    for (kp_a, d_a), (kp_b, d_b) in zip(serial, results):
        assert len(kp_a) > 0
        np.testing.assert_array_equal(lfast.keypoints_to_array(kp_b), lfast.keypoints_to_array(kp_a))
        np.testing.assert_array_equal(d_b, d_a)
