#!/usr/bin/env python3
"""Time to reach a given relMSE: `octree` versus `path`, cache build counted (issue 3, item 10).

For each scene with a committed Mitsuba 3 reference (tests/refs/<scene>.exr, 128x128), renders a
ladder of sample counts with both integrators, measures wall time (octree: photon tracing + octree
build + render; taken from the stats JSON) and relMSE against the reference, interpolates each
curve log-log at the target relMSE and prints the speed-up path_time / octree_time from this one run.

Usage: bench/time_to_error.py [--targets 1e-2 5e-3 2e-3] [--scenes cornell-box cornell-spheres] [--photons 1000000]
Needs: cargo build --release -p octolux-cli (the script builds it if missing).
"""
from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BIN = ROOT / "target" / "release" / "octolux"


def run(scene: str, integrator: str, spp: int, photons: int, max_depth: int, out: Path) -> tuple[float, float, dict]:
    cmd = [str(BIN), "render", scene, "--integrator", integrator, "--spp", str(spp), "--resolution", "128x128",
           "--max-depth", str(max_depth), "--seed", "7", "-q", "-o", str(out)]
    if integrator == "octree":
        cmd += ["--photons", str(photons)]
    subprocess.run(cmd, check=True)
    stats = json.loads(out.with_suffix(".json").read_text())
    t = stats["timings"]["render_s"] + (stats["build"]["t_c_s"] if stats.get("build") else 0.0)
    ref = ROOT / "tests" / "refs" / f"{scene}.exr"
    err = json.loads(subprocess.run([str(BIN), "compare", str(out), str(ref)], check=True, capture_output=True, text=True).stdout)
    return t, err["rel_mse"], stats


def time_at(points: list[tuple[float, float]], target: float) -> float | None:
    """Log-log interpolation of time at which relMSE falls to `target` (points sorted by time)."""
    for (t0, e0), (t1, e1) in zip(points, points[1:]):
        if e0 >= target >= e1 and e0 > 0 and e1 > 0 and e0 != e1:
            a = (math.log(target) - math.log(e0)) / (math.log(e1) - math.log(e0))
            return math.exp(math.log(t0) + a * (math.log(t1) - math.log(t0)))
    if points and points[0][1] <= target:
        return points[0][0]
    return None


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--targets", type=float, nargs="+", default=[1e-2, 5e-3, 2e-3])
    ap.add_argument("--scenes", nargs="+", default=["cornell-box", "cornell-spheres"])
    ap.add_argument("--photons", type=int, default=1_000_000)
    args = ap.parse_args()
    if not BIN.exists():
        subprocess.run(["cargo", "build", "--release", "-p", "octolux-cli"], cwd=ROOT, check=True)
    manifest = json.loads((ROOT / "tests" / "refs" / "manifest.json").read_text())["references"]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for scene in args.scenes:
            if scene not in manifest:
                print(f"{scene}: no reference in tests/refs/manifest.json, skipped", file=sys.stderr)
                continue
            max_depth = int(manifest[scene]["max_depth"])
            curves = {}
            for integ, ladder in (("path", [4, 8, 16, 32, 64, 128, 256, 512, 1024]), ("octree", [1, 2, 4, 8, 16, 32, 64])):
                pts = []
                for spp in ladder:
                    t, e, _ = run(scene, integ, spp, args.photons, max_depth, Path(tmp) / f"{scene}-{integ}-{spp}.exr")
                    pts.append((t, e))
                    print(f"{scene:16} {integ:7} spp {spp:5}  time {t:8.3f} s  relMSE {e:.3e}", file=sys.stderr)
                    if e < min(args.targets) / 4:
                        break
                curves[integ] = pts
            for target in args.targets:
                tp, to = time_at(curves["path"], target), time_at(curves["octree"], target)
                rows.append((scene, target, tp, to, min(e for _, e in curves["octree"])))
    print("\nTime to a relMSE target (128x128, vs Mitsuba 3 reference; octree includes photon tracing and build)\n")
    print("| scene | target relMSE | path (s) | octree (s) | speed-up | octree's lowest relMSE |")
    print("|---|---|---|---|---|---|")
    for scene, target, tp, to, floor in rows:
        f = lambda v: "not reached" if v is None else f"{v:.2f}"
        ratio = f"{tp / to:.1f}x" if tp and to else "n/a"
        print(f"| {scene} | {target:g} | {f(tp)} | {f(to)} | {ratio} | {floor:.2e} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
