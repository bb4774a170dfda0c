#!/usr/bin/env python3
"""Checks of translate.py (run with the Mitsuba venv: `.venv-mitsuba/bin/python tools/mitsuba/test_translate.py`).

* sRGB linearisation at known points;
* 0.6's solar position formula against a case with a known answer (equinox noon at the equator);
* a small 0.6 file with every translated plugin (sppm, srgb, sunsky with a z-up to_world and with
  a time, phong, ward, smooth BSDFs with alpha) is accepted by Mitsuba 3, and the translated
  sunsky emits nothing below 0.6's horizon and its sun where 0.6 puts it;
* phong/ward blends keep kd + ks (the weights reproduce both albedos).
"""
from __future__ import annotations

import math
import os
import sys
import unittest
import xml.etree.ElementTree as ET

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import translate  # noqa: E402

SCENE_06 = """<scene version="0.6.0">
  <integrator type="sppm"><integer name="maxDepth" value="7"/><integer name="photonCount" value="10"/></integrator>
  <sensor type="perspective"><float name="fov" value="40"/>
    <sampler type="ldsampler"><integer name="sampleCount" value="4"/></sampler>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>
  <emitter type="sunsky">
    <transform name="toWorld"><rotate z="1" angle="90"/></transform>
    <vector name="sunDirection" x="-0.8" y="0.3" z="0.5"/>
    <float name="sunScale" value="2"/><float name="skyScale" value="3"/><float name="sunRadiusScale" value="4"/>
  </emitter>
  <bsdf type="phong" id="p"><srgb name="diffuseReflectance" value="0.5 0.5 0.5"/>
    <rgb name="specularReflectance" value="0.1 0.1 0.1"/><float name="exponent" value="20"/></bsdf>
  <bsdf type="ward" id="w"><rgb name="diffuseReflectance" value="0.2 0.3 0.4"/>
    <rgb name="specularReflectance" value="0.3 0.2 0.1"/><float name="alphaU" value="0.2"/><float name="alphaV" value="0.3"/></bsdf>
  <bsdf type="dielectric" id="g"><float name="alpha" value="0.1"/><float name="intIOR" value="1.5"/></bsdf>
  <bsdf type="conductor" id="c"><string name="extEta" value="air"/><float name="alpha" value="0.1"/></bsdf>
  <shape type="sphere"><ref id="p"/></shape>
  <shape type="sphere"><point name="center" x="3" y="0" z="0"/><ref id="w"/></shape>
  <shape type="sphere"><point name="center" x="-3" y="0" z="0"/><ref id="g"/></shape>
  <shape type="sphere"><point name="center" x="0" y="3" z="0"/><ref id="c"/></shape>
</scene>"""


