"""Render the frames of an animation on a Dask cluster.

    from distributed import Client
    from octolux.dask import render_frames
    client = Client("tcp://scheduler:8786")          # or LocalCluster() for one machine
    render_frames(client, "scene.xml", "frames/f.exr", camera_path="path.json",
                  bake={"photons": 2_000_000}, spp=64, seed=1)

or from a shell: ``python -m octolux.dask scene.xml -o frames/f.exr --camera-path path.json
--scheduler tcp://scheduler:8786 --photons 2000000 --spp 64``.

How a job runs:
1. The lighting is baked once (:func:`octolux.bake`, as one task on a worker), unless ``cache``
   names a file baked already. Its bytes are broadcast to the workers and named by their
   SHA-256: a worker writes them once to ``<tmp>/octolux-caches/<sha256>.oxc`` and every later
   task (of this job or another) with the same hash reuses that file.
2. Each frame is one task: :func:`octolux.render_to_files` (``octolux render``'s own job, in the
   worker's process) with the cache, the frame and the seed, in a private folder on the worker,
   whose output files (``f_0001.exr``, ``.png``, ``.json``) return to the client as bytes. The
   client writes them under the names one machine would write, each staged and renamed.
3. A frame's image depends only on the cache, its camera and the seed (docs/guide/baking.md),
   so the EXR and PNG files are bit-identical to a single-machine ``octolux render --cache ...
   --camera-path ...`` with the same seed; the JSON's times and command line differ.
4. A task whose worker dies is run again elsewhere (``retries``, and Dask's own rescheduling of
   lost tasks); progress is printed as frames complete.

Needs Dask's ``distributed`` package: ``pip install "./crates/octolux-py[dask]"`` (the ``dask``
extra). Workers need the ``octolux`` Python module and the scene files at the same path
(shared storage); no ``octolux`` binary is needed anywhere. A missing output folder is created,
as ``octolux render`` creates it. Frames are the unit: tiles of one image are not split.
"""
from __future__ import annotations

import argparse
import hashlib
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Callable, Dict, List, Mapping, Optional, Tuple

__all__ = ["render_frames"]

_NEEDS_DISTRIBUTED = (
    "octolux.dask needs Dask's `distributed` package, which is not installed: "
    "pip install \"./crates/octolux-py[dask]\" (from a checkout of octolux), or pip install distributed"
)


def _distributed() -> Any:
    """The ``distributed`` package, or an ImportError saying how to install it."""
    try:
        import distributed
    except ImportError as e:
        raise ImportError(_NEEDS_DISTRIBUTED) from e
    return distributed


def _bake_task(scene: str, defines: Mapping[str, Any], seed: int, bake: Mapping[str, Any]) -> bytes:
    import octolux

    with tempfile.TemporaryDirectory(prefix="octolux-bake-") as d:
        out = Path(d) / "lighting.oxc"
        octolux.bake(octolux.load_scene(scene, defines=defines), out, seed, **bake)
        return out.read_bytes()


def _cache_file(digest: str, data: bytes) -> Path:
    """The worker's copy of the cache with this SHA-256, written once (staged, renamed)."""
    folder = Path(tempfile.gettempdir()) / "octolux-caches"
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{digest}.oxc"
    if not path.exists():
        if hashlib.sha256(data).hexdigest() != digest:
            raise RuntimeError("the lighting cache arrived corrupted (SHA-256 mismatch)")
        staged = folder / f".{digest}.{os.getpid()}.tmp"
        staged.write_bytes(data)
        os.replace(staged, path)
    return path


def _frame_task(scene: str, digest: str, data: bytes, index: int, name: str, kwargs: Mapping[str, Any]) -> Dict[str, bytes]:
    import octolux

    cache = _cache_file(digest, data)
    with tempfile.TemporaryDirectory(prefix="octolux-frame-") as d:
        octolux.render_to_files(scene, Path(d) / name, cache=cache, frames=(index, index), **kwargs)
        return {p.name: p.read_bytes() for p in sorted(Path(d).iterdir())}


def _write_atomic(path: Path, data: bytes) -> None:
    staged = path.with_name(f".{path.name}.partial")
    staged.write_bytes(data)
    os.replace(staged, path)


