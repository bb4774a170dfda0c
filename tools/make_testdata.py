#!/usr/bin/env python3
"""Write the generated test scenes of tests/scenes/ (plain Python 3, no dependencies).

    python3 tools/make_testdata.py            # (re)writes tests/scenes/{envmap,mirrored,wrappers,manylights}/
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
* tests/scenes/wrappers/: Mitsuba 3's BSDF wrappers under one area light: a `mask` cut-out
  (leaf.png: a 32x32 grey 8-bit PNG, an ellipse with round holes, binary 0/255) on a tilted
  quad whose shadow falls on the floor, a `bumpmap` plane (height.hdr: 32x32 Radiance map of
  crossed sines in [0,1], `scale` 0.2) over a rough plastic, and a `normalmap` plane
  (normals.hdr: 32x32 map of 4x4 domes, `2 rgb - 1` in the tangent frame) over a diffuse.
  The data maps are float (.hdr) files, which no renderer sRGB-decodes.
* tests/scenes/manylights/scene.xml: lights of very different size and distance (issue 23): a
  large bright sphere overhead with 200 times the power of each of four small spheres hung
  15 cm in front of a wall, over a floor with a glossy (rough plastic) ball. Selection by power
  starves the small spheres where they dominate (the wall around them); the light tree does not.

The Mitsuba 3 references are made by
    .venv-mitsuba/bin/python tools/mitsuba/make_refs.py --collection --only envmap --only mirrored --only wrappers --only manylights
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


def png_gray_bytes(w: int, h: int, pixel) -> bytes:
    """An 8-bit greyscale PNG (no filter, zlib) of pixel(x, y) in 0..255."""
    import struct
    import zlib

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    raw = b"".join(b"\x00" + bytes(pixel(x, y) for x in range(w)) for y in range(h))
    ihdr = struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")


def hdr_map_bytes(w: int, h: int, pixel) -> bytes:
    head = f"#?RADIANCE\n# tools/make_testdata.py\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n".encode()
    return head + b"".join(rgbe(*pixel(x, y)) for y in range(h) for x in range(w))


MAP_N = 32


def leaf_pixel(x: int, y: int) -> int:
    """Opaque (255) inside an ellipse, except for three round holes; transparent (0) elsewhere."""
    u, v = (x + 0.5) / MAP_N - 0.5, (y + 0.5) / MAP_N - 0.5
    inside = (u / 0.46) ** 2 + (v / 0.3) ** 2 <= 1.0
    holes = [(-0.2, 0.0, 0.08), (0.05, -0.08, 0.06), (0.22, 0.07, 0.07)]
    hole = any((u - hu) ** 2 + (v - hv) ** 2 <= r * r for hu, hv, r in holes)
    return 255 if inside and not hole else 0


def height_pixel(x: int, y: int) -> tuple[float, float, float]:
    u, v = (x + 0.5) / MAP_N, (y + 0.5) / MAP_N
    h = 0.5 + 0.25 * math.sin(2 * math.pi * 3 * u) + 0.25 * math.sin(2 * math.pi * 2 * v + 0.7)
    return (h, h, h)


def normal_pixel(x: int, y: int) -> tuple[float, float, float]:
    """4x4 spherical domes of radius 0.45 tile: the dome's normal, encoded as (n + 1) / 2."""
    fu, fv = ((x + 0.5) / MAP_N * 4) % 1.0 - 0.5, ((y + 0.5) / MAP_N * 4) % 1.0 - 0.5
    r2 = fu * fu + fv * fv
    if r2 < 0.45 ** 2:
        nx, ny = fu / 0.45 * 0.8, fv / 0.45 * 0.8
        nz = math.sqrt(max(0.0, 1.0 - nx * nx - ny * ny))
    else:
        nx, ny, nz = 0.0, 0.0, 1.0
    return ((nx + 1) / 2, (ny + 1) / 2, (nz + 1) / 2)


