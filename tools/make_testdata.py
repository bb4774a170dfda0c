#!/usr/bin/env python3
"""Write the generated test scenes of tests/scenes/ (plain Python 3, no dependencies).

    python3 tools/make_testdata.py            # (re)writes tests/scenes/{envmap,mirrored}/
    python3 tools/make_testdata.py --check    # exits 1 if the committed files differ

* tests/scenes/envmap/sky.hdr: a 64x32 lat-long Radiance RGBE map (flat scanlines): a sky
  gradient (blue zenith, warm horizon, dark ground; about 0.1-0.4) with a bright sun-like spot (peak about 60,
  Gaussian of 1.2 pixels) at azimuth u = 0.3, elevation v = 0.3 of the image.
* tests/scenes/envmap/scene.xml: Mitsuba 3 scene lit only by that map (`envmap`, `scale` 1.5,
  rotated 30 degrees about +y): a diffuse floor (rectangle) and a diffuse sphere.
* tests/scenes/mirrored/scene.xml: every analytic shape under a mirroring transform (negative
  determinant): emitting rectangle, disk, sphere and cube, plus a diffuse mirrored sphere and cube
  standing on a floor, so that the side an emitter lights and the side a one-sided BSDF shows
  both follow Mitsuba 3's orientation rule.

The Mitsuba 3 references of both are made by
    .venv-mitsuba/bin/python tools/mitsuba/make_refs.py --collection --only envmap --only mirrored
and checked by crates/octolux-cli/tests/agreement_collection.rs.
"""
from __future__ import annotations

import argparse
import math
import os
import sys

REPO = os.path.abspath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
OUT = os.path.join(REPO, "tests", "scenes")

ENV_W, ENV_H = 64, 32
SUN_U, SUN_V, SUN_SIGMA_PX, SUN_PEAK = 0.3, 0.3, 1.2, 60.0


def sky_pixel(x: int, y: int) -> tuple[float, float, float]:
    u, v = (x + 0.5) / ENV_W, (y + 0.5) / ENV_H
    elev = (0.5 - v) * math.pi  # +pi/2 at the top row (zenith), -pi/2 at the bottom
    if elev >= 0:
        t = math.sin(elev)  # 0 at the horizon, 1 at the zenith
        horizon, zenith = (1.0, 0.85, 0.65), (0.25, 0.45, 1.0)
        c = [h + (z - h) * t ** 0.6 for h, z in zip(horizon, zenith)]
    else:
        t = min(1.0, -elev / 0.3)
        ground = (0.12, 0.10, 0.08)
        c = [0.6 + (g - 0.6) * t for g in ground]
    # A slight azimuthal variation, so that a wrong rotation shows.
    c = [0.35 * ch * (1.0 + 0.25 * math.cos(2 * math.pi * u)) for ch in c]
    dx = min(abs(u - SUN_U), 1 - abs(u - SUN_U)) * ENV_W
    dy = (v - SUN_V) * ENV_H
    s = SUN_PEAK * math.exp(-0.5 * (dx * dx + dy * dy) / SUN_SIGMA_PX ** 2)
    return (c[0] + s, c[1] + 0.9 * s, c[2] + 0.75 * s)


def rgbe(r: float, g: float, b: float) -> bytes:
    v = max(r, g, b)
    if v < 1e-32:
        return bytes(4)
    m, e = math.frexp(v)
    scale = m * 256.0 / v
    return bytes([int(r * scale), int(g * scale), int(b * scale), e + 128])


def hdr_bytes() -> bytes:
    head = f"#?RADIANCE\n# tools/make_testdata.py\nFORMAT=32-bit_rle_rgbe\n\n-Y {ENV_H} +X {ENV_W}\n".encode()
    body = b"".join(rgbe(*sky_pixel(x, y)) for y in range(ENV_H) for x in range(ENV_W))
    return head + body


ENVMAP_XML = """<?xml version="1.0" encoding="utf-8"?>
<!-- Written by tools/make_testdata.py: an envmap-lit scene (see its docstring). -->
<scene version="3.0.0">
    <integrator type="path">
        <integer name="max_depth" value="8"/>
    </integrator>

    <sensor type="perspective">
        <float name="fov" value="45"/>
        <string name="fov_axis" value="x"/>
        <transform name="to_world">
            <lookat origin="0, 1.3, 4" target="0, 0.45, 0" up="0, 1, 0"/>
        </transform>
        <sampler type="independent">
            <integer name="sample_count" value="64"/>
        </sampler>
        <film type="hdrfilm">
            <integer name="width" value="320"/>
            <integer name="height" value="240"/>
            <rfilter type="box"/>
        </film>
    </sensor>

    <emitter type="envmap">
        <string name="filename" value="sky.hdr"/>
        <float name="scale" value="1.5"/>
        <transform name="to_world">
            <rotate y="1" angle="30"/>
        </transform>
    </emitter>

    <shape type="rectangle">
        <transform name="to_world">
            <scale value="3"/>
            <rotate x="1" angle="-90"/>
        </transform>
        <bsdf type="diffuse">
            <rgb name="reflectance" value="0.5, 0.5, 0.5"/>
        </bsdf>
    </shape>

    <shape type="sphere">
        <point name="center" x="0" y="0.5" z="0"/>
        <float name="radius" value="0.5"/>
        <bsdf type="diffuse">
            <rgb name="reflectance" value="0.7, 0.35, 0.2"/>
        </bsdf>
    </shape>
</scene>
"""

