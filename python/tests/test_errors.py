"""Every bad input raises the documented exception, with a message naming the cause."""

from __future__ import annotations

import os

import numpy as np
import pytest

import lfast

IMG = np.zeros((64, 80), np.uint8)


@pytest.fixture(scope="module")
def det() -> lfast.Detector:
    return lfast.Detector(backend="cpu")


@pytest.mark.parametrize(
    "image, exc, words",
    [
        ([[0, 1], [2, 3]], TypeError, "numpy.ndarray"),
        (None, TypeError, "numpy.ndarray"),
        (np.zeros((64, 80), np.float32), TypeError, "dtype"),
        (np.zeros((64, 80), np.int32), TypeError, "dtype"),
        (np.zeros((64, 80), bool), TypeError, "dtype"),
        (np.zeros(80, np.uint8), ValueError, "dimensions"),
        (np.zeros((2, 64, 80, 3), np.uint8), ValueError, "dimensions"),
        (np.zeros((64, 80, 2), np.uint8), ValueError, "channels"),
        (np.zeros((0, 80), np.uint8), ValueError, "empty"),
        (np.zeros((64, 0, 3), np.uint8), ValueError, "empty"),
        (np.zeros((1, 20000), np.uint8), ValueError, "limit"),
    ],
    ids=["list", "None", "float32", "int32", "bool", "1-D", "4-D", "2-channel", "empty", "empty-bgr", "too-wide"],
)
@pytest.mark.parametrize("call", ["detect", "detectAndCompute", "edges", "compute"])
def test_bad_images(det, image, exc, words, call):
    with pytest.raises(exc, match=words):
        if call == "compute":
            det.compute(image, np.zeros((0, 7), np.float32))
        else:
            getattr(det, call)(image)


@pytest.mark.parametrize(
    "mask, exc, words",
    [
        (np.zeros((64, 81), np.uint8), ValueError, "mask is 81x64 but the image is 80x64"),
        (np.zeros((63, 80), bool), ValueError, "mask is 80x63"),
        (np.zeros((64, 80), np.float64), TypeError, "mask must have dtype"),
        (np.zeros((64, 80), np.uint16), TypeError, "mask must have dtype uint8 or bool"),
        (np.zeros((64, 80, 1), np.uint8), ValueError, "mask must have 2 dimensions"),
        ("all", TypeError, "mask must be a numpy.ndarray"),
    ],
)
def test_bad_masks(det, mask, exc, words):
    with pytest.raises(exc, match=words):
        det.detect(IMG, mask)
    with pytest.raises(exc, match=words):
        det.detectAndCompute(IMG, mask)


@pytest.mark.parametrize(
    "kw, field",
    [
        ({"n_levels": 0}, "n_levels"),
        ({"n_levels": 33}, "n_levels"),
        ({"scale_factor": 1.0}, "scale_factor"),
        ({"scale_factor": float("nan")}, "scale_factor"),
        ({"delta": 0.0}, "delta"),
        ({"delta": float("inf")}, "delta"),
        ({"alpha_pct": 100}, "alpha_pct"),
        ({"support": 9}, "support"),
        ({"straight_tol": 8}, "straight_tol"),
        ({"border": 3}, "border"),
        ({"nms_radius": 33}, "nms_radius"),
        ({"orientation_bins": 361}, "orientation_bins"),
        ({"mode": "fast"}, "mode"),
        ({"mode": 1}, "mode"),
        ({"n_features": -1}, "n_features"),
        ({"n_features": 1.5}, "n_features"),
        ({"n_features": "100"}, "n_features"),
        ({"n_features": 2**40}, "n_features"),
        ({"distribution": 1}, "distribution"),
        ({"n_levels": True}, "n_levels"),
        ({"n_levels": [3]}, "n_levels"),
    ],
)
def test_bad_config_values_name_the_field(kw, field):
    with pytest.raises(ValueError, match=f"`{field}`"):
        lfast.Detector(backend="cpu", **kw)


def test_unknown_keyword_and_backend():
    with pytest.raises(TypeError, match="unexpected keyword argument 'nfeatures'.*n_features"):
        lfast.Detector(backend="cpu", nfeatures=100)
    with pytest.raises(ValueError, match="`backend`.*tpu"):
        lfast.Detector(backend="tpu")
    with pytest.raises(TypeError, match="backend"):
        lfast.Detector(backend=None)


