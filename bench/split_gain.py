#!/usr/bin/env python3
"""What splitting at a path's first vertex gains, measured (issue 24, item 2; the path
tracer's `split` setting, integrators/pathloop.rs "Splitting").

For each scene and split factor k the path tracer renders S seeds at the same spp. Per pixel
and channel the variance over the seeds, weighted by the relMSE's 1/(r² + 0.01) (r: the
scene's reference, metrics.rs), estimates the expected relMSE of one render without any
reference noise; its render's CPU time (out.json `timings.render_cpu_s`, all threads, scene
loading excluded) is the cost. The efficiency gain of k over k = 1 is (V_1 T_1) / (V_k T_k). The variance of the
fireflies' pixels is itself noisy: the printed 90% interval comes from a bootstrap over the
seeds (both factors resampled together).

`--variant LABEL=ARGS` (repeatable) compares any renders instead, the first being the
baseline: ARGS are the octolux options, `integrator=NAME` picks the integrator and `bin=PATH`
the binary (another build, for a before/after comparison), e.g.
`--variant before="integrator=octree bin=target/octolux-before --set mode=unbiased"` (a
relative `bin` is taken from the repository root).

Usage: .venv-py/bin/python bench/split_gain.py [--scenes classroom sponza ...] [--splits 1 2 4 8]
       [--variant LABEL=ARGS ...] [--seeds 24] [--spp 4] [--res 160x90]
"""
from __future__ import annotations

import argparse
import shlex
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from machine import cpu_line  # noqa: E402
from seed_renders import BIN, ROOT, check_bin, read, render, scenes_at  # noqa: E402


def variants(a: argparse.Namespace) -> list[tuple[str, str, Path, list[str]]]:
    """(label, integrator, binary, options) of each variant, the baseline first."""
    if not a.variant:
        return [(f"k={k}", "path", BIN, ["--set", f"split={k}"]) for k in a.splits]
    out = []
    for v in a.variant:
        label, _, args = v.partition("=")
        integrator, binary, opts = "path", BIN, []
        for t in shlex.split(args):
            if t.startswith("integrator="):
                integrator = t.split("=", 1)[1]
            elif t.startswith("bin="):
                binary = ROOT / t.split("=", 1)[1]  # an absolute PATH stays as it is
            else:
                opts.append(t)
        out.append((label, integrator, binary, opts))
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", nargs="+", default=["classroom", "dining-room", "sponza", "veach-lamp"])
    ap.add_argument("--splits", nargs="+", type=int, default=[1, 2, 4, 8])
    ap.add_argument("--seeds", type=int, default=24)
    ap.add_argument("--spp", type=int, default=4)
    ap.add_argument("--res", default="160x90")
    ap.add_argument("--variant", action="append", default=[], help="LABEL=ARGS (module docs)")
    a = ap.parse_args()
    check_bin()
    if a.splits[0] != 1:
        a.splits.insert(0, 1)
    vs = variants(a)
    print(cpu_line())
    print(f"{a.seeds} seeds x {a.spp} spp at {a.res}, 2 threads; baseline {vs[0][0]}")
    print("| scene | " + " | ".join(f"{v[0]}: time, gain [90%]" for v in vs[1:]) + " |")
    print("|---" * len(vs) + "|")
    rng = np.random.default_rng(1)
    with tempfile.TemporaryDirectory() as tmp:
        for name, sc, wgt in scenes_at(a.scenes, a.res):
            per_k = {}
            for k, (label, integrator, binary, opts) in enumerate(vs):
                imgs, times = [], []
                for s in range(a.seeds):
                    out = Path(tmp) / f"{name}-{k}-{s}.exr"
                    times.append(render(sc["scene"], sc["max_depth"], a.spp, a.res, 1000 + s, out, opts, integrator, binary))
                    imgs.append(read(out))
                per_k[k] = (np.stack(imgs), np.array(times))
                print(f"  {name} {label}: {np.mean(times):.3f} CPU s per render", file=sys.stderr, flush=True)

            def eff(k: int, idx: np.ndarray) -> float:
                x, t = per_k[k]
                v = (x[idx].var(axis=0, ddof=1) * wgt).mean()
                return 1.0 / (v * t[idx].mean())

            every = np.arange(a.seeds)
            cells = []
            for k in range(1, len(vs)):
                gain = eff(k, every) / eff(0, every)
                boot = []
                for _ in range(400):
                    i = rng.integers(0, a.seeds, a.seeds)
                    j = rng.integers(0, a.seeds, a.seeds)
                    boot.append(eff(k, i) / eff(0, j))
                lo, hi = np.percentile(boot, [5, 95])
                t_ratio = per_k[k][1].mean() / per_k[0][1].mean()
                cells.append(f"{t_ratio:.2f}x, {gain:.2f}x [{lo:.2f}, {hi:.2f}]")
            print(f"| {name} | " + " | ".join(cells) + " |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
