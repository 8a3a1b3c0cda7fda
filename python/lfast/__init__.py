"""lfast: the L-FAST feature detector in OpenCV's Feature2D vocabulary.

L-FAST (Lu et al., Sensors 2022) finds corners on an improved adaptive Canny
edge map and describes them with ORB's rotated BRIEF, over an image pyramid.
The same results come from the GPU (wgpu compute shaders) and the CPU, bit for
bit.

>>> import lfast, cv2
>>> det = lfast.Detector(backend="cpu", n_features=1000)
>>> img = cv2.imread("frame.png")                    # BGR, gray, BGRA or uint16
>>> keypoints, descriptors = det.detectAndCompute(img, None)
>>> matches = lfast.match(descriptors, other_descriptors, ratio=0.8)

With OpenCV (``cv2``) installed, keypoints are ``cv2.KeyPoint`` and matches
``cv2.DMatch``. Without it, keypoints are an N x 7 float32 array with the
columns of :data:`KEYPOINT_COLUMNS` and matches an M x 3 int32 array (query
index, train index, distance); :func:`keypoints_to_array` and
:func:`array_to_keypoints` convert either way.

Inputs: ``numpy.ndarray`` of dtype uint8 or uint16 (16-bit values are shifted
right by 8), H x W gray or H x W x 3 BGR / H x W x 4 BGRA in OpenCV's channel
order (converted with OpenCV's integer BT.601 luma), any strides (slices,
crops, flips). Errors:

- ``TypeError``: not an ndarray, or a dtype other than uint8/uint16 (masks:
  uint8 or bool); an unknown keyword of :class:`Detector`;
- ``ValueError``: a bad config value (the message names the field), wrong
  number of dimensions or channels, an empty or oversized image, a mask of
  another size than the image, a keypoint outside the image;
- :class:`GpuError` (a ``RuntimeError``): ``backend="gpu"`` without a usable GPU.

Every call releases the GIL while it works, so threads run frames in parallel.
"""

from __future__ import annotations

import functools
import os
from typing import Any, Iterable, Iterator, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _lfast
from ._lfast import GpuError, default_config, imread, output_paths

__all__ = [
    "Detector",
    "GpuError",
    "KEYPOINT_COLUMNS",
    "array_to_keypoints",
    "default_config",
    "detect_file",
    "frames",
    "hamming",
    "imread",
    "keypoints_to_array",
    "match",
    "output_paths",
    "shared_detector",
    "write_features",
]

__version__: str = _lfast.__version__

#: Columns of a keypoint array: the fields of ``cv2.KeyPoint``, in order.
KEYPOINT_COLUMNS: Tuple[str, ...] = ("x", "y", "size", "angle", "response", "octave", "class_id")

_CV2: Any = None
_CV2_CHECKED = False


def _cv2() -> Any:
    """The cv2 module, or None when OpenCV is not installed (looked up once)."""
    global _CV2, _CV2_CHECKED
    if not _CV2_CHECKED:
        try:
            import cv2  # noqa: PLC0415

            _CV2 = cv2
        except ImportError:
            _CV2 = None
        _CV2_CHECKED = True
    return _CV2


KeyPoints = Union[List[Any], np.ndarray]


def keypoints_to_array(keypoints: Union[Iterable[Any], np.ndarray]) -> np.ndarray:
    """Keypoints as an N x 7 float32 array (columns :data:`KEYPOINT_COLUMNS`).

    Accepts a sequence of ``cv2.KeyPoint`` (or any objects with ``pt``, ``size``,
    ``angle``, ``response``, ``octave`` and ``class_id``) or an N x 7 array,
    which is returned as a C-contiguous float32 copy.
    """
    if isinstance(keypoints, np.ndarray):
        arr = np.ascontiguousarray(keypoints, dtype=np.float32)
        if arr.ndim == 1 and arr.size == 0:
            arr = arr.reshape(0, 7)
        if arr.ndim != 2 or arr.shape[1] != 7:
            raise ValueError(f"a keypoint array must have shape (N, 7), got {keypoints.shape}")
        return arr.copy() if arr is keypoints else arr
    rows = []
    for i, k in enumerate(keypoints):
        try:
            rows.append((k.pt[0], k.pt[1], k.size, k.angle, k.response, k.octave, k.class_id))
        except AttributeError:
            raise TypeError(
                f"keypoint {i} is a {type(k).__name__}, not a cv2.KeyPoint (pt, size, angle, response, octave, class_id)"
            ) from None
    return np.array(rows, dtype=np.float32).reshape(len(rows), 7)


