"""Results: bit-identical to the CLI, every accepted input form, OpenCV interop."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

import lfast
from conftest import IMAGES, cli_arrays

NAMES = [p.name for p in IMAGES]


@pytest.fixture(scope="module")
def det() -> lfast.Detector:
    return lfast.Detector(backend="cpu")


def as_array(kps) -> np.ndarray:
    return lfast.keypoints_to_array(kps)


@pytest.mark.parametrize("path", IMAGES, ids=NAMES)
def test_detect_and_compute_equals_cli_json(det, cli_json, path):
    ref_kps, ref_desc = cli_arrays(cli_json[path.name])
    assert len(ref_kps) > 0, "the bundled images all have keypoints"
    img = lfast.imread(path)
    kps, desc = det.detectAndCompute(img, None)
    assert all(isinstance(k, cv2.KeyPoint) for k in kps)
    np.testing.assert_array_equal(as_array(kps), ref_kps)
    assert desc.dtype == np.uint8 and desc.shape == (len(kps), 32)
    np.testing.assert_array_equal(desc, ref_desc)


@pytest.mark.parametrize("path", IMAGES, ids=NAMES)
def test_cv2_imread_unchanged_gives_the_same_result(det, cli_json, path):
    # BGR (astronaut) and gray PNGs as cv2 decodes them: SPEC 0 luma is OpenCV's
    img = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    kps, desc = det.detectAndCompute(img)
    ref_kps, ref_desc = cli_arrays(cli_json[path.name])
    np.testing.assert_array_equal(as_array(kps), ref_kps)
    np.testing.assert_array_equal(desc, ref_desc)


@pytest.fixture(scope="module")
def astro_bgr() -> np.ndarray:
    img = cv2.imread(str(IMAGES[0]), cv2.IMREAD_COLOR)
    assert img is not None and img.ndim == 3
    return img


def luma(bgr: np.ndarray) -> np.ndarray:
    """SPEC 0: OpenCV's integer BT.601 luma, (19596 R + 38470 G + 7470 B + 32768) >> 16."""
    b, g, r = (bgr[..., i].astype(np.uint32) for i in range(3))
    return ((19596 * r + 38470 * g + 7470 * b + 32768) >> 16).astype(np.uint8)


@pytest.fixture(scope="module")
def astro_gray(astro_bgr) -> np.ndarray:
    return luma(astro_bgr)


@pytest.fixture(scope="module")
def astro_ref(det, astro_gray):
    return det.detect_and_compute(astro_gray)


def check_same(got, ref):
    np.testing.assert_array_equal(as_array(got[0]), as_array(ref[0]))
    np.testing.assert_array_equal(got[1], ref[1])


def test_bgr_is_converted_by_spec0_luma(det, astro_bgr, astro_ref):
    check_same(det.detectAndCompute(astro_bgr), astro_ref)


def test_cv2_gray_first_gives_what_bgr_gives(det, astro_bgr):
    # a cv2 user who converts to gray first gets exactly the keypoints of one who passes BGR
    check_same(det.detectAndCompute(cv2.cvtColor(astro_bgr, cv2.COLOR_BGR2GRAY)), det.detectAndCompute(astro_bgr))
    # and on a larger, noisier colour image (1000x700), where the older 14-bit weights differed
    rng = np.random.default_rng(3)
    photo = cv2.resize(astro_bgr, (1000, 700), interpolation=cv2.INTER_CUBIC).astype(np.float32)
    photo = np.clip(photo + rng.normal(0, 4, photo.shape), 0, 255).astype(np.uint8)
    check_same(det.detectAndCompute(cv2.cvtColor(photo, cv2.COLOR_BGR2GRAY)), det.detectAndCompute(photo))


def test_luma_equals_cv2_on_all_2_pow_24_colours(tmp_path):
    # SPEC 0 on every colour: lfast.imread of a 4096x4096 PNG holding each colour once
    # against cv2.cvtColor(COLOR_BGR2GRAY), and against the formula
    i = np.arange(1 << 24, dtype=np.uint32)
    bgr = np.stack([(i >> 16) & 255, (i >> 8) & 255, i & 255], axis=-1).astype(np.uint8).reshape(4096, 4096, 3)
    path = tmp_path / "all_colours.png"
    assert cv2.imwrite(str(path), bgr, [cv2.IMWRITE_PNG_COMPRESSION, 1])
    want = cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY)
    np.testing.assert_array_equal(want, luma(bgr))
    np.testing.assert_array_equal(lfast.imread(path), want)


def test_bgra_and_single_channel(det, astro_bgr, astro_gray, astro_ref):
    bgra = cv2.cvtColor(astro_bgr, cv2.COLOR_BGR2BGRA)
    bgra[..., 3] = 17  # alpha is ignored
    check_same(det.detectAndCompute(bgra), astro_ref)
    check_same(det.detectAndCompute(astro_gray[:, :, None]), astro_ref)