def render_frames(
    client: Any,
    scene: str,
    output: str,
    *,
    camera_path: Optional[str] = None,
    sensors: bool = False,
    frames: Optional[Tuple[int, int]] = None,
    cache: Optional[str] = None,
    bake: Optional[Mapping[str, Any]] = None,
    seed: int = 0,
    spp: Optional[int] = None,
    resolution: Optional[Tuple[int, int]] = None,
    defines: Optional[Mapping[str, Any]] = None,
    render: Optional[Mapping[str, Any]] = None,
    retries: int = 3,
    progress: bool = True,
    on_frame: Optional[Callable[[int], None]] = None,
) -> List[Path]:
    """Render frames ``frames`` (first, last; default all) of ``camera_path`` (or of the
    scene's ``<sensor>``s with ``sensors=True``) on the Dask ``client``; returns the EXR paths.

    The lighting comes from ``cache`` (a file ``octolux bake`` wrote), else it is baked once on
    the cluster with ``bake``: keyword arguments of :func:`octolux.bake` (``photons``,
    ``settings``, ``settings_file``, ``max_depth``). ``render`` holds further keyword arguments
    of :func:`octolux.render_to_files` (``settings``, ``max_depth``, ``time_budget``, ...).
    ``on_frame(i)`` is called on the client as each frame's files are written.
    """
    import octolux

    as_completed = _distributed().as_completed
    if (camera_path is None) == (not sensors):
        raise ValueError("give exactly one of camera_path= or sensors=True")
    scene = os.path.abspath(scene) if os.path.exists(scene) else scene
    out = Path(output).resolve()
    # the CLI's rule for the output set, before any work: a missing folder is created (and
    # removed again, if still empty, when the job fails)
    octolux._octolux.check_output(str(out))
    try:
        defines = dict(defines or {})
        kwargs: Dict[str, Any] = {"seed": seed, "defines": defines, **dict(render or {})}
        if spp is not None:
            kwargs["spp"] = spp
        if resolution is not None:
            kwargs["resolution"] = tuple(resolution)
        if camera_path is not None:
            kwargs["camera_path"] = os.path.abspath(camera_path)
        else:
            kwargs["sensors"] = True
        defs = [(str(k), octolux._define_value(v)) for k, v in defines.items()]
        count = octolux._octolux.frame_count(scene, defs, kwargs.get("camera_path"), sensors)
        first, last = frames or (1, count)
        if not (1 <= first <= last <= count):
            raise ValueError(f"frames {first}..{last}: the animation has frames 1..{count}")

        t0 = time.monotonic()
        if cache is not None:
            data = Path(cache).read_bytes()
        else:
            data = client.submit(_bake_task, scene, defines, seed, dict(bake or {}), pure=False, retries=retries).result()
            if progress:
                print(f"octolux.dask: baked {len(data)} bytes in {time.monotonic() - t0:.1f} s", file=sys.stderr)
        digest = hashlib.sha256(data).hexdigest()
        shipped = client.scatter(data, broadcast=True, hash=False)
        tasks = {
            client.submit(
                _frame_task, scene, digest, shipped, i, out.name, kwargs, key=f"octolux-frame-{digest[:12]}-{seed}-{i}-{out.name}", retries=retries
            ): i
            for i in range(first, last + 1)
        }
        written: List[Path] = []
        done = 0
        for fut in as_completed(tasks):
            i = tasks[fut]
            files = fut.result()
            # named as one machine names them (OUT_0001.exr, .png, .json)
            exrs = [name for name in files if name.endswith(".exr")]
            if len(exrs) != 1:
                raise RuntimeError(f"frame {i}: the worker returned {sorted(files)}, not one EXR")
            for name, data in files.items():
                _write_atomic(out.parent / name, data)
            written.append(out.parent / exrs[0])
            done += 1
            if on_frame is not None:
                on_frame(i)
            if progress:
                print(f"octolux.dask: frame {i} done ({done}/{len(tasks)}, {time.monotonic() - t0:.1f} s)", file=sys.stderr)
        octolux._octolux.keep_created_folders()
        return sorted(written)
    except BaseException:
        octolux._octolux.remove_created_folders()
        raise


def _parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(
        prog="python -m octolux.dask",
        description="Render the frames of an animation on a Dask cluster: the lighting is baked once, each frame is one "
        "task, and the frames equal those of `octolux render --cache ... --camera-path ...` with the same seed.",
        epilog='Needs Dask\'s distributed package: pip install "./crates/octolux-py[dask]". More: docs/guide/python.md.',
    )
    ap.add_argument("scene", help="a built-in scene name or a scene file (at the same path on every worker)")
    ap.add_argument("-o", "--output", required=True, help="frame file pattern, e.g. frames/f.exr -> frames/f_0001.exr")
    ap.add_argument("--camera-path", help="camera path file (JSON or TOML keyframes)")
    ap.add_argument("--sensors", action="store_true", help="render every <sensor> of the scene file instead")
    ap.add_argument("--frames", help="render frames A..B only (from 1, both included)")
    ap.add_argument("--cache", help="a lighting cache baked already (default: bake one on the cluster)")
    ap.add_argument("--photons", type=int, help="photons of the bake (when no --cache)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the render and of the bake's photons")
    ap.add_argument("--spp", type=int, help="samples per pixel (default: the scene's, else 64)")
    ap.add_argument("--resolution", help="image size WxH (default: the scene's film)")
    ap.add_argument("-D", dest="define", action="append", default=[], metavar="NAME=VALUE", help="a Mitsuba <default> parameter")
    ap.add_argument("--scheduler", help="address of a Dask scheduler (default: a LocalCluster on this machine)")
    return ap


def main(argv: Optional[List[str]] = None) -> int:
    a = _parser().parse_args(argv)
    try:
        distributed = _distributed()
    except ImportError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    Client, LocalCluster = distributed.Client, distributed.LocalCluster
    client = Client(a.scheduler) if a.scheduler else Client(LocalCluster())
    frames = tuple(int(x) for x in a.frames.split("..")) if a.frames else None
    resolution = tuple(int(x) for x in a.resolution.lower().split("x")) if a.resolution else None
    render_frames(
        client,
        a.scene,
        a.output,
        camera_path=a.camera_path,
        sensors=a.sensors,
        frames=frames,  # type: ignore[arg-type]
        cache=a.cache,
        bake={"photons": a.photons} if a.photons else None,
        seed=a.seed,
        spp=a.spp,
        resolution=resolution,  # type: ignore[arg-type]
        defines=dict(d.split("=", 1) for d in a.define),
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
