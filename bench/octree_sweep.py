#!/usr/bin/env python3
"""Settings sweep of the `octree` integrator: one render per scene and variant at a fixed photon
count and spp, against the time-to-error references; prints relMSE, the render's CPU time, their
product (relMSE x CPU: lower is better when the error is noise) and the brightest pixel against
the reference's.

    python3 bench/octree_sweep.py --scenes torus box --photons 1000000 --spp 16 \\
        --variant base= --variant paper=mode=paper --variant k2=footprint=2
    python3 bench/octree_sweep.py --scenes cornell-box --variant path:        # `path:` = --integrator path

A variant is NAME=KEY=VALUE[,KEY=VALUE...] (octree `--set` keys; NAME= alone: the defaults), or
NAME: for octolux `path`. Scenes and references as bench/time_to_error.py takes them
(tests/refs/tte/ where it has the scene, else tests/refs/collection/ or tests/refs/). Cost is the
child's CPU time (user + system), photon pass and build included. Writes target/sweep/<tag>.json.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import time_to_error as tte  # noqa: E402

ROOT = tte.ROOT
BIN = tte.BIN
OUT = ROOT / "target" / "sweep"


def child_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def run(sc: dict, variant: str, photons: int, spp: int, out: Path, seed: int) -> dict:
    name, _, keys = variant.partition("=")
    path = variant.endswith(":") and "=" not in variant
    w, h = sc["res"]
    cmd = [str(BIN), "render", sc["scene"], "--integrator", "path" if path else "octree", "--spp", str(spp),
           "--resolution", f"{w}x{h}", "--max-depth", str(sc["depth"]), "--seed", str(seed), "-q", "-o", str(out)]
    if not path:
        cmd += ["--photons", str(photons)]
        for kv in filter(None, keys.split(",")):
            cmd += ["--set", kv]
    c0, t0 = child_cpu(), time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True)
    cpu, wall = child_cpu() - c0, time.perf_counter() - t0
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}: {p.stderr.strip()[-600:]}")
    err = tte.compare(out, sc["ref"])
    stats = json.loads(out.with_suffix(".json").read_text())
    ends = stats.get("render", {}).get("counters", {}).get("cache_ends")
    import numpy as np  # only for the brightest pixel
    sys.path.insert(0, str(ROOT / "tools" / "mitsuba"))
    import compare as mc  # noqa: E402
    img, ref = mc.read_exr(str(out)), mc.read_exr(sc["ref"])
    return {"variant": name.rstrip(":"), "cpu_s": cpu, "wall_s": wall, "rel_mse": err["rel_mse"],
            "error": err["rel_mse"] - sc["ref_noise"], "max": float(np.max(img)), "ref_max": float(np.max(ref)),
            "mean_ratio": err.get("mean_ratio"), "cache_ends": ends}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", nargs="+", required=True)
    ap.add_argument("--variant", action="append", required=True)
    ap.add_argument("--photons", type=int, default=1_000_000)
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--seed", type=int, default=tte.SEED)
    ap.add_argument("--tag", default="sweep")
    args = ap.parse_args()
    scenes = tte.scenes()
    OUT.mkdir(parents=True, exist_ok=True)
    rows = []
    print(f"{'scene':12} {'variant':14} {'relMSE':>10} {'error':>10} {'CPU s':>8} {'rel x CPU':>10} {'max/refmax':>10}  ends")
    for name in args.scenes:
        sc = scenes[name]
        for v in args.variant:
            out = OUT / f"{args.tag}-{name}-{v.split('=')[0].rstrip(':')}.exr"
            r = run(sc, v, args.photons, args.spp, out, args.seed)
            r["scene"] = name
            rows.append(r)
            print(f"{name:12} {r['variant']:14} {r['rel_mse']:10.4g} {r['error']:10.4g} {r['cpu_s']:8.2f} "
                  f"{r['rel_mse'] * r['cpu_s']:10.4g} {r['max'] / max(r['ref_max'], 1e-9):10.3g}  {r['cache_ends']}",
                  flush=True)
    (OUT / f"{args.tag}.json").write_text(json.dumps({"photons": args.photons, "spp": args.spp, "rows": rows}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