def array_to_keypoints(array: np.ndarray) -> List[Any]:
    """An N x 7 keypoint array as a list of ``cv2.KeyPoint`` (needs OpenCV)."""
    cv2 = _cv2()
    if cv2 is None:
        raise ImportError("array_to_keypoints needs OpenCV: pip install opencv-python-headless")
    a = keypoints_to_array(array)
    return [
        cv2.KeyPoint(float(x), float(y), float(s), float(ang), float(r), int(o), int(c))
        for x, y, s, ang, r, o, c in a.tolist()
    ]


def _keypoints_out(arr: np.ndarray) -> KeyPoints:
    return array_to_keypoints(arr) if _cv2() is not None else arr


def _descriptors_in(d: Any) -> Any:
    # cv2 returns None for "no descriptors"; treat it as an empty set
    return np.zeros((0, 32), np.uint8) if d is None else d


class Detector:
    """L-FAST keypoints and ORB descriptors, as an OpenCV ``Feature2D``.

    ``Detector(backend="auto", **config)``: ``backend`` is ``"auto"`` (the GPU
    when one opens, else the CPU), ``"gpu"`` (or :class:`GpuError`) or
    ``"cpu"``. Every field of the configuration is a keyword (see
    :func:`default_config` for the names and defaults): ``delta``,
    ``alpha_pct``, ``mode`` (``"branch"`` or ``"paper"``), ``support``,
    ``straight_tol``, ``border``, ``nms_radius``, ``n_levels``,
    ``scale_factor``, ``n_features`` (0 = no cap), ``distribution``,
    ``orientation_bins``, ``descriptor`` (``"lfast"`` or ``"opencv"``: equal
    to ``cv2.ORB_create().compute()``'s, CPU only), ``snap_radius``, ``reject_edges``,
    ``fill_fast_ini`` and ``fill_fast_min`` (with a cap, FAST corners top up
    levels L-FAST leaves short, ``class_id`` 1; 0 = off; CPU only). A bad value raises ``ValueError`` naming the field;
    an unknown name raises ``TypeError``.

    One detector may be shared by threads; each call releases the GIL.
    """

    def __init__(self, backend: str = "auto", **config: Any) -> None:
        if not isinstance(backend, str):
            raise TypeError(f"backend must be 'auto', 'gpu' or 'cpu', got {backend!r}")
        self._d = _lfast.Detector(backend, **config)

    @property
    def backend(self) -> str:
        """``"gpu"`` or ``"cpu"``: where the next frame runs."""
        return self._d.backend

    @property
    def adapter(self) -> Optional[str]:
        """The GPU adapter's name, or None on the CPU."""
        return self._d.adapter

    @property
    def config(self) -> dict:
        """Every configuration field and its value."""
        return self._d.config

    def __repr__(self) -> str:
        return repr(self._d)

    def detect(self, image: np.ndarray, mask: Optional[np.ndarray] = None) -> KeyPoints:
        """Keypoints of ``image``: a list of ``cv2.KeyPoint`` (an N x 7 array without cv2).

        ``mask``: uint8 or bool, the image's height and width; keypoints lie
        only where it is nonzero (away from its boundary by the descriptor's
        radius). Order: response descending, then octave, y, x.
        """
        return _keypoints_out(self._d.detect(image, mask))

    def detectAndCompute(  # noqa: N802 (OpenCV's name)
        self, image: np.ndarray, mask: Optional[np.ndarray] = None
    ) -> Tuple[KeyPoints, np.ndarray]:
        """``(keypoints, descriptors)``: descriptors is N x 32 uint8, row i of keypoint i."""
        kps, desc = self._d.detect_and_compute(image, mask)
        return _keypoints_out(kps), desc

    detect_and_compute = detectAndCompute

    def compute(self, image: np.ndarray, keypoints: KeyPoints) -> Tuple[KeyPoints, np.ndarray]:
        """``(keypoints, descriptors)`` of given keypoints (from any detector).

        Each keypoint is described at its ``octave`` with an orientation
        recomputed from the image, so lfast's own keypoints get exactly the
        descriptors of :meth:`detectAndCompute`. With ``descriptor="opencv"``
        the keypoint's own ``angle`` is used, as cv2 ORB's ``compute`` does,
        and keypoints near the border (which cv2 drops) are kept, in order.
        A keypoint outside the image
        or with an octave outside ``0..n_levels`` raises ``ValueError``.
        """
        arr = keypoints_to_array(keypoints)
        return keypoints, self._d.compute(image, arr)

    def edges(self, image: np.ndarray) -> np.ndarray:
        """The improved Canny edge map of ``image``: uint8, 255 = edge, 0 elsewhere."""
        return self._d.edges(image)

    # OpenCV's Feature2D accessors
    def descriptorSize(self) -> int:  # noqa: N802
        """32 bytes (256-bit rBRIEF)."""
        return 32

    def descriptorType(self) -> int:  # noqa: N802
        """``cv2.CV_8U`` (0)."""
        return 0

    def defaultNorm(self) -> int:  # noqa: N802
        """``cv2.NORM_HAMMING`` (6)."""
        return 6

    def getDefaultName(self) -> str:  # noqa: N802
        return "lfast.Detector"


