"""Type stubs of the native module lfast._lfast (python/src/lib.rs).

Use the wrapper in ``lfast`` (OpenCV types, documentation); this module works
on arrays only: keypoints N x 7 float32, descriptors N x 32 uint8.
"""

from os import PathLike
from typing import Any, Dict, List, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

__version__: str

class GpuError(RuntimeError): ...

class Detector:
    def __init__(self, backend: str = "auto", **config: Any) -> None: ...
    @property
    def backend(self) -> str: ...
    @property
    def adapter(self) -> Optional[str]: ...
    @property
    def config(self) -> Dict[str, Any]: ...
    def detect(self, image: npt.NDArray[Any], mask: Optional[npt.NDArray[Any]] = None) -> npt.NDArray[np.float32]: ...
    def detect_and_compute(
        self, image: npt.NDArray[Any], mask: Optional[npt.NDArray[Any]] = None
    ) -> tuple[npt.NDArray[np.float32], npt.NDArray[np.uint8]]: ...
    def compute(self, image: npt.NDArray[Any], keypoints: npt.NDArray[np.float32]) -> npt.NDArray[np.uint8]: ...
    def edges(self, image: npt.NDArray[Any]) -> npt.NDArray[np.uint8]: ...

def default_config() -> Dict[str, Any]: ...
def match_arrays(
    query: npt.NDArray[np.uint8],
    train: npt.NDArray[np.uint8],
    cross_check: bool = True,
    ratio: Optional[float] = None,
    max_distance: Optional[int] = None,
) -> npt.NDArray[np.int32]: ...
def hamming(a: npt.NDArray[np.uint8], b: npt.NDArray[np.uint8]) -> Union[int, npt.NDArray[np.uint32]]: ...
def imread(path: Union[str, PathLike[str]]) -> npt.NDArray[np.uint8]: ...
def write_features(
    base: Union[str, PathLike[str]],
    image: Union[str, PathLike[str]],
    width: int,
    height: int,
    keypoints: npt.NDArray[np.float32],
    descriptors: npt.NDArray[np.uint8],
    formats: Sequence[str] = ...,
) -> List[Any]: ...
def output_paths(base: str, formats: Sequence[str] = ...) -> List[str]: ...
