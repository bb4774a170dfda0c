"""Render the frames of an animation on a Dask cluster (issue 15, item 2).

    from distributed import Client
    from octolux.dask import render_frames
    client = Client("tcp://scheduler:8786")          # or LocalCluster() for one machine
    render_frames(client, "scene.xml", "frames/f.exr", camera_path="path.json",
                  bake={"photons": 2_000_000}, spp=64, seed=1)

or from a shell: ``python -m octolux.dask scene.xml -o frames/f.exr --camera-path path.json
--scheduler tcp://scheduler:8786 --photons 2000000 --spp 64``.

How a job runs:
1. The lighting is baked once (``octolux bake``, as one task on a worker), unless ``cache``
   names a file baked already. Its bytes are broadcast to the workers and named by their
   SHA-256: a worker writes them once to ``<tmp>/octolux-caches/<sha256>.oxc`` and every later
   task (of this job or another) with the same hash reuses that file.
2. Each frame is one task: ``octolux render SCENE --cache FILE --frames i..i --seed S ...`` in a
   private folder on the worker, whose output files (``f_0001.exr``, ``.png``, ``.json``) return
   to the client as bytes. The client writes them under the names one machine would write,
   each staged and renamed.
3. A frame's image depends only on the cache, its camera and the seed (docs/baking.md), so the
   EXR and PNG files are bit-identical to a single-machine ``octolux render --cache ...
   --camera-path ...`` with the same seed; the JSON's timings and command line differ.
4. A task whose worker dies is run again elsewhere (``retries``, and Dask's own rescheduling of
   lost tasks); progress is printed as frames complete.

Workers need the ``octolux`` binary (``octolux_bin``, else ``$OCTOLUX_BIN``, else ``octolux``
on their ``PATH``) and the scene files at the same path (shared storage). Frames are the unit:
tiles of one image are not split (the CLI renders whole images).
"""
from __future__ import annotations

import argparse
import hashlib
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence, Tuple

__all__ = ["render_frames"]


def _bin(octolux_bin: Optional[str]) -> str:
    b = octolux_bin or os.environ.get("OCTOLUX_BIN") or shutil.which("octolux")
    if not b:
        raise RuntimeError("no octolux binary: pass octolux_bin=, set OCTOLUX_BIN, or put `octolux` on the PATH")
    return b


def _run(cmd: Sequence[str]) -> None:
    p = subprocess.run(list(cmd), capture_output=True, text=True)
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed ({p.returncode}):\n{p.stderr.strip()}")


def _bake_task(bin_: str, scene: str, args: Sequence[str]) -> bytes:
    with tempfile.TemporaryDirectory(prefix="octolux-bake-") as d:
        out = Path(d) / "lighting.oxc"
        _run([bin_, "bake", scene, "-o", str(out), "-q", *args])
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