@functools.lru_cache(maxsize=None)
def _shared(backend: str, config: Tuple[Tuple[str, Any], ...]) -> Detector:
    return Detector(backend, **dict(config))


def shared_detector(backend: str = "auto", **config: Any) -> Detector:
    """The :class:`Detector` of this process for these arguments, built on first use.

    For task engines (Dask, Ray, multiprocessing): tasks call it instead of
    building a detector each (a GPU context and its buffers), and every task
    of a worker process shares one. Thread-safe to use; the arguments must be
    hashable.
    """
    return _shared(backend, tuple(sorted(config.items())))


shared_detector.cache_info = _shared.cache_info  # type: ignore[attr-defined]
shared_detector.cache_clear = _shared.cache_clear  # type: ignore[attr-defined]


def match(
    query: np.ndarray,
    train: np.ndarray,
    cross_check: bool = True,
    ratio: Optional[float] = None,
    max_distance: Optional[int] = None,
) -> Union[List[Any], np.ndarray]:
    """Brute-force Hamming matching of N x 32 uint8 descriptors.

    For each query descriptor, its nearest train descriptor (lowest index on
    ties). ``cross_check``: keep a match only when the query is also the
    nearest of its train descriptor. ``ratio``: Lowe's test ``d1 < ratio * d2``
    in (0, 1], evaluated exactly in integers. ``max_distance``: keep matches at
    most this far (0..256). At most one match per query, in query order.

    Returns a list of ``cv2.DMatch`` (an M x 3 int32 array of query index,
    train index, distance without cv2).
    """
    m = _lfast.match_arrays(
        _descriptors_in(query), _descriptors_in(train), cross_check, ratio, max_distance
    )
    cv2 = _cv2()
    if cv2 is None:
        return m
    return [cv2.DMatch(q, t, float(d)) for q, t, d in m.tolist()]