def test_uint16_uses_the_high_byte(det, astro_bgr, astro_gray, astro_ref):
    g16 = (astro_gray.astype(np.uint16) << 8) | 0x5A
    check_same(det.detectAndCompute(g16), astro_ref)
    bgr16 = (astro_bgr.astype(np.uint16) << 8) | 0xFF
    check_same(det.detectAndCompute(bgr16), astro_ref)


def test_non_contiguous_views(det, astro_bgr, astro_gray):
    big = np.zeros((300, 320, 4), np.uint8)
    big[10:266, 30:286, :3] = astro_bgr
    view = big[10:266, 30:286, :3]  # a crop of a channel slice: every stride unusual
    assert not view.flags.c_contiguous
    check_same(det.detectAndCompute(view), det.detectAndCompute(np.ascontiguousarray(view)))
    gray = astro_gray
    for v in (gray[::-1], gray[:, ::-1], gray.T, gray[5:200, 7:250]):
        check_same(det.detectAndCompute(v), det.detectAndCompute(np.ascontiguousarray(v)))


def test_detect_equals_detect_and_compute_keypoints(det, astro_bgr, astro_ref):
    kps = det.detect(astro_bgr)
    np.testing.assert_array_equal(as_array(kps), as_array(astro_ref[0]))


def test_compute_on_own_keypoints_gives_the_same_descriptors(det, astro_bgr, astro_ref):
    kps, desc = det.compute(astro_bgr, astro_ref[0])
    assert kps is astro_ref[0]
    np.testing.assert_array_equal(desc, astro_ref[1])
    # and from the array form
    _, desc2 = det.compute(astro_bgr, as_array(astro_ref[0]))
    np.testing.assert_array_equal(desc2, astro_ref[1])


def test_compute_on_opencv_orb_keypoints(det, astro_bgr):
    orb = cv2.ORB_create(nfeatures=200, nlevels=det.config["n_levels"], scaleFactor=det.config["scale_factor"])
    kps = orb.detect(astro_bgr, None)
    assert len(kps) > 50
    out, desc = det.compute(astro_bgr, kps)
    assert desc.shape == (len(kps), 32) and desc.dtype == np.uint8
    assert len(out) == len(kps)