MIRRORED_XML = """<?xml version="1.0" encoding="utf-8"?>
<!-- Written by tools/make_testdata.py: analytic shapes and emitters under mirroring transforms
     (negative determinant); see its docstring. -->
<scene version="3.0.0">
    <integrator type="path">
        <integer name="max_depth" value="6"/>
    </integrator>

    <sensor type="perspective">
        <float name="fov" value="50"/>
        <string name="fov_axis" value="x"/>
        <transform name="to_world">
            <lookat origin="0.3, 1.6, 4.2" target="0, 0.7, 0" up="0, 1, 0"/>
        </transform>
        <sampler type="independent">
            <integer name="sample_count" value="64"/>
        </sampler>
        <film type="hdrfilm">
            <integer name="width" value="320"/>
            <integer name="height" value="240"/>
            <rfilter type="box"/>
        </film>
    </sensor>

    <bsdf type="diffuse" id="white">
        <rgb name="reflectance" value="0.7, 0.7, 0.7"/>
    </bsdf>

    <!-- Floor (y = 0, facing +y) and back wall (z = -1.5, facing +z): not mirrored. -->
    <shape type="rectangle">
        <transform name="to_world">
            <scale value="3"/>
            <rotate x="1" angle="-90"/>
        </transform>
        <ref id="white"/>
    </shape>
    <shape type="rectangle">
        <transform name="to_world">
            <scale x="3" y="2" z="1"/>
            <translate x="0" y="2" z="-1.5"/>
        </transform>
        <ref id="white"/>
    </shape>

    <!-- Emitters, each mirrored. The rectangle and disk are turned to face down (-y) before the
         mirror is applied: which side emits is what the test checks. -->
    <shape type="rectangle">
        <transform name="to_world">
            <scale x="-0.3" y="0.2" z="1"/>
            <rotate x="1" angle="90"/>
            <translate x="-1.3" y="1.8" z="0"/>
        </transform>
        <emitter type="area">
            <rgb name="radiance" value="12, 4, 2"/>
        </emitter>
    </shape>
    <shape type="disk">
        <transform name="to_world">
            <scale x="0.25" y="-0.25" z="1"/>
            <rotate x="1" angle="90"/>
            <translate x="0" y="2.0" z="0.3"/>
        </transform>
        <emitter type="area">
            <rgb name="radiance" value="3, 10, 4"/>
        </emitter>
    </shape>
    <shape type="sphere">
        <transform name="to_world">
            <scale x="-0.15" y="0.15" z="0.15"/>
            <translate x="1.3" y="1.3" z="0"/>
        </transform>
        <emitter type="area">
            <rgb name="radiance" value="3, 4, 14"/>
        </emitter>
    </shape>
    <shape type="cube">
        <transform name="to_world">
            <scale x="0.12" y="0.12" z="-0.12"/>
            <rotate y="1" angle="25"/>
            <translate x="0.6" y="1.6" z="-1.0"/>
        </transform>
        <emitter type="area">
            <rgb name="radiance" value="8, 7, 4"/>
        </emitter>
    </shape>

    <!-- Diffuse (one-sided) shapes, mirrored. -->
    <shape type="sphere">
        <transform name="to_world">
            <scale x="0.35" y="-0.35" z="0.35"/>
            <translate x="-0.6" y="0.35" z="0.2"/>
        </transform>
        <bsdf type="diffuse">
            <rgb name="reflectance" value="0.8, 0.5, 0.3"/>
        </bsdf>
    </shape>
    <shape type="cube">
        <transform name="to_world">
            <scale x="-0.3" y="0.3" z="0.3"/>
            <rotate y="1" angle="-20"/>
            <translate x="0.6" y="0.3" z="0.1"/>
        </transform>
        <bsdf type="diffuse">
            <rgb name="reflectance" value="0.3, 0.6, 0.8"/>
        </bsdf>
    </shape>
</scene>
"""


def files() -> dict[str, bytes]:
    return {
        os.path.join(OUT, "envmap", "sky.hdr"): hdr_bytes(),
        os.path.join(OUT, "envmap", "scene.xml"): ENVMAP_XML.encode(),
        os.path.join(OUT, "mirrored", "scene.xml"): MIRRORED_XML.encode(),
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--check", action="store_true", help="compare with the files on disk, write nothing")
    args = ap.parse_args(argv)
    bad = 0
    for path, data in files().items():
        rel = os.path.relpath(path, REPO)
        if args.check:
            same = os.path.exists(path) and open(path, "rb").read() == data
            print(f"{'ok  ' if same else 'DIFF'} {rel}")
            bad += not same
        else:
            os.makedirs(os.path.dirname(path), exist_ok=True)
            with open(path, "wb") as f:
                f.write(data)
            print(f"wrote {rel} ({len(data)} bytes)")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
