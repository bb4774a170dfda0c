"""An object inserted into baked lighting, measured (issue 13, item 5; docs/guide/baking.md
"Inserted objects").

Bakes the built-in Cornell box, then renders a ball (ball.obj) moving along path.json (8 frames)
- from the cache with the octree integrator (`--insert`): re-baked per frame (the default,
  `--insert-light rebake`: the photon paths the ball meets are traced again), and reading the
  baked volume (`--insert-light volume`) with and without the ambient-occlusion correction
  (`--insert-ao`),
- with the path tracer, the ball present (the truth), and once without the ball,
and reports, on the ball's pixels (listed by each frame's OUT.json) and on the pixels the ball
changes in the scene (its shadow and reflections: where the truths with and without it differ by
more than 10%, the ball's pixels excluded):
- relMSE (mean of (a - r)^2 / (r^2 + 1e-2) over the pixels and channels),
- the bias of the mean (mean a / mean r - 1),
- flicker: the RMS over consecutive frames of the change of the per-frame bias (the error
  moving from one frame to the next; a steady error does not flicker),
and the time of each frame's re-bake (out.json `insert.rebake`) against the bake's photons and
octrees (its report's `t_c_s`), and writes the strip docs/img/insert-strip-rebake.png (top: octolux
re-baked from the cache; bottom: truth).

Reads EXR through Mitsuba 3's Python module (the one tools/mitsuba/ uses), else through
octolux's own (`.venv-py`, then without the strip):
    python bench/insert/measure.py [--bin target/release/octolux] [--spp 64] [--truth-spp 1024]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
HERE = Path(__file__).resolve().parent


def run(cmd: list[str]) -> float:
    t = time.time()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.time() - t


def read(path: Path):
    try:
        import mitsuba as mi
    except ImportError:  # octolux's own Python module reads EXR too (.venv-py)
        import octolux

        return np.asarray(octolux.read_exr(path), dtype=np.float64)[..., :3]
    return np.array(mi.Bitmap(str(path)), dtype=np.float64)[..., :3]


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", default=str(ROOT / "target" / "release" / "octolux"))
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--truth-spp", type=int, default=1024)
    ap.add_argument("--resolution", default="96x96")
    ap.add_argument("--photons", type=int, default=1_000_000)
    ap.add_argument("--ao-rays", type=int, default=16)
    ap.add_argument("--strip", default=str(ROOT / "docs" / "img" / "insert-strip-rebake.png"))
    ap.add_argument("--keep", help="folder for the renders (default: a temporary one)")
    ap.add_argument("--reuse-truth", action="store_true", help="keep the path-traced renders already in --keep")
    a = ap.parse_args()
    try:
        import mitsuba as mi

        mi.set_variant("scalar_rgb")
    except ImportError:
        mi = None
        print("no mitsuba module: EXR read by octolux's, no strip written", file=sys.stderr)
    tmp = Path(a.keep) if a.keep else Path(tempfile.mkdtemp(prefix="octolux-insert-"))
    tmp.mkdir(parents=True, exist_ok=True)
    obj, path = str(HERE / "ball.obj"), str(HERE / "path.json")
    common = ["render", "cornell-box", "--resolution", a.resolution, "--quiet"]
    ins = ["--insert", obj, "--insert-path", path]
    # --volume: the volumetric solution (the free-space tree) the volume light reads
    t_bake = run([a.bin, "bake", "cornell-box", "-o", str(tmp / "l.oxc"), "--photons", str(a.photons), "--volume", "--quiet"])
    t_reb = run([a.bin, *common, "--cache", str(tmp / "l.oxc"), *ins, "--spp", str(a.spp), "-o", str(tmp / "reb.exr")])
    vol = [*ins, "--insert-light", "volume"]
    t_oct = run([a.bin, *common, "--cache", str(tmp / "l.oxc"), *vol, "--spp", str(a.spp), "-o", str(tmp / "oct.exr")])
    t_ao = run([a.bin, *common, "--cache", str(tmp / "l.oxc"), *vol, "--insert-ao", str(a.ao_rays), "--spp", str(a.spp), "-o", str(tmp / "ao.exr")])
    t_pt = None
    if not (a.reuse_truth and (tmp / "base.exr").exists()):
        t_pt = run([a.bin, *common, "--integrator", "path", *ins, "--spp", str(a.truth_spp), "-o", str(tmp / "pt.exr")])
        run([a.bin, *common, "--integrator", "path", "--spp", str(a.truth_spp), "-o", str(tmp / "base.exr")])
    frames = sorted(p.name[len("pt_") : -len(".exr")] for p in tmp.glob("pt_*.exr"))
    base = read(tmp / "base.exr")
    h, w = base.shape[:2]
    rows = {k: [] for k in ("reb", "oct", "ao")}
    for f in frames:
        info = json.loads((tmp / f"pt_{f}.json").read_text())["insert"]
        obj_mask = np.zeros(h * w, bool)
        obj_mask[np.array(info["pixels"], dtype=np.int64)] = True
        obj_mask = obj_mask.reshape(h, w)
        truth = read(tmp / f"pt_{f}.exr")
        near = (np.abs(truth - base).mean(-1) > 0.1 * (base.mean(-1) + 1e-3)) & ~obj_mask
        for k in rows:
            img = read(tmp / f"{k}_{f}.exr")
            row = {}
            for name, m in (("object", obj_mask), ("near", near)):
                x, r = img[m], truth[m]
                row[name] = {
                    "pixels": int(m.sum()),
                    "relmse": float(((x - r) ** 2 / (r**2 + 1e-2)).mean()) if m.any() else 0.0,
                    "bias": float(x.mean() / r.mean() - 1.0) if m.any() else 0.0,
                }
            row["object"]["frame_bias"] = row["object"]["bias"]
            rows[k].append(row)
    t_c = json.loads((tmp / "l.json").read_text())["build"]["t_c_s"]
    rebake = [json.loads((tmp / f"reb_{f}.json").read_text())["insert"]["rebake"] for f in frames]
    out = {
        "frames": len(frames),
        "times_s": {"bake": t_bake, "rebake_frames": t_reb, "volume_frames": t_oct, "volume_ao_frames": t_ao, "path_frames": t_pt},
        "bake_photons_and_octrees_s": t_c,
        "rebake_per_frame": {
            "t_s": [round(r["t_s"], 4) for r in rebake],
            "over_bake": [round(r["t_s"] / t_c, 3) for r in rebake],
            "paths_retraced": [r["paths_retraced"] for r in rebake],
            "photons_moved": [r["photons_moved"] for r in rebake],
            "leaves_estimated": [r["leaves_estimated"] for r in rebake],
        },
    }
    for k, rs in rows.items():
        for name in ("object", "near"):
            bias = np.array([r[name]["bias"] for r in rs])
            out[f"{k}.{name}"] = {
                "relmse_mean": float(np.mean([r[name]["relmse"] for r in rs])),
                "bias_mean": float(bias.mean()),
                "bias_range": [float(bias.min()), float(bias.max())],
                "flicker": float(np.sqrt(np.mean(np.diff(bias) ** 2))) if len(bias) > 1 else 0.0,
                "pixels_mean": float(np.mean([r[name]["pixels"] for r in rs])),
                "bias_per_frame": [round(float(b), 4) for b in bias],
            }
    print(json.dumps(out, indent=1))
    if mi is None:
        return 0
    # the strip: every other frame, octolux (top) over the truth (bottom), sRGB 8-bit
    pick = frames[:: max(1, len(frames) // 4)][:4]
    top = np.concatenate([read(tmp / f"reb_{f}.exr") for f in pick], axis=1)
    bottom = np.concatenate([read(tmp / f"pt_{f}.exr") for f in pick], axis=1)
    strip = np.concatenate([top, np.ones((2, top.shape[1], 3)), bottom], axis=0)
    mi.util.write_bitmap(a.strip, mi.Bitmap(strip.astype(np.float32)), write_async=False)
    print(f"strip: {a.strip} (frames {', '.join(pick)}; renders in {tmp})", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
