#!/usr/bin/env python3
"""How much could splitting at a path's first vertex gain, with a perfect guide? (issue 24, item 2)

Splitting a path at its first vertex into k continuations (ADRRS, EARS, or a cache's estimate of
the incident light choosing k) divides the continuation's variance by k and multiplies its cost
by k. With a per-pixel oracle that knows each pixel's variances, this script computes the best
any such rule can do, so that a cache-driven rule can be judged against it before it is built.

For each scene and seed the path tracer renders the image twice with the same random numbers:
at full depth (X) and stopped after the first vertex's light sample and BSDF ray
(`--max-depth 2`, X0). The continuation is X1 = X - X0. Over S seeds, per pixel and channel,
each divided by the reference's r² + 0.01 (the relMSE's weights, `metrics.rs`):

- V0 = var(X0), V1 = var(X1), C = cov(X0, X1);
- with k continuations the pixel's variance is V0 + 2C + V1 / k (each continuation has the
  same covariance with X0; they are independent given the first vertex);
- the cost per sample is T0 + k T1, with T0 the `--max-depth 2` render time and T1 the rest
  (uniform over pixels: the oracle's gain is then an upper bound only in its variance part).

Printed per scene: T0/T1, the continuation's share of the variance, the best uniform k and its
gain in efficiency (1 / (relMSE x time)) over k = 1, and the per-pixel oracle's (k_p from
Lagrange: k_p = sqrt(T0 · V1_p / (T1 · W0)) with W0 = mean(V0 + 2C); k_p may be below 1: Russian roulette at the first vertex). k may be fractional: the
gain of a rule that rounds it stochastically.

Usage: .venv-py/bin/python bench/splitting_bound.py [--scenes dining-room classroom ...]
       [--seeds 16] [--spp 4] [--res 160x90]
"""
from __future__ import annotations

import argparse
import math
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from seed_renders import check_bin, read, render, scenes_at  # noqa: E402





def moments(x0: np.ndarray, x1: np.ndarray, wgt: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per pixel and channel, weighted: var(X0), cov(X0, X1), var(X1) over the seeds (axis 0)."""
    n = x0.shape[0]
    c = ((x0 - x0.mean(0)) * (x1 - x1.mean(0))).sum(0) / (n - 1)
    return x0.var(axis=0, ddof=1) * wgt, c * wgt, x1.var(axis=0, ddof=1) * wgt


def cost(k: np.ndarray, m: tuple, t0: float, t1: float) -> float:
    """relMSE x time (up to constants) with k_p continuations in pixel p, under moments m."""
    v0, c, v1 = m
    return float((v0 + 2 * c + v1 / k).mean() * (t0 + t1 * k.mean()))


def efficiency_gain(fit: tuple, test: tuple, t0: float, t1: float) -> dict:
    """The best uniform k and the per-pixel oracle, both chosen on the moments `fit` and judged on
    the independent `test` (seeds not used to choose: no credit for noise in the estimates)."""
    v0, c, v1 = fit
    one = np.ones_like(v1)
    base = cost(one, test, t0, t1)
    w0 = max(float((v0 + 2 * c).mean()), 1e-30)
    # uniform k minimising (W0 + mean V1 / k)(T0 + T1 k)
    k_uni = math.sqrt(max(float(v1.mean()), 0.0) * t0 / (w0 * t1)) or 1.0
    # per pixel: minimise (W0 + mean V1_p / k_p)(T0 + T1 mean k_p). Its stationary point has
    # k_p = lam sqrt(V1_p), and then (W0 + ms / lam)(T0 + T1 lam ms), ms = mean sqrt(V1_p), is
    # least at lam = sqrt(T0 / (W0 T1)).
    lam = math.sqrt(t0 / (w0 * t1))
    k = np.clip(lam * np.sqrt(np.maximum(v1, 0.0)), 1e-2, None)
    return {"k_uniform": k_uni, "gain_uniform": base / cost(one * k_uni, test, t0, t1),
            "gain_oracle": base / cost(k, test, t0, t1),
            "k_oracle": (float(np.percentile(k, 10)), float(np.median(k)), float(np.percentile(k, 90)))}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", nargs="+", default=["dining-room", "classroom", "sponza", "veach-lamp"])
    ap.add_argument("--seeds", type=int, default=16)
    ap.add_argument("--spp", type=int, default=4)
    ap.add_argument("--res", default="160x90")
    a = ap.parse_args()
    check_bin()
    print("| scene | T0/T1 | continuation's share of variance | best uniform k | its gain | oracle k_p (10/50/90%) | oracle gain |")
    print("|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for name, sc, wgt in scenes_at(a.scenes, a.res):
            xs, x0s, t_full, t_first = [], [], 0.0, 0.0
            for seed in range(1, a.seeds + 1):
                f, g = Path(tmp) / f"{name}_{seed}_full.exr", Path(tmp) / f"{name}_{seed}_first.exr"
                t_full += render(sc["scene"], sc["max_depth"], a.spp, a.res, seed, f)
                t_first += render(sc["scene"], 2, a.spp, a.res, seed, g)
                xs.append(read(f))
                x0s.append(read(g))
            x, x0 = np.stack(xs), np.stack(x0s)
            x1 = x - x0
            h = a.seeds // 2
            halves = [moments(x0[:h], x1[:h], wgt), moments(x0[h:], x1[h:], wgt)]
            t0, t1 = t_first, max(t_full - t_first, 1e-9)
            rs = [efficiency_gain(halves[0], halves[1], t0, t1), efficiency_gain(halves[1], halves[0], t0, t1)]
            r = {key: (sum(q[key] for q in rs) / 2 if key != "k_oracle" else rs[0][key]) for key in rs[0]}
            v0, c, v1 = moments(x0, x1, wgt)
            share = v1.mean() / (v0 + 2 * c + v1).mean()
            ko = r["k_oracle"]
            print(f"| {name} | {t0 / t1:.2f} | {share:.0%} | {r['k_uniform']:.2f} | {r['gain_uniform']:.3f}x | "
                  f"{ko[0]:.2f} / {ko[1]:.2f} / {ko[2]:.2f} | {r['gain_oracle']:.3f}x |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
