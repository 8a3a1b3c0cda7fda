"""descriptor="opencv": lfast's descriptors equal cv2 ORB compute()'s bit for bit.

cv2 drops keypoints within 31 pixels of the image border and groups by
octave; lfast keeps every keypoint in order, so rows are paired by keypoint.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest

import lfast

from conftest import IMAGES


def _by_key(kps):
    return {(k.pt[0], k.pt[1], k.octave, k.angle): i for i, k in enumerate(kps)}


@pytest.mark.parametrize("path", IMAGES, ids=lambda p: p.name)
def test_lfast_keypoints_described_as_cv2_does(path):
    img = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    det = lfast.Detector(backend="cpu", descriptor="opencv")
    kps, desc = det.detectAndCompute(img)
    assert len(kps) > 0
    ref_kps, ref_desc = cv2.ORB_create().compute(img, list(kps))
    assert len(ref_kps) > 0
    row = _by_key(kps)
    mine = np.array([desc[row[(k.pt[0], k.pt[1], k.octave, k.angle)]] for k in ref_kps])
    np.testing.assert_array_equal(mine, ref_desc)


@pytest.mark.parametrize("path", IMAGES, ids=lambda p: p.name)
def test_cv2_keypoints_described_as_cv2_does(path):
    img = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    orb = cv2.ORB_create(nfeatures=1000)
    kps, ref = orb.compute(img, orb.detect(img, None))
    assert len(kps) > 0
    _, desc = lfast.Detector(backend="cpu", descriptor="opencv").compute(img, kps)
    np.testing.assert_array_equal(desc, ref)


def test_default_descriptor_is_lfast_and_bad_names_are_errors():
    assert lfast.Detector(backend="cpu").config["descriptor"] == "lfast"
    with pytest.raises(ValueError, match="descriptor"):
        lfast.Detector(backend="cpu", descriptor="sift")