class Translate(unittest.TestCase):
    def test_srgb(self):
        self.assertAlmostEqual(translate.srgb_to_linear(0.0), 0.0)
        self.assertAlmostEqual(translate.srgb_to_linear(1.0), 1.0)
        self.assertAlmostEqual(translate.srgb_to_linear(0.5), 0.21404, places=4)
        self.assertEqual(translate.parse_triplet("#ff0000", "t"), [1.0, 0.0, 0.0])

    def test_sun_position(self):
        # 2010-03-20 12:00 UTC at (0, 0): the sun is within about 2 degrees of the zenith
        # (equinox 17:32 UTC that day; equation of time -7.5 min).
        zen, _ = translate.sun_coordinates_06(12, 0, 0, 2010, 3, 20, 0.0, 0.0, 0.0)
        self.assertLess(math.degrees(zen), 2.5)
        # Midnight there: below the horizon.
        zen, _ = translate.sun_coordinates_06(0, 0, 0, 2010, 3, 20, 0.0, 0.0, 0.0)
        self.assertGreater(math.degrees(zen), 170)
        # Tokyo, 2010-07-10 15:00 JST (0.6's defaults): afternoon sun, about 40-50 deg high, in
        # the west-south-west (0.6 azimuth measured from north through east).
        zen, az = translate.sun_coordinates_06(15, 0, 0, 2010, 7, 10, 35.6894, 139.6917, 9)
        self.assertTrue(35 < 90 - math.degrees(zen) < 55, math.degrees(zen))
        self.assertTrue(230 < math.degrees(az) < 290, math.degrees(az))

    def test_translated_scene_loads_and_sky_is_oriented(self):
        import mitsuba as mi
        if mi.variant() is None:
            mi.set_variant("scalar_rgb")
        root = ET.fromstring(SCENE_06)
        notes: list[str] = []
        approx = translate.translate_tree(root, notes)
        self.assertEqual(root.find("integrator").get("type"), "path")
        self.assertEqual(translate.find_prop(root.find("integrator"), "max_depth").get("value"), "7")
        self.assertEqual(len(approx), 3, approx)  # sunsky, phong, ward
        # Sampler and film are render.py's business; drop the 0.x sampler for this load.
        sensor = root.find("sensor")
        sensor.remove(sensor.find("sampler"))
        scene = mi.load_string(ET.tostring(root, encoding="unicode"))
        em = scene.emitters()[0]
        # 0.6's up is to_world * +y = -x here (Mitsuba 3's own default would be +z): below it
        # the sky is black, above it is not.
        si = mi.SurfaceInteraction3f()
        # (-1, 0, -0.3): above 0.6's horizon, below Mitsuba 3's default one; the opposite for -d.
        up = mi.Vector3f(-1.0, 0.0, -0.3)
        for d, positive in ((up, True), (-up, False)):
            si.wi = -mi.Vector3f(d) / math.sqrt(1.09)  # wi points back from the emitter
            val = em.eval(si)
            self.assertEqual(max(val) > 0, positive, (d, val))
        # The sun is where the file says (world direction), and the brightest there.
        sd = [-0.8, 0.3, 0.5]
        n = math.sqrt(sum(x * x for x in sd))
        si.wi = -mi.Vector3f([x / n for x in sd])
        sun = max(em.eval(si))
        si.wi = -mi.Vector3f(-1.0, 0.0, 0.0)
        zen = max(em.eval(si))
        self.assertGreater(sun, 100 * zen)

    def test_blend_weights_keep_albedos(self):
        root = ET.fromstring(SCENE_06)
        translate.translate_tree(root, [])
        for bid, kd, ks in (("p", [translate.srgb_to_linear(0.5)] * 3, [0.1] * 3), ("w", [0.2, 0.3, 0.4], [0.3, 0.2, 0.1])):
            b = next(e for e in root.iter("bsdf") if e.get("id") == bid)
            self.assertEqual(b.get("type"), "blendbsdf")
            t = float(translate.find_prop(b, "weight").get("value"))
            d, s = list(b.iter("bsdf"))[1:3]
            dr = translate.parse_triplet(translate.find_prop(d, "reflectance").get("value"), "d")
            sr = translate.parse_triplet(translate.find_prop(s, "specular_reflectance").get("value"), "s")
            for c in range(3):
                self.assertAlmostEqual((1 - t) * dr[c], kd[c], places=6)
                self.assertAlmostEqual(t * sr[c], ks[c], places=6)

    def test_crease_normals(self):
        import numpy as np
        # A unit cube of 8 vertices and 12 triangles: 90-degree edges.
        p = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=float)
        quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
        f = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])
        src, n, nf = translate.crease_normals(p, f, 40.0)
        self.assertEqual(len(src), 24)  # every corner split three ways: flat faces
        for fi in range(len(f)):
            fn = np.cross(p[f[fi, 1]] - p[f[fi, 0]], p[f[fi, 2]] - p[f[fi, 0]])
            for k in range(3):
                self.assertAlmostEqual(float(n[nf[fi, k]] @ fn / np.linalg.norm(fn)), 1.0)
                self.assertEqual(src[nf[fi, k]], f[fi, k])
        src, n, nf = translate.crease_normals(p, f, 100.0)
        self.assertEqual(len(src), 8)  # all smooth: one normal per corner, pointing outwards
        for i, v in enumerate(src):
            self.assertGreater(float(n[i] @ (p[v] - 0.5)), 0.5)


if __name__ == "__main__":
    unittest.main()
