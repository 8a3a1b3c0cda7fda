"""Without OpenCV, keypoints are N x 7 float32 arrays and matches M x 3 int32 arrays."""

from __future__ import annotations

import subprocess
import sys
import textwrap

CODE = textwrap.dedent(
    """
    import sys
    sys.modules["cv2"] = None          # as if OpenCV were not installed
    import numpy as np
    import lfast
    rng = np.random.default_rng(0)
    img = np.kron((rng.random((16, 20)) * 255).astype(np.uint8), np.ones((8, 8), np.uint8))
    det = lfast.Detector(backend="cpu")
    kps = det.detect(img)
    assert isinstance(kps, np.ndarray) and kps.dtype == np.float32 and kps.shape[1] == 7, kps
    assert len(kps) > 0
    kps2, desc = det.detectAndCompute(img)
    assert np.array_equal(kps, kps2) and desc.shape == (len(kps), 32)
    same, desc3 = det.compute(img, kps)
    assert same is kps and np.array_equal(desc, desc3)
    m = lfast.match(desc, desc)
    assert m.dtype == np.int32 and m.shape == (len(desc), 3)
    assert np.array_equal(m[:, 0], m[:, 1]) and not m[:, 2].any()
    try:
        lfast.array_to_keypoints(kps)
    except ImportError as e:
        assert "opencv" in str(e)
    else:
        raise AssertionError("array_to_keypoints without cv2 must raise ImportError")
    print("ok", len(kps))
    """
)


def test_without_cv2():
    r = subprocess.run([sys.executable, "-c", CODE], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith("ok ")