def _frame_task(bin_: str, scene: str, digest: str, data: bytes, index: int, name: str, args: Sequence[str]) -> Dict[str, bytes]:
    cache = _cache_file(digest, data)
    with tempfile.TemporaryDirectory(prefix="octolux-frame-") as d:
        _run([bin_, "render", scene, "--cache", str(cache), "--frames", f"{index}..{index}", "-o", str(Path(d) / name), "-q", *args])
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
    render_args: Sequence[str] = (),
    octolux_bin: Optional[str] = None,
    retries: int = 3,
    progress: bool = True,
    on_frame: Optional[Callable[[int], None]] = None,
) -> List[Path]:
    """Render frames ``frames`` (first, last; default all) of ``camera_path`` (or of the
    scene's ``<sensor>``s with ``sensors=True``) on the Dask ``client``; returns the EXR paths.

    The lighting comes from ``cache`` (a file ``octolux bake`` wrote), else it is baked once on
    the cluster with ``bake`` (``{"photons": N, "settings": FILE, "set": ["KEY=VALUE", ...]}``).
    ``render_args`` are further ``octolux render`` arguments (``--resolution``, ``-D``, ...).
    ``on_frame(i)`` is called on the client as each frame's files are written.
    """
    from distributed import as_completed

    if (camera_path is None) == (not sensors):
        raise ValueError("give exactly one of camera_path= or sensors=True")
    bin_ = _bin(octolux_bin)
    scene = os.path.abspath(scene) if os.path.exists(scene) else scene
    out = Path(output).resolve()
    out.parent.mkdir(parents=True, exist_ok=True)
    common = ["--seed", str(seed), *render_args]
    if spp is not None:
        common += ["--spp", str(spp)]
    if camera_path is not None:
        common += ["--camera-path", os.path.abspath(camera_path)]
    else:
        common += ["--sensors"]
    count = _frame_count(bin_, scene, common)
    first, last = frames or (1, count)
    if not (1 <= first <= last <= count):
        raise ValueError(f"frames {first}..{last}: the animation has frames 1..{count}")

    t0 = time.monotonic()
    if cache is not None:
        data = Path(cache).read_bytes()
    else:
        bake_args = ["--seed", str(seed)]
        for k, v in (bake or {}).items():
            if k == "set":
                for s in v:
                    bake_args += ["--set", s]
            else:
                bake_args += [f"--{k.replace('_', '-')}", str(v)]
        data = client.submit(_bake_task, bin_, scene, bake_args, pure=False, retries=retries).result()
        if progress:
            print(f"octolux.dask: baked {len(data)} bytes in {time.monotonic() - t0:.1f} s", file=sys.stderr)
    digest = hashlib.sha256(data).hexdigest()
    shipped = client.scatter(data, broadcast=True, hash=False)
    tasks = {
        client.submit(
            _frame_task, bin_, scene, digest, shipped, i, out.name, common, key=f"octolux-frame-{digest[:12]}-{seed}-{i}-{out.name}", retries=retries
        ): i
        for i in range(first, last + 1)
    }
    written: List[Path] = []
    done = 0
    for fut in as_completed(tasks):
        i = tasks[fut]
        files = fut.result()
        # the CLI named them as one machine does (OUT_0001.exr, .png, .json)
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
    return sorted(written)


def _frame_count(bin_: str, scene: str, common: Sequence[str]) -> int:
    """The animation's frame count, as the CLI counts it: asked for more frames than any
    animation has, it refuses, saying how many there are (after loading the scene)."""
    with tempfile.TemporaryDirectory(prefix="octolux-count-") as d:
        cmd = [bin_, "render", scene, *common, "--frames", f"1..{2**63}", "-q", "-o", str(Path(d) / "count.exr")]
        p = subprocess.run(cmd, capture_output=True, text=True)
    m = re.search(r"makes (\d+) frames", p.stderr)
    if not m:
        raise RuntimeError(f"cannot count the frames of {scene}: {p.stderr.strip()}")
    return int(m.group(1))


def main(argv: Optional[Sequence[str]] = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m octolux.dask", description=__doc__.split("\n\n")[0])
    ap.add_argument("scene")
    ap.add_argument("-o", "--output", required=True, help="frame file pattern, e.g. frames/f.exr -> frames/f_0001.exr")
    ap.add_argument("--camera-path")
    ap.add_argument("--sensors", action="store_true")
    ap.add_argument("--frames", help="A..B (both included)")
    ap.add_argument("--cache", help="a lighting cache baked already")
    ap.add_argument("--photons", type=int, help="photons of the bake (when no --cache)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--spp", type=int)
    ap.add_argument("--scheduler", help="address of a Dask scheduler (default: a LocalCluster on this machine)")
    ap.add_argument("--octolux-bin")
    a, rest = ap.parse_known_args(argv)
    from distributed import Client, LocalCluster

    client = Client(a.scheduler) if a.scheduler else Client(LocalCluster())
    frames = tuple(int(x) for x in a.frames.split("..")) if a.frames else None
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
        render_args=rest,
        octolux_bin=a.octolux_bin,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
