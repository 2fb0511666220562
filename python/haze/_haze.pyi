"""Type stubs of the native module (crates/python); `haze/__init__.py` documents the API."""

import os
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

class HazeError(Exception):
    """A haze operation failed; the message is the command line's one-line error."""

class HazeWarning(UserWarning):
    """A haze warning: the command line's WARN line, through ``warnings.warn``."""

def version() -> str: ...
def inspect(
    path: str,
    frames: Optional[str] = None,
    grid: Optional[str] = None,
    env_layout: str = "haze",
    env_rotate: float = 0.0,
    env_strength: float = 1.0,
) -> Dict[str, Any]: ...
def bake(
    src: str,
    out: str,
    frames: Optional[str] = None,
    rbfs: Optional[int] = None,
    residual_error: Optional[float] = None,
    resume: bool = False,
    progress: Optional[Callable[[Dict[str, Any]], Any]] = None,
    warm_up: int = 0,
    domain_offset: Optional[Sequence[float]] = None,
    baseline: Optional[Tuple[float, float, float, int, int]] = None,
    grid: Optional[str] = None,
    vdb_index: Optional[str] = None,
) -> Dict[str, Any]: ...
def baseline(
    src: str,
    frames: Optional[str] = None,
    rbfs: Optional[int] = None,
    grid: Optional[str] = None,
) -> Tuple[float, float, float, int, int]: ...
def merge(chunks: Sequence[str], out: str) -> List[int]: ...
def frame_sizes(src: str, frames: Optional[str] = None) -> List[Tuple[int, int]]: ...
def render(
    input: str,
    frame: Optional[int] = None,
    width: int = 400,
    height: int = 300,
    eye: Optional[Sequence[float]] = None,
    target: Optional[Sequence[float]] = None,
    up: Sequence[float] = ...,
    fov: float = 40.0,
    env: str = "sky",
    suns_: Sequence[Sequence[float]] = ...,
    lights_: Sequence[Sequence[float]] = ...,
    sigma_t: float = 4.0,
    albedo: float = 0.8,
    g: float = 0.3,
    multiple: bool = True,
    residual: bool = True,
    sh_order: int = 4,
    gpu: bool = False,
    reference: bool = False,
    spp: int = 64,
    check: int = 0,
    supersample_: Union[str, int, None] = None,
    ground: str = "auto",
    env_layout: str = "haze",
    env_rotate: float = 0.0,
    env_strength: float = 1.0,
) -> npt.NDArray[np.float32]: ...
def render_scene(
    scene: str,
    width: Optional[int] = None,
    height: Optional[int] = None,
    gpu: bool = False,
    reference: bool = False,
    time: float = 0.0,
) -> npt.NDArray[np.float32]: ...

class Asset:
    """A baked or packed `.haze` asset, opened for reading.

    Reading frames keeps the hash volume last decoded (at most the bake's `--volume-mib`,
    128 MiB by default), so a sequence read frame by frame, in either order, decodes each
    volume at most twice."""

    def __init__(self, path: Union[str, "os.PathLike[str]"]) -> None: ...
    @property
    def path(self) -> "os.PathLike[str]": ...
    @property
    def frames(self) -> List[int]: ...
    @property
    def dims(self) -> Tuple[int, int, int]: ...
    @property
    def bbox(self) -> Tuple[Tuple[float, float, float], Tuple[float, float, float]]: ...
    def __len__(self) -> int: ...
    def rbfs(
        self, number: int
    ) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
    def frame(self, number: int) -> npt.NDArray[np.float32]: ...
    def write_vdb(
        self, number: int, out: Union[str, "os.PathLike[str]"]
    ) -> "os.PathLike[str]": ...

