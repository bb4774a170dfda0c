#!/usr/bin/env python3
"""Environment-map sampling on a 2048x1024 map: what share of the path tracer's time it takes.

    python3 bench/env_sampling.py                      # both scenes, 16 spp, 2 threads
    python3 bench/env_sampling.py --perf               # plus a perf profile of each render
    python3 bench/env_sampling.py --scene room --spp 8 --keep target/envbench
    python3 bench/env_sampling.py --scene classroom     # needs ../shared/scenes

Writes into a temporary folder (never into the repository) a 2048x1024 Radiance HDR sky
(gradient, streaks of cloud, a sun of a few pixels 25 degrees up holding about a third of the
power) and scenes lit only by it:
  open       the floor and sphere of tests/scenes/envmap under the big map;
  room       a closed box room (4 x 3 x 5) lit through one window in a wall: most light samples
             end on the walls, and the rest of a path is cheap (ten rectangles);
  classroom  the collection's classroom (../shared/scenes/bitterli-collection) with its sunsky
             replaced by the map, turned so that the sun comes from the sky's sun direction
             (a patched copy with absolute file names; 320x180), the issue's case: an interior
             of real geometry lit through windows.
Renders each with octolux `path` (2 threads, --sampler sobol) and reports samples per CPU
second; with --perf, `perf record` runs the render and the report gives the share of samples
in the environment map's sampling (`Distribution1D::sample`, `LatLong::sample_direction`) and in
`LatLong::pdf` among the top symbols. --reference DIR adds each render's relMSE against
DIR/<scene>.exr (e.g. a 256-spp render of the same scene). Needs `target/release/octolux`.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import resource
import shutil
import subprocess
import sys
import tempfile

REPO = os.path.abspath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
sys.path.insert(0, os.path.join(REPO, "bench"))
from machine import cpu_line  # noqa: E402

W, H = 2048, 1024
SUN_U, SUN_V = 0.3, 0.36  # the sun's place in the map: elevation (0.5 - SUN_V) * 180 = 25 degrees
CLASSROOM = os.path.join(REPO, "..", "shared", "scenes", "bitterli-collection", "classroom", "scene.xml")


def rgbe(r: float, g: float, b: float) -> bytes:
    v = max(r, g, b)
    if v < 1e-32:
        return bytes(4)
    m, e = math.frexp(v)
    s = m * 256.0 / v
    return bytes([int(r * s), int(g * s), int(b * s), e + 128])


def sky(x: int, y: int) -> tuple[float, float, float]:
    u, v = (x + 0.5) / W, (y + 0.5) / H
    theta, phi = v * math.pi, u * 2 * math.pi
    if theta < math.pi / 2:
        t = math.cos(theta)
        c = [0.9 - 0.6 * t, 0.85 - 0.35 * t, 0.8 + 0.2 * t]
    else:
        c = [0.08, 0.07, 0.06]
    cloud = 1.0 + 0.5 * math.sin(13 * phi + 7 * theta) * math.cos(5 * phi - 3 * theta)
    dx, dy = x - SUN_U * W, y - SUN_V * H
    sun = 3.0e4 * math.exp(-(dx * dx + dy * dy) / 8.0)
    return (c[0] * cloud + sun, c[1] * cloud + 0.95 * sun, c[2] * cloud + 0.85 * sun)


def write_sky(path: str) -> None:
    with open(path, "wb") as f:
        f.write(f"#?RADIANCE\n# bench/env_sampling.py\nFORMAT=32-bit_rle_rgbe\n\n-Y {H} +X {W}\n".encode())
        for y in range(H):
            f.write(b"".join(rgbe(*sky(x, y)) for x in range(W)))


HEAD = """<?xml version="1.0" encoding="utf-8"?>
<scene version="3.0.0">
    <integrator type="path"><integer name="max_depth" value="8"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="{fov}"/>
        <transform name="to_world"><lookat origin="{origin}" target="{target}" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="16"/></sampler>
        <film type="hdrfilm"><integer name="width" value="320"/><integer name="height" value="240"/></film>
    </sensor>
    <emitter type="envmap">
        <string name="filename" value="sky2k.hdr"/>
        <transform name="to_world"><rotate y="1" angle="30"/></transform>
    </emitter>
    <bsdf type="diffuse" id="white"><rgb name="reflectance" value="0.6, 0.6, 0.6"/></bsdf>
"""

OPEN = HEAD.format(fov=45, origin="0, 1.3, 4", target="0, 0.45, 0") + """
    <shape type="rectangle">
        <transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/></transform>
        <ref id="white"/>
    </shape>
    <shape type="sphere"><point name="center" x="0" y="0.5" z="0"/><float name="radius" value="0.5"/>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.35, 0.2"/></bsdf>
    </shape>