def scene_head(comment: str, max_depth: int, fov: int, origin: str, target: str, width: int, height: int) -> str:
    """What every generated scene starts with: Mitsuba 3's path integrator and a perspective
    camera (x field of view, 64 spp, box filter) looking from `origin` to `target`, y up."""
    return f"""<?xml version="1.0" encoding="utf-8"?>
<!-- Written by tools/make_testdata.py: {comment} -->
<scene version="3.0.0">
    <integrator type="path">
        <integer name="max_depth" value="{max_depth}"/>
    </integrator>

    <sensor type="perspective">
        <float name="fov" value="{fov}"/>
        <string name="fov_axis" value="x"/>
        <transform name="to_world">
            <lookat origin="{origin}" target="{target}" up="0, 1, 0"/>
        </transform>
        <sampler type="independent">
            <integer name="sample_count" value="64"/>
        </sampler>
        <film type="hdrfilm">
            <integer name="width" value="{width}"/>
            <integer name="height" value="{height}"/>
            <rfilter type="box"/>
        </film>
    </sensor>
"""


ENVMAP_XML = scene_head(comment='an envmap-lit scene (see its docstring).', max_depth=8, fov=45, origin='0, 1.3, 4', target='0, 0.45, 0', width=320, height=240) + """
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

MIRRORED_XML = scene_head(comment='analytic shapes and emitters under mirroring transforms\n     (negative determinant); see its docstring.', max_depth=6, fov=50, origin='0.3, 1.6, 4.2', target='0, 0.7, 0', width=320, height=240) + """
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


WRAPPERS_XML = scene_head(comment="Mitsuba 3's mask, bumpmap and normalmap (see its docstring).", max_depth=6, fov=50, origin='0, 2.2, 4.0', target='0, 0.4, 0', width=160, height=120) + """
    <bsdf type="diffuse" id="white">
        <rgb name="reflectance" value="0.6, 0.6, 0.6"/>
    </bsdf>

    <!-- Floor (y = 0, facing +y) and back wall (z = -1.5). -->
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

    <!-- The light, facing down. -->
    <shape type="rectangle">
        <transform name="to_world">
            <scale x="1.3" y="0.9" z="1"/>
            <rotate x="1" angle="90"/>
            <translate x="-0.3" y="2.6" z="0.6"/>
        </transform>
        <emitter type="area">
            <rgb name="radiance" value="2.6, 2.45, 2.3"/>
        </emitter>
    </shape>

    <!-- A leaf cut-out between the light and the floor: its shadow shows the holes. -->
    <shape type="rectangle">
        <transform name="to_world">
            <scale x="0.6" y="0.4" z="1"/>
            <rotate x="1" angle="-60"/>
            <rotate y="1" angle="20"/>
            <translate x="-1.1" y="1.5" z="0.3"/>
        </transform>
        <bsdf type="mask">
            <texture name="opacity" type="bitmap">
                <string name="filename" value="leaf.png"/>
            </texture>
            <bsdf type="twosided">
                <bsdf type="diffuse">
                    <rgb name="reflectance" value="0.25, 0.6, 0.15"/>
                </bsdf>
            </bsdf>
        </bsdf>
    </shape>

    <!-- A bump-mapped rough plastic plane, tilted towards the camera. -->
    <shape type="rectangle">
        <transform name="to_world">
            <scale x="0.7" y="0.6" z="1"/>
            <rotate x="1" angle="-60"/>
            <translate x="0.2" y="0.45" z="0.2"/>
        </transform>
        <bsdf type="bumpmap">
            <texture name="height" type="bitmap">
                <string name="filename" value="height.hdr"/>
            </texture>
            <float name="scale" value="0.2"/>
            <bsdf type="roughplastic">
                <string name="distribution" value="ggx"/>
                <float name="alpha" value="0.15"/>
                <rgb name="diffuse_reflectance" value="0.7, 0.35, 0.2"/>
            </bsdf>
        </bsdf>
    </shape>

    <!-- A normal-mapped diffuse plane. -->
    <shape type="rectangle">
        <transform name="to_world">
            <scale x="0.6" y="0.6" z="1"/>
            <rotate x="1" angle="-50"/>
            <rotate y="1" angle="-25"/>
            <translate x="1.5" y="0.5" z="0.0"/>
        </transform>
        <bsdf type="normalmap">
            <texture name="normalmap" type="bitmap">
                <string name="filename" value="normals.hdr"/>
            </texture>
            <bsdf type="diffuse">
                <rgb name="reflectance" value="0.3, 0.45, 0.75"/>
            </bsdf>
        </bsdf>
    </shape>
</scene>
"""


