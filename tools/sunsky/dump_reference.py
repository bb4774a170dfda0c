#!/usr/bin/env python3
"""Dump radiance values of Mitsuba 3's `sunsky` and `envmap` emitters for octolux's tests.

Evaluates the emitters of the installed Mitsuba 3 (`scalar_rgb`) for a fixed set of
configurations and directions and writes `crates/octolux/tests/data/emitters_mitsuba.json`:

  {"mitsuba_version": ..., "sunsky": [{"params": {...}, "samples": [[dx, dy, dz, r, g, b], ...]}],
   "envmap": [{"width": w, "height": h, "pixels": [...], "scale": s, "to_world": [16 row-major],
               "samples": [[dx, dy, dz, r, g, b], ...]}]}

Directions are world-space unit vectors pointing from the scene towards the emitter (the
direction of an escaping ray); radiance is linear RGB. For `sunsky`, directions are drawn in the
emitter's upper hemisphere, a few inside the sun disk (the sun's radiance is what is hardest to
get right). The envmap is a small generated image (distinct values per pixel), so orientation
and interpolation errors show.

Usage: python tools/sunsky/dump_reference.py [--out FILE]   (with Mitsuba 3's environment)
"""

import argparse
import json
import math
import os

import numpy as np


def main():
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=os.path.join(root, "crates", "octolux", "tests", "data", "emitters_mitsuba.json"))
    args = ap.parse_args()

    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    rng = np.random.default_rng(2024)

    def evaluate(emitter, d):
        si = mi.SurfaceInteraction3f()
        si.wi = -mi.Vector3f(*[float(x) for x in d])
        return [float(x) for x in np.array(emitter.eval(si))]

    def transform(rot):
        """(mitsuba transform, row-major 4x4 list) of a rotation given as (axis, degrees) pairs."""
        t = mi.ScalarTransform4f()
        for axis, deg in rot:
            t = t @ mi.ScalarTransform4f().rotate(axis, deg)
        m = np.array(t.matrix, dtype=np.float64)
        return t, [float(x) for x in m.ravel()]

    configs = [
        dict(sun_direction=[0.3, 0.4, 0.866025], turbidity=3.0),
        dict(sun_direction=[-0.8, 0.1, 0.2], turbidity=1.5, albedo=0.0, sun_scale=2.0, sky_scale=0.5),
        dict(sun_direction=[0.1, -0.2, 0.97], turbidity=7.3, albedo=[0.9, 0.5, 0.1], sun_aperture=2.0),
        dict(sun_direction=[0.6, 0.6, 0.05], turbidity=10.0, albedo=0.5, sun_aperture=10.0),
        dict(hour=9.0, turbidity=5.0, sun_aperture=2.1432, rot=[([0, 1, 0], -30.0), ([1, 0, 0], 90.0)]),
        dict(year=2023, month=12, day=21, hour=12.5, minute=20.0, latitude=48.85, longitude=2.35, timezone=1.0),
        dict(sun_direction=[0.88698, 0.288862, 0.360313], turbidity=3.0, sky_scale=30.0, sun_scale=10.0,
             sun_aperture=0.5358 * 3.75345, rot=[([1, 0, 0], -90.0)]),
    ]
    sunsky = []
    for cfg in configs:
        params = {k: v for k, v in cfg.items() if k != "rot"}
        d = {"type": "sunsky"}
        for k, v in params.items():
            if k == "sun_direction":
                d[k] = mi.ScalarVector3f(*v)
            elif k == "albedo" and isinstance(v, list):
                d[k] = {"type": "rgb", "value": v}
            elif k in ("year", "month", "day"):
                d[k] = int(v)
            else:
                d[k] = float(v)
        to_world = None
        if "rot" in cfg:
            t, to_world = transform(cfg["rot"])
            d["to_world"] = t
        e = mi.load_dict(d)
        m = np.array(to_world, dtype=np.float64).reshape(4, 4)[:3, :3] if to_world else np.eye(3)
        # the sun's world direction: search the brightest of many directions near the analytic one
        samples = []
        for _ in range(24):
            v = rng.normal(size=3)
            v[2] = abs(v[2]) + 0.02
            v = m @ (v / np.linalg.norm(v))
            samples.append(list(v) + evaluate(e, v))
        if "sun_direction" in params:
            s = np.array(params["sun_direction"], dtype=np.float64)
            s /= np.linalg.norm(s)
            half = math.radians(0.5 * params.get("sun_aperture", 0.5358))
            f = mi.Frame3f(mi.Vector3f(*s))
            for k in range(6):
                r = half * 0.9 * k / 5
                phi = 2.0 * math.pi * rng.random()
                loc = np.array([math.sin(r) * math.cos(phi), math.sin(r) * math.sin(phi), math.cos(r)])
                v = np.array(f.s) * loc[0] + np.array(f.t) * loc[1] + s * loc[2]
                samples.append(list(v / np.linalg.norm(v)) + evaluate(e, v))
        entry = {"params": params, "samples": samples}
        if to_world:
            entry["to_world"] = to_world
        sunsky.append(entry)

    w, h = 8, 5
    img = np.zeros((h, w, 3), dtype=np.float32)
    for y in range(h):
        for x in range(w):
            img[y, x] = [x + 1, 10 * (y + 1), 100 + x * y]
    envmaps = []
    for scale, rot in [(1.0, []), (0.5, [([0, 1, 0], 40.0), ([1, 0, 0], -25.0)])]:
        d = {"type": "envmap", "bitmap": mi.Bitmap(img), "scale": scale}
        to_world = None
        if rot:
            t, to_world = transform(rot)
            d["to_world"] = t
        e = mi.load_dict(d)
        samples = []
        for _ in range(40):
            v = rng.normal(size=3)
            v /= np.linalg.norm(v)
            samples.append(list(v) + evaluate(e, v))
        envmaps.append(
            {
                "width": w,
                "height": h,
                "pixels": [float(x) for x in img.ravel()],
                "scale": scale,
                "to_world": to_world or [float(x) for x in np.eye(4).ravel()],
                "samples": samples,
            }
        )
    out = {"mitsuba_version": mi.__version__, "variant": "scalar_rgb", "sunsky": sunsky, "envmap": envmaps}
    os.makedirs(os.path.dirname(args.out), exist_ok=True)
    with open(args.out, "w") as f:
        json.dump(out, f, indent=None, separators=(",", ":"))
        f.write("\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