def test_mask(det, astro_bgr, astro_ref):
    h, w = astro_bgr.shape[:2]
    check_same(det.detectAndCompute(astro_bgr, np.full((h, w), 255, np.uint8)), astro_ref)
    assert len(det.detect(astro_bgr, np.zeros((h, w), np.uint8))) == 0
    left = np.zeros((h, w), bool)
    left[:, : w // 2] = True
    kps = det.detect(astro_bgr, left)
    assert 0 < len(kps) < len(astro_ref[0])
    assert all(k.pt[0] < w // 2 for k in kps)


def test_edges(det, astro_bgr, astro_gray):
    e = det.edges(astro_bgr)
    assert e.dtype == np.uint8 and e.shape == astro_bgr.shape[:2]
    assert set(np.unique(e)) == {0, 255}
    np.testing.assert_array_equal(e, det.edges(astro_gray))


def test_edges_equal_the_cli(det, cli, tmp_path):
    import subprocess

    path = IMAGES[1]
    out = tmp_path / "e.png"
    subprocess.run([str(cli), "edges", str(path), "--out", str(out), "--backend", "cpu", "--quiet"], check=True)
    np.testing.assert_array_equal(det.edges(lfast.imread(path)), cv2.imread(str(out), cv2.IMREAD_UNCHANGED))


def test_config_keywords(astro_bgr):
    d = lfast.Detector(backend="cpu", n_features=50, mode="paper", distribution=True, scale_factor=1.5, n_levels=4)
    cfg = d.config
    assert (cfg["n_features"], cfg["mode"], cfg["distribution"], cfg["scale_factor"], cfg["n_levels"]) == (
        50, "paper", True, 1.5, 4
    )
    assert set(cfg) == set(lfast.default_config())
    kps = d.detect(astro_bgr)
    assert 0 < len(kps) <= 50
    assert max(k.octave for k in kps) < 4
    assert d.backend == "cpu" and d.adapter is None
    assert "n_features=50" in repr(d)
    # numpy scalars are accepted like Python numbers
    d2 = lfast.Detector(backend="cpu", n_features=np.int64(50), mode="paper", distribution=np.True_,
                        scale_factor=np.float32(1.5), n_levels=np.uint8(4))
    assert d2.config == cfg


def test_opencv_accepts_the_outputs(det, astro_bgr):
    kps, desc = det.detectAndCompute(astro_bgr)
    drawn = cv2.drawKeypoints(astro_bgr, kps, None, flags=cv2.DRAW_MATCHES_FLAGS_DRAW_RICH_KEYPOINTS)
    assert drawn.shape == astro_bgr.shape and not np.array_equal(drawn, astro_bgr)
    # a rotated copy matched against the original, with OpenCV's matcher and lfast's
    rot = cv2.rotate(astro_bgr, cv2.ROTATE_90_CLOCKWISE)
    kps2, desc2 = det.detectAndCompute(rot)
    bf = cv2.BFMatcher(cv2.NORM_HAMMING, crossCheck=False)
    cv_matches = bf.match(desc, desc2)
    ours = lfast.match(desc, desc2, cross_check=False)
    assert len(cv_matches) == len(ours) == len(desc)
    # the nearest distance of every query agrees (indices may differ on ties)
    assert [m.distance for m in sorted(cv_matches, key=lambda m: m.queryIdx)] == [m.distance for m in ours]
    assert all(isinstance(m, cv2.DMatch) for m in ours)
    cc = cv2.BFMatcher(cv2.NORM_HAMMING, crossCheck=True).match(desc, desc2)
    assert len(cc) > 20
    drawn = cv2.drawMatches(astro_bgr, kps, rot, kps2, lfast.match(desc, desc2)[:30], None)
    assert drawn.shape[1] == astro_bgr.shape[1] + rot.shape[1]


def reference_match(q, t, cross_check, ratio, max_distance):
    """The matcher's definition (src/cpu/matcher.rs) in numpy."""
    d = lfast.hamming(q, t).astype(np.int64)
    best = d.argmin(axis=1)  # lowest index on ties
    d1 = d[np.arange(len(q)), best]
    d2 = np.sort(d, axis=1)[:, 1] if d.shape[1] > 1 else np.full(len(q), -1)
    back = d.argmin(axis=0)
    out = []
    for i in range(len(q)):
        if d1[i] > max_distance:
            continue
        if ratio is not None and d2[i] >= 0 and not (d1[i] * 65536 < int(ratio * 65536) * d2[i]):
            continue
        if cross_check and back[best[i]] != i:
            continue
        out.append((i, best[i], d1[i]))
    return np.array(out, dtype=np.int32).reshape(-1, 3)


@pytest.mark.parametrize("cross_check", [False, True])
@pytest.mark.parametrize("ratio", [None, 0.8])
@pytest.mark.parametrize("max_distance", [None, 40])
def test_match_follows_its_definition(det, astro_bgr, cross_check, ratio, max_distance):
    rng = np.random.default_rng(7)
    q = rng.integers(0, 256, (120, 32), dtype=np.uint8)
    t = q.copy()
    flip = rng.integers(0, 32, (120, 3))
    for i, cols in enumerate(flip):
        t[i, cols] ^= rng.integers(1, 256, 3, dtype=np.uint8)
    t = np.concatenate([t, rng.integers(0, 256, (40, 32), dtype=np.uint8)])
    rng.shuffle(t)
    ours = lfast.match(q, t, cross_check=cross_check, ratio=ratio, max_distance=max_distance)
    got = np.array([(m.queryIdx, m.trainIdx, int(m.distance)) for m in ours], dtype=np.int32).reshape(-1, 3)
    ref = reference_match(q, t, cross_check, ratio, 256 if max_distance is None else max_distance)
    np.testing.assert_array_equal(got, ref)
    assert len(got) > 0


def test_hamming():
    rng = np.random.default_rng(3)
    a = rng.integers(0, 256, (5, 32), dtype=np.uint8)
    b = rng.integers(0, 256, (7, 32), dtype=np.uint8)
    m = lfast.hamming(a, b)
    assert m.shape == (5, 7) and m.dtype == np.uint32
    for i in range(5):
        for j in range(7):
            assert m[i, j] == np.unpackbits(a[i] ^ b[j]).sum() == cv2.norm(a[i], b[j], cv2.NORM_HAMMING)
    assert lfast.hamming(a[0], b[0]) == m[0, 0]
    assert isinstance(lfast.hamming(a[0], a[0]), int) and lfast.hamming(a[0], a[0]) == 0


def test_keypoint_array_round_trip(det, astro_bgr):
    kps = det.detect(astro_bgr)
    arr = lfast.keypoints_to_array(kps)
    assert arr.dtype == np.float32 and arr.shape == (len(kps), 7)
    back = lfast.array_to_keypoints(arr)
    np.testing.assert_array_equal(lfast.keypoints_to_array(back), arr)
    assert lfast.keypoints_to_array([]).shape == (0, 7)
    assert lfast.KEYPOINT_COLUMNS == ("x", "y", "size", "angle", "response", "octave", "class_id")


def test_kitti_frame(kitti1):
    det = lfast.Detector(backend="cpu", n_features=2000)
    img = cv2.imread(str(kitti1), cv2.IMREAD_GRAYSCALE)
    kps, desc = det.detectAndCompute(img)
    assert 500 <= len(kps) <= 2000 and desc.shape == (len(kps), 32)


@pytest.fixture
def kitti1():
    from conftest import kitti_frames

    return kitti_frames(1)[0]