</scene>
"""


def room() -> str:
    """A 4 x 3 x 5 room (x in [-2, 2], y in [0, 3], z in [-2.5, 2.5]) of rectangles facing in;
    the wall at x = 2 has a 1.2 x 1 window (four rectangles around the hole)."""
    def rect(cx, cy, cz, sx, sy, rot):
        return (f'    <shape type="rectangle"><transform name="to_world"><scale x="{sx}" y="{sy}" z="1"/>{rot}'
                f'<translate x="{cx}" y="{cy}" z="{cz}"/></transform><ref id="white"/></shape>\n')
    s = HEAD.format(fov=60, origin="-1.8, 1.5, 2.3", target="1, 1.0, -1")
    s += rect(0, 0, 0, 2, 2.5, '<rotate x="1" angle="-90"/>')          # floor, facing +y
    s += rect(0, 3, 0, 2, 2.5, '<rotate x="1" angle="90"/>')           # ceiling, facing -y
    s += rect(0, 1.5, -2.5, 2, 1.5, "")                                  # back wall, facing +z
    s += rect(0, 1.5, 2.5, 2, 1.5, '<rotate y="1" angle="180"/>')      # front wall, facing -z
    s += rect(-2, 1.5, 0, 2.5, 1.5, '<rotate y="1" angle="90"/>')      # wall x = -2, facing +x
    # wall x = 2 facing -x, with a window y in [1, 2], z in [-0.6, 0.6]
    rot = '<rotate y="1" angle="-90"/>'
    s += rect(2, 0.5, 0, 2.5, 0.5, rot)                                  # below the window
    s += rect(2, 2.5, 0, 2.5, 0.5, rot)                                  # above
    s += rect(2, 1.5, -1.55, 0.95, 0.5, rot)                             # beside (z < -0.6)
    s += rect(2, 1.5, 1.55, 0.95, 0.5, rot)                              # beside (z > 0.6)
    return s + "</scene>\n"


def classroom(folder: str) -> str | None:
    """The classroom with its sunsky replaced by the map (see the module docs)."""
    import re
    src = os.path.join(os.environ.get("OCTOLUX_SHARED", os.path.join(REPO, "..", "shared")), "scenes",
                       "bitterli-collection", "classroom", "scene.xml")
    if not os.path.exists(src):
        return None
    base = os.path.dirname(os.path.abspath(src))
    with open(src) as f:
        text = f.read()
    sun = re.search(r'name="sunDirection" x="([-0-9.e]+)" y="([-0-9.e]+)" z="([-0-9.e]+)"', text)
    tx, tz = float(sun.group(1)), float(sun.group(3))
    # the map's sun at u = SUN_U is local direction (sin t sin p, cos t, -sin t cos p), p = 2 pi u:
    # a turn about +y by `a` adds `a` to atan2(x, z)
    phi = 2 * math.pi * SUN_U
    a = math.degrees(math.atan2(tx, tz) - math.atan2(math.sin(phi), -math.cos(phi)))
    env = (f'<emitter type="envmap"><string name="filename" value="{os.path.join(folder, "sky2k.hdr")}"/>'
           f'<transform name="toWorld"><rotate y="1" angle="{a:.4f}"/></transform></emitter>')
    text = re.sub(r'<emitter type="sunsky"\s*>.*?</emitter>', env, text, flags=re.S)
    text = re.sub(r'(name="filename" value=")([^"/][^"]*)"',
                  lambda m: m.group(1) + (os.path.join(base, m.group(2)) if not m.group(2).startswith(folder) else m.group(2)) + '"',
                  text)
    return text


def children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", action="append", choices=["open", "room", "classroom"])
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--perf", action="store_true", help="profile each render with perf record")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--reference", help="a folder of <scene>.exr references: print each render's relMSE against them")
    ap.add_argument("--keep", help="write the scenes here instead of a temporary folder")
    ap.add_argument("--octolux", default=os.path.join(REPO, "target", "release", "octolux"))
    args = ap.parse_args(argv)
    if not os.path.exists(args.octolux):
        sys.exit(f"{args.octolux} missing: cargo build --release -p octolux-cli")
    folder = args.keep or tempfile.mkdtemp(prefix="octolux-envbench-")
    os.makedirs(folder, exist_ok=True)
    try:
        sky_path = os.path.join(folder, "sky2k.hdr")
        if not os.path.exists(sky_path):
            print(f"writing the {W}x{H} sky", file=sys.stderr)
            write_sky(sky_path)
        scenes = {"open": OPEN, "room": room(), "classroom": classroom(folder)}
        print(f"# {cpu_line()}; load average {os.getloadavg()[0]:.2f}; {args.spp} spp, {args.threads} threads")
        for name in args.scene or ["open", "room", "classroom"]:
            if scenes[name] is None:
                print(f"skip: {name}: {CLASSROOM} is absent")
                continue
            xml = os.path.join(folder, f"{name}.xml")
            with open(xml, "w") as f:
                f.write(scenes[name])
            out = os.path.join(folder, f"{name}.exr")
            cmd = [args.octolux, "render", xml, "--integrator", "path", "--spp", str(args.spp), "--threads",
                   str(args.threads), "--sampler", "sobol", "--quiet", "-o", out, "--seed", str(args.seed)]
            if name == "classroom":
                cmd += ["--resolution", "320x180"]
            if args.perf:
                data = os.path.join(folder, f"{name}.perf.data")
                cmd = ["perf", "record", "-e", "cpu-clock", "-F", "999", "-g", "-o", data, "--"] + cmd
            c0 = children_cpu()
            subprocess.run(cmd, check=True, stderr=subprocess.DEVNULL)
            cpu = children_cpu() - c0
            with open(os.path.join(folder, f"{name}.json")) as f:
                stats = json.load(f)
            err = ""
            ref = os.path.join(args.reference, f"{name}.exr") if args.reference else None
            if ref and os.path.exists(ref):
                c = subprocess.run([args.octolux, "compare", out, ref], text=True, capture_output=True)
                err = f", relMSE {json.loads(c.stdout)['rel_mse']:.4e}"
            print(f"{name}: {stats['samples_per_second'] / 1e6:.3f} M samples/s wall, CPU {cpu:.1f} s, "
                  f"render {stats['timings']['render_s']:.1f} s{err}")
            if args.perf:
                rep = subprocess.run(["perf", "report", "-i", data, "--no-children", "--stdio", "--sort", "symbol",
                                      "--percent-limit", "0.5"], text=True, capture_output=True).stdout
                lines = [l for l in rep.splitlines() if l.strip() and not l.startswith("#") and "%" in l.split()[0]]
                print("\n".join("    " + l.strip() for l in lines[:25]))
    finally:
        if not args.keep:
            shutil.rmtree(folder, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