def test_gpu_backend_is_gpu_or_gpu_error():
    """backend='gpu' opens a GPU or raises GpuError; CI (REQUIRE_GPU=1, lavapipe) must open one."""
    try:
        d = lfast.Detector(backend="gpu")
    except lfast.GpuError as e:
        assert isinstance(e, RuntimeError)
        if os.environ.get("REQUIRE_GPU") == "1":
            pytest.fail(f"REQUIRE_GPU=1 but no GPU: {e}")
        pytest.skip(f"no GPU here: {e}")
    assert d.backend == "gpu" and d.adapter
    rng = np.random.default_rng(1)
    img = (rng.random((120, 160)) * 255).astype(np.uint8)
    img = np.kron(img[::8, ::8], np.ones((8, 8), np.uint8))  # blocks: corners
    cpu = lfast.Detector(backend="cpu")
    k1, d1 = d.detectAndCompute(img)
    k2, d2 = cpu.detectAndCompute(img)
    assert len(k1) > 0
    np.testing.assert_array_equal(lfast.keypoints_to_array(k1), lfast.keypoints_to_array(k2))
    np.testing.assert_array_equal(d1, d2)
    np.testing.assert_array_equal(d.edges(img), cpu.edges(img))


@pytest.mark.parametrize(
    "kps, exc, words",
    [
        (np.array([[500.0, 10, 31, 0, 0, 0, -1]], np.float32), ValueError, "keypoint 0: position"),
        (np.array([[10.0, 10, 31, 0, 0, 9, -1]], np.float32), ValueError, "keypoint 0: octave 9"),
        (np.array([[10.0, 10, 31, 0, 0, 0.5, -1]], np.float32), ValueError, "octave 0.5 is not an integer"),
        (np.array([[np.nan, 10, 31, 0, 0, 0, -1]], np.float32), ValueError, "not finite"),
        (np.zeros((3, 6), np.float32), ValueError, r"shape \(N, 7\)"),
        ([1, 2, 3], TypeError, "keypoint 0 is a int"),
    ],
)
def test_bad_keypoints_for_compute(det, kps, exc, words):
    with pytest.raises(exc, match=words):
        det.compute(IMG, kps)


def test_bad_descriptors_for_match_and_hamming():
    good = np.zeros((4, 32), np.uint8)
    with pytest.raises(ValueError, match=r"shape \(N, 32\)"):
        lfast.match(np.zeros((4, 31), np.uint8), good)
    with pytest.raises(TypeError, match="dtype uint8"):
        lfast.match(good.astype(np.int64), good)
    with pytest.raises(TypeError, match="numpy.ndarray"):
        lfast.match([[0] * 32], good)
    with pytest.raises(ValueError, match="`ratio`"):
        lfast.match(good, good, ratio=0.0)
    with pytest.raises(ValueError, match="`ratio`"):
        lfast.match(good, good, ratio=1.5)
    with pytest.raises(ValueError, match="max_distance"):
        lfast.match(good, good, max_distance=300)
    with pytest.raises(ValueError, match=r"shape \(N, 32\)"):
        lfast.hamming(np.zeros(16, np.uint8), good)
    # empty sets are fine: no matches
    assert len(lfast.match(good[:0], good)) == 0
    assert len(lfast.match(good, None)) == 0


def test_imread_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope.png"):
        lfast.imread(tmp_path / "nope.png")
    bad = tmp_path / "bad.png"
    bad.write_bytes(b"not an image")
    with pytest.raises(ValueError, match="bad.png"):
        lfast.imread(bad)


def test_write_features_errors(tmp_path):
    kps = np.zeros((2, 7), np.float32)
    with pytest.raises(ValueError, match="2 keypoints but 1 descriptors"):
        lfast.write_features(tmp_path / "a", "a.png", 10, 10, kps, np.zeros((1, 32), np.uint8))
    with pytest.raises(ValueError, match="unknown format `xml`"):
        lfast.write_features(tmp_path / "a", "a.png", 10, 10, kps, np.zeros((2, 32), np.uint8), ["xml"])
