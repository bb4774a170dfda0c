"""octolux from Python: load a scene, render it with any integrator, bake and reuse lighting
caches, compare images.

    >>> import octolux
    >>> img = octolux.render("cornell-box", spp=4)          # (H, W, 3) float32, linear RGB
    >>> img, stats = octolux.render("cornell-box", spp=4, integrator="octree",
    ...                             settings={"photons": {"photons": 200_000}}, stats=True)

Errors raise :class:`OctoluxError` with the messages of the ``octolux`` command line, a bad
settings key named as the dict spells it (``settings={"bogus": 1}``, not ``--set``); a scene's
warnings are issued as :class:`OctoluxWarning`. Renders release the GIL and stop at the next
tile on Ctrl-C (``KeyboardInterrupt``).
"""
from __future__ import annotations

import json
import os
import warnings
from typing import Any, Dict, Iterable, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _octolux
from ._octolux import INTEGRATORS, OctoluxError, Scene, __version__

__all__ = [
    "INTEGRATORS",
    "OctoluxError",
    "OctoluxWarning",
    "Scene",
    "__version__",
    "bake",
    "builtin_scenes",
    "compare",
    "load_scene",
    "read_exr",
    "render",
    "render_to_files",
    "write_exr",
]

PathLike = Union[str, "os.PathLike[str]"]


def __dir__() -> List[str]:
    # the public names only: not the helpers and imports (`np`, `os`, `Any`, ...)
    return sorted(__all__)


class OctoluxWarning(UserWarning):
    """A warning of octolux: what it renders differently from what the scene file says."""


def _warn(lines: Iterable[str]) -> None:
    for w in lines:
        warnings.warn(w, OctoluxWarning, stacklevel=3)


def builtin_scenes() -> List[str]:
    """The names of the built-in scenes (``cornell-box``, ...)."""
    return list(_octolux.builtin_scenes())


def load_scene(
    path: PathLike,
    defines: Optional[Mapping[str, Any]] = None,
    resolution: Optional[Tuple[int, int]] = None,
    backend: str = "auto",
) -> Scene:
    """Load and prepare a scene: a built-in name, a Mitsuba XML file or an OBJ/PLY mesh.

    ``defines`` are Mitsuba's ``-D name=value`` parameters; ``resolution`` is (width, height);
    ``backend`` is ``auto``, ``embree`` or ``bvh``. The scene can be rendered many times.
    """
    defs = [(str(k), _define_value(v)) for k, v in (defines or {}).items()]
    scene = _octolux.load_scene(os.fspath(path), defs, None if resolution is None else tuple(resolution), backend)
    _warn(scene.warnings)
    return scene


def _define_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    return str(v)


def _sets(settings: Optional[Mapping[str, Any]], prefix: str = "") -> List[str]:
    """A nested settings dict as the CLI's ``--set KEY=VALUE`` writes (dotted keys, JSON values)."""
    out: List[str] = []
    for k, v in (settings or {}).items():
        key = f"{prefix}{k}"
        if isinstance(v, Mapping) and v:
            out += _sets(v, key + ".")
        else:
            out.append(f"{key}={json.dumps(v)}")
    return out


def _scene(scene: Union[Scene, PathLike], resolution: Optional[Tuple[int, int]]) -> Scene:
    if isinstance(scene, Scene):
        if resolution is not None and tuple(resolution) != scene.resolution:
            raise OctoluxError("resolution applies when the scene is loaded: pass it to load_scene(), or pass a path")
        return scene
    return load_scene(scene, resolution=resolution)


def render(
    scene: Union[Scene, PathLike],
    integrator: Optional[str] = None,
    spp: Optional[int] = None,
    seed: int = 0,
    *,
    max_depth: Optional[int] = None,
    photons: Optional[int] = None,
    settings: Optional[Mapping[str, Any]] = None,
    settings_file: Optional[PathLike] = None,
    cache: Optional[PathLike] = None,
    allow_stale_cache: bool = False,
    resolution: Optional[Tuple[int, int]] = None,
    threads: Optional[int] = None,
    time_budget: Optional[float] = None,
    stats: bool = False,
) -> Union[np.ndarray, Tuple[np.ndarray, Dict[str, Any]]]:
    """Render ``scene`` (a :class:`Scene`, a built-in name or a file) and return the image as
    an (H, W, 3) float32 array of linear RGB; with ``stats=True``, also a dict of statistics
    (the ``OUT.json`` of ``octolux render``: ``integrator_settings``, ``render``, ``build``, ...).

    ``integrator`` is one of :data:`INTEGRATORS` (default ``path``); ``settings`` is a nested
    dict of that integrator's settings (the keys of ``octolux render --set``), applied after
    ``settings_file``; ``cache`` renders the ``octree`` integrator from a file :func:`bake`
    wrote. ``spp`` defaults to the scene's sample count, else 64; ``max_depth`` to the scene's.
    """
    sc = _scene(scene, resolution)
    pixels, stats_json = _octolux.render(
        sc,
        integrator,
        spp,
        seed,
        max_depth,
        photons,
        _sets(settings),
        None if settings_file is None else os.fspath(settings_file),
        None if cache is None else os.fspath(cache),
        allow_stale_cache,
        threads,
        time_budget,
    )
    info = json.loads(stats_json)
    _warn(info["warnings"])
    w, h = sc.resolution
    img = pixels.reshape(h, w, 3)
    return (img, info) if stats else img


