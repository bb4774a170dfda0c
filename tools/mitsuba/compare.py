#!/usr/bin/env python3
"""Compare two RGB EXR images: `compare.py test.exr reference.exr [--json]`.

Prints the mean per channel of both images, and
  relMSE = mean over pixels and channels of (a-b)^2 / (b^2 + 1e-2)   (b = second image, the reference)
  RMSE   = sqrt(mean over pixels and channels of (a-b)^2)
Only the first three channels are used. Reads EXRs with Mitsuba's Bitmap (run it with the
.venv-mitsuba interpreter; see tools/mitsuba/setup.sh).
"""
from __future__ import annotations

import argparse
import json
import sys

import numpy as np

REL_EPS = 1e-2


def read_exr(path: str) -> np.ndarray:
    import mitsuba as mi
    if mi.variant() is None:
        mi.set_variant("scalar_rgb")
    bmp = mi.Bitmap(path)
    a = np.array(bmp, dtype=np.float64)
    if a.ndim == 2:
        a = a[..., None].repeat(3, axis=2)
    if a.shape[2] == 1:
        a = a.repeat(3, axis=2)
    return a[..., :3]


def rel_mse(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.mean((a - b) ** 2 / (b * b + REL_EPS)))


def rmse(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean((a - b) ** 2)))


def compare(a: np.ndarray, b: np.ndarray) -> dict:
    if a.shape != b.shape:
        raise SystemExit(f"shape mismatch: {a.shape} vs {b.shape}")
    return {
        "shape": list(a.shape),
        "mean_a": [float(x) for x in a.reshape(-1, 3).mean(axis=0)],
        "mean_b": [float(x) for x in b.reshape(-1, 3).mean(axis=0)],
        "rel_mse": rel_mse(a, b),
        "rmse": rmse(a, b),
        "max_abs_diff": float(np.max(np.abs(a - b))),
        "finite_a": bool(np.isfinite(a).all()),
        "finite_b": bool(np.isfinite(b).all()),
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("a", help="image under test")
    ap.add_argument("b", help="reference image")
    ap.add_argument("--json", action="store_true", help="print one JSON object instead of text")
    args = ap.parse_args(argv)
    r = compare(read_exr(args.a), read_exr(args.b))
    if args.json:
        print(json.dumps(r))
        return 0
    fmt = lambda v: " ".join(f"{x:.6f}" for x in v)
    print(f"size      : {r['shape'][1]}x{r['shape'][0]}")
    print(f"mean a    : {fmt(r['mean_a'])}   ({args.a})")
    print(f"mean b    : {fmt(r['mean_b'])}   ({args.b})")
    print(f"relMSE    : {r['rel_mse']:.6e}")
    print(f"RMSE      : {r['rmse']:.6e}")
    print(f"max |a-b| : {r['max_abs_diff']:.6e}")
    if not (r["finite_a"] and r["finite_b"]):
        print("WARNING: non-finite values present")
    return 0


if __name__ == "__main__":
    sys.exit(main())