# The big sphere: radius 0.5, radiance 30; each small one radius 0.04 and the radiance that
# gives it 1/200 of the big one's power (power = L 4 pi^2 r^2): L = 30 * 0.5^2 / (200 * 0.04^2).
SMALL_L = 30.0 * 0.5 ** 2 / (200 * 0.04 ** 2)
SMALL_TINTS = [(1.0, 0.75, 0.5), (0.6, 0.8, 1.0), (1.0, 0.95, 0.8), (0.8, 1.0, 0.7)]
SMALL_CENTRES = [(-0.9, 0.9), (-0.3, 1.3), (0.3, 0.8), (0.9, 1.2)]


def small_spheres() -> str:
    out = []
    for (x, y), tint in zip(SMALL_CENTRES, SMALL_TINTS):
        # each tint is scaled to mean 1, so that every small sphere has the same power
        m = sum(tint) / 3
        rgb = ", ".join(f"{SMALL_L * c / m:.4f}" for c in tint)
        out.append(f"""    <shape type="sphere">
        <point name="center" x="{x}" y="{y}" z="-1.35"/>
        <float name="radius" value="0.04"/>
        <emitter type="area">
            <rgb name="radiance" value="{rgb}"/>
        </emitter>
    </shape>""")
    return "\n".join(out)


MANYLIGHTS_XML = scene_head(comment='one large bright light and four small ones near a wall\n     (see its docstring).', max_depth=6, fov=50, origin='0, 1.2, 3.5', target='0, 0.9, -1.5', width=320, height=240) + """
    <bsdf type="diffuse" id="white">
        <rgb name="reflectance" value="0.6, 0.6, 0.6"/>
    </bsdf>

    <!-- Floor (y = 0, facing +y) and back wall (z = -1.5, facing +z). -->
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

    <!-- The large light overhead: 200 times the power of each small one. -->
    <shape type="sphere">
        <point name="center" x="0" y="3.2" z="0.8"/>
        <float name="radius" value="0.5"/>
        <emitter type="area">
            <rgb name="radiance" value="30, 29, 27"/>
        </emitter>
    </shape>

    <!-- Four small lights, 15 cm in front of the wall. -->
""" + small_spheres() + """

    <!-- A glossy ball on the floor: MIS between the light and BSDF samples. -->
    <shape type="sphere">
        <point name="center" x="0.8" y="0.35" z="-0.3"/>
        <float name="radius" value="0.35"/>
        <bsdf type="roughplastic">
            <string name="distribution" value="ggx"/>
            <float name="alpha" value="0.1"/>
            <rgb name="diffuse_reflectance" value="0.2, 0.3, 0.6"/>
        </bsdf>
    </shape>
</scene>
"""


def files() -> dict[str, bytes]:
    return {
        os.path.join(OUT, "envmap", "sky.hdr"): hdr_bytes(),
        os.path.join(OUT, "envmap", "scene.xml"): ENVMAP_XML.encode(),
        os.path.join(OUT, "mirrored", "scene.xml"): MIRRORED_XML.encode(),
        os.path.join(OUT, "wrappers", "leaf.png"): png_gray_bytes(MAP_N, MAP_N, leaf_pixel),
        os.path.join(OUT, "wrappers", "height.hdr"): hdr_map_bytes(MAP_N, MAP_N, height_pixel),
        os.path.join(OUT, "wrappers", "normals.hdr"): hdr_map_bytes(MAP_N, MAP_N, normal_pixel),
        os.path.join(OUT, "wrappers", "scene.xml"): WRAPPERS_XML.encode(),
        os.path.join(OUT, "manylights", "scene.xml"): MANYLIGHTS_XML.encode(),
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