def bake(
    scene: Union[Scene, PathLike],
    output: PathLike,
    seed: int = 0,
    *,
    max_depth: Optional[int] = None,
    photons: Optional[int] = None,
    settings: Optional[Mapping[str, Any]] = None,
    settings_file: Optional[PathLike] = None,
    threads: Optional[int] = None,
    volume: bool = False,
) -> Dict[str, Any]:
    """Trace the photons and build the ``octree`` integrator's octrees of ``scene``, and write
    them to the lighting cache ``output`` (``octolux bake``: the same bytes for the same scene,
    settings and seed); returns the bake's report (also written beside the cache as
    ``NAME.json``: statistics, times, warnings). ``volume=True`` also stores the volumetric
    values (``octolux bake --volume``)."""
    sc = _scene(scene, None)
    info = json.loads(
        _octolux.bake(
            sc,
            os.fspath(output),
            seed,
            max_depth,
            photons,
            _sets(settings),
            None if settings_file is None else os.fspath(settings_file),
            threads,
            volume,
        )
    )
    _warn(info["warnings"])
    return info


def render_to_files(
    scene: PathLike,
    output: PathLike,
    integrator: Optional[str] = None,
    spp: Optional[int] = None,
    seed: int = 0,
    *,
    defines: Optional[Mapping[str, Any]] = None,
    resolution: Optional[Tuple[int, int]] = None,
    backend: str = "auto",
    max_depth: Optional[int] = None,
    photons: Optional[int] = None,
    settings: Optional[Mapping[str, Any]] = None,
    settings_file: Optional[PathLike] = None,
    cache: Optional[PathLike] = None,
    allow_stale_cache: bool = False,
    camera_path: Optional[PathLike] = None,
    sensors: bool = False,
    frames: Optional[Tuple[int, int]] = None,
    threads: Optional[int] = None,
    time_budget: Optional[float] = None,
) -> List[str]:
    """``octolux render`` itself: render ``scene`` (a built-in name or a file) to ``output``
    (``OUT.exr``, with ``OUT.png`` and ``OUT.json`` beside it), or the frames of
    ``camera_path`` / of the scene's ``sensors`` (``frames``: first and last, from 1) to
    ``OUT_0001.exr``, ... The files are the CLI's, byte for byte but the JSON's times and command
    line. Returns the EXR paths written."""
    written, warns = _octolux.render_to_files(
        os.fspath(scene),
        os.fspath(output),
        [(str(k), _define_value(v)) for k, v in (defines or {}).items()],
        None if resolution is None else tuple(resolution),
        backend,
        integrator,
        spp,
        seed,
        max_depth,
        photons,
        _sets(settings),
        None if settings_file is None else os.fspath(settings_file),
        None if cache is None else os.fspath(cache),
        allow_stale_cache,
        None if camera_path is None else os.fspath(camera_path),
        sensors,
        None if frames is None else tuple(frames),
        threads,
        time_budget,
    )
    _warn(warns)
    return list(written)


def _image(x: Union[np.ndarray, PathLike]) -> np.ndarray:
    if isinstance(x, np.ndarray):
        if x.ndim != 3 or x.shape[2] != 3:
            raise OctoluxError(f"expected an (H, W, 3) array, got shape {x.shape}")
        return np.ascontiguousarray(x, dtype=np.float32)
    return read_exr(x)


def compare(image: Union[np.ndarray, PathLike], reference: Union[np.ndarray, PathLike]) -> Dict[str, Any]:
    """relMSE, RMSE and channel means of ``image`` against ``reference`` (arrays or EXR files):
    ``octolux compare``'s numbers."""
    return json.loads(_octolux.compare(_image(image), _image(reference)))


def read_exr(path: PathLike) -> np.ndarray:
    """An EXR file as an (H, W, 3) float32 array."""
    pixels, w, h = _octolux.read_exr(os.fspath(path))
    return pixels.reshape(h, w, 3)


def write_exr(path: PathLike, image: np.ndarray) -> None:
    """Write an (H, W, 3) array as an EXR file (written aside, then renamed)."""
    _octolux.write_exr(os.fspath(path), _image(image))
