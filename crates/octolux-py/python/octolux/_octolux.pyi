"""Type stubs of the compiled module (crates/octolux-py/src/lib.rs); use the `octolux` package."""
from typing import List, Optional, Sequence, Tuple

import numpy as np
import numpy.typing as npt

__version__: str
INTEGRATORS: List[str]

class OctoluxError(Exception):
    """An octolux error: the message is the CLI's."""

class Scene:
    """A loaded and prepared scene, reusable across renders."""

    @property
    def name(self) -> str: ...
    @property
    def resolution(self) -> Tuple[int, int]: ...
    @property
    def backend(self) -> str: ...
    @property
    def warnings(self) -> List[str]: ...
    @property
    def notes(self) -> List[str]: ...

def load_scene(
    path: str, defines: Sequence[Tuple[str, str]] = ..., resolution: Optional[Tuple[int, int]] = ..., backend: str = ...
) -> Scene: ...
def render(
    scene: Scene,
    integrator: Optional[str] = ...,
    spp: Optional[int] = ...,
    seed: int = ...,
    max_depth: Optional[int] = ...,
    photons: Optional[int] = ...,
    sets: Sequence[str] = ...,
    settings_file: Optional[str] = ...,
    cache: Optional[str] = ...,
    allow_stale_cache: bool = ...,
    threads: Optional[int] = ...,
    time_budget: Optional[float] = ...,
) -> Tuple[npt.NDArray[np.float32], str]: ...
def bake(
    scene: Scene,
    output: str,
    seed: int = ...,
    max_depth: Optional[int] = ...,
    photons: Optional[int] = ...,
    sets: Sequence[str] = ...,
    settings_file: Optional[str] = ...,
    threads: Optional[int] = ...,
) -> str: ...
def render_to_files(
    scene: str,
    output: str,
    defines: Sequence[Tuple[str, str]] = ...,
    resolution: Optional[Tuple[int, int]] = ...,
    backend: str = ...,
    integrator: Optional[str] = ...,
    spp: Optional[int] = ...,
    seed: int = ...,
    max_depth: Optional[int] = ...,
    photons: Optional[int] = ...,
    sets: Sequence[str] = ...,
    settings_file: Optional[str] = ...,
    cache: Optional[str] = ...,
    allow_stale_cache: bool = ...,
    camera_path: Optional[str] = ...,
    sensors: bool = ...,
    frames: Optional[Tuple[int, int]] = ...,
    threads: Optional[int] = ...,
    time_budget: Optional[float] = ...,
) -> Tuple[List[str], List[str]]: ...
def frame_count(scene: str, defines: Sequence[Tuple[str, str]] = ..., camera_path: Optional[str] = ..., sensors: bool = ...) -> int: ...
def check_output(path: str) -> None: ...
def remove_created_folders() -> None: ...
def keep_created_folders() -> None: ...
def compare(image: npt.NDArray[np.float32], reference: npt.NDArray[np.float32]) -> str: ...
def read_exr(path: str) -> Tuple[npt.NDArray[np.float32], int, int]: ...
def write_exr(path: str, image: npt.NDArray[np.float32]) -> None: ...
def builtin_scenes() -> List[str]: ...