def hamming(a: np.ndarray, b: np.ndarray) -> Union[int, np.ndarray]:
    """Hamming distance of two 32-byte descriptors (an int), or the N x M
    uint32 distance matrix of two N x 32 and M x 32 uint8 arrays."""
    return _lfast.hamming(a, b)


PathLike = Union[str, "os.PathLike[str]"]


def write_features(
    base: PathLike,
    image: PathLike,
    width: int,
    height: int,
    keypoints: KeyPoints,
    descriptors: np.ndarray,
    formats: Sequence[str] = ("json",),
) -> List[str]:
    """Writes one image's features exactly as ``lfast detect --format ...`` does.

    ``base``: the output path without suffix (``OUT/rel/name``); the files are
    ``base.json``, ``base.csv``, ``base.keypoints.npy`` and
    ``base.descriptors.npy``, ``base.yaml`` for the formats ``json``, ``csv``,
    ``npy``, ``yaml``. ``image`` is the input path recorded in the JSON. Files
    are written atomically (temporary file and rename); missing directories
    are created. Returns the paths written.
    """
    written = _lfast.write_features(
        os.fspath(base),
        os.fspath(image),
        int(width),
        int(height),
        keypoints_to_array(keypoints),
        _descriptors_in(descriptors),
        list(formats),
    )
    return [os.fspath(p) for p in written]


def detect_file(
    detector: Detector,
    path: PathLike,
    base: PathLike,
    formats: Sequence[str] = ("json",),
) -> int:
    """Reads ``path`` as ``lfast detect`` does, detects and describes, and writes
    ``base + ".json"`` (and the other ``formats``) as ``lfast detect`` writes
    them; returns the number of keypoints. The building block of batch jobs
    (see docs/scale-out.md)."""
    img = imread(os.fspath(path))
    kps, desc = detector._d.detect_and_compute(img, None)
    write_features(base, path, img.shape[1], img.shape[0], kps, desc, formats)
    return int(kps.shape[0])



#: Image file extensions :func:`frames` takes from a folder (as ``lfast detect``).
IMAGE_EXTENSIONS: Tuple[str, ...] = (
    ".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".pgm", ".ppm", ".pnm", ".pbm",
)


def frames(path: PathLike, topic: Optional[str] = None) -> Iterator[Tuple[Optional[int], np.ndarray]]:
    """The frames of a folder, a video or an MCAP file, as ``(timestamp, image)``.

    ``image`` is the frame as ``lfast detect`` reads it: a uint8 H x W gray
    array (SPEC 0: colour by OpenCV's BT.601 luma, 16-bit by ``v >> 8``),
    ready for :meth:`Detector.detectAndCompute` or any cv2 function.
    ``timestamp`` is an int in nanoseconds: the message's log time (MCAP) or
    the presentation time (video); ``None`` for a folder.

    - A folder: its image files (not its subfolders), sorted by name.
    - An MCAP file (``.mcap``, e.g. a ROS 2 bag): the frames of ``topic``
      (default: the file's one image topic; with several, the error lists
      them), in log-time order: ``sensor_msgs/msg/Image`` (mono8, mono16,
      rgb8, bgr8, rgba8, bgra8), ``sensor_msgs/msg/CompressedImage`` (png,
      jpeg), ``foxglove.RawImage``, ``foxglove.CompressedImage``.
    - A video (mp4, mkv, avi, mov, webm): decoded by the ``ffmpeg`` program.

    Frames are read one at a time: memory does not grow with the recording.
    A damaged file (truncated, a chunk with a bad CRC) raises ``ValueError``
    saying where reading stopped, after every intact frame before it;
    another image encoding raises ``RuntimeError`` naming it.
    """
    p = os.fspath(path)
    if os.path.isdir(p):
        names = sorted(n for n in os.listdir(p) if n.lower().endswith(IMAGE_EXTENSIONS) and not n.startswith("."))
        for n in names:
            f = os.path.join(p, n)
            if os.path.isfile(f):
                yield None, imread(f)
        return
    yield from _lfast.Frames(p, topic)
