"""What the splitting benches share (splitting_bound.py, split_gain.py): the path tracer run
once per seed as a subprocess, its render time, and the reference brought to the renders'
resolution. Images are read with the octolux Python module (`octolux.read_exr`).

OCTOLUX_BIN: the binary to run (default: the checkout's target/release/octolux).
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
BIN = Path(os.environ.get("OCTOLUX_BIN", ROOT / "target" / "release" / "octolux"))

try:
    import octolux  # noqa: F401  (the PyO3 module: read_exr)
except ImportError:  # pragma: no cover
    sys.exit("the splitting benches need the octolux Python module (pip install -e crates/octolux-py)")


def check_bin() -> None:
    if not BIN.exists():
        sys.exit(f"{BIN} missing: cargo build --release -p octolux-cli")


def render(scene: str, depth: int, spp: int, res: str, seed: int, out: Path, extra: list[str] = (),
           integrator: str = "path", binary: Path = BIN) -> float:
    """`integrator` (the path tracer by default) at `depth` (Mitsuba's max_depth), 2 threads;
    returns its render's CPU time (s, all threads: out.json's `timings.render_cpu_s`, a bake
    excluded; on a shared machine it moves far less than the wall clock), else its wall time
    (`render.render_s`) where the platform has no CPU clock."""
    cmd = [str(binary), "render", str(scene), "--integrator", integrator, "--spp", str(spp), "--resolution", res,
           "--max-depth", str(depth), "--seed", str(seed), "--threads", "2", "-q", "-o", str(out), *extra]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed: {p.stderr.strip()[-600:]}")
    stats = json.loads(out.with_suffix(".json").read_text())
    cpu = stats["timings"].get("render_cpu_s")
    return float(cpu if cpu is not None else stats["render"]["render_s"])


def read(path: Path) -> np.ndarray:
    return octolux.read_exr(str(path)).astype(np.float64)


def downsample(img: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    h, w = shape
    fy, fx = img.shape[0] // h, img.shape[1] // w
    return img[: h * fy, : w * fx].reshape(h, fy, w, fx, 3).mean(axis=(1, 3))


def relmse_weights(reference: str, shape: tuple[int, int]) -> np.ndarray:
    """Per pixel and channel, the relMSE's weight 1 / (r² + 0.01) of the reference (metrics.rs)."""
    ref = downsample(read(Path(reference)), shape)
    return 1.0 / (ref ** 2 + 1e-2)


def scene(name: str) -> dict | None:
    """The alias's entry (bench/scenes.json), or None, saying why, when its scene or reference is missing."""
    import scenes as aliases  # bench/scenes.json

    try:
        sc = aliases.get(name)
    except (KeyError, FileNotFoundError) as e:
        print(f"skipped {name}: {e}", file=sys.stderr)
        return None
    if not Path(sc["reference"]).exists() or (not sc.get("builtin") and not Path(sc["scene"]).exists()):
        print(f"skipped {name}: scene or reference missing", file=sys.stderr)
        return None
    return sc


def scenes_at(names: list[str], res: str):
    """(name, entry, relMSE weights at `res`, "WxH") of each scene that is at hand."""
    rw, rh = (int(v) for v in res.split("x"))
    for name in names:
        sc = scene(name)
        if sc is not None:
            yield name, sc, relmse_weights(sc["reference"], (rh, rw))
