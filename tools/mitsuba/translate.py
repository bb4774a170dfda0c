#!/usr/bin/env python3
"""Mitsuba 0.5/0.6 scene files -> files Mitsuba 3 loads.

    .venv-mitsuba/bin/python tools/mitsuba/translate.py SCENE.xml -o OUT.xml [--json]

The scene file is only read; the translation is written where `-o` says (a temporary or
`target/` folder, never beside the scene). Relative `filename`s are made absolute against the
original scene's folder so the copy loads from anywhere. `tools/mitsuba/render.py` applies the
same translation on the fly, so `render.py SCENE.xml` works on 0.6 files directly.

What is changed, and why (Mitsuba 3.9 loads camelCase names of 0.6 files only partly and refuses
the rest; each rule below is something it refused or read differently):

* names: camelCase -> snake_case (`toWorld` -> `to_world`, `maxDepth` -> `max_depth`, ...);
  0.x-only properties dropped (`strictNormals`, `samplingWeight`, ...);
* integrator: one Mitsuba 3 does not have (`sppm`, `bdpt`, `pssmlt`, `photonmapper`, ...) becomes
  `path` with the file's `maxDepth` (and `rrDepth`); the other method's parameters are dropped;
* `<srgb>` colours: 0.6 reads them as gamma-encoded sRGB and linearises them, so they become
  `<rgb>` with the linearised value (hex `#rrggbb` too);
* `sunsky` (0.6: Preetham sun + Hosek-Wilkie sky, y up, `sunDirection` or time/place,
  `sunScale`/`skyScale`/`scale`, `sunRadiusScale`, `albedo` default 0.2) -> Mitsuba 3 `sunsky`
  (Hosek-Wilkie sky and solar radiance, z up): the same world sun direction (computed from the
  time/place with 0.6's own formula when not given), the same up axis (`to_world` maps Mitsuba 3's
  +z onto 0.6's transformed +y), `sun_aperture` = 0.5358 deg x sunRadiusScale (both keep the sun's
  power when its size changes), the scales and the albedo carried over. Recorded as an
  approximation: the sun's spectrum comes from a different model;
* `phong` (no Mitsuba 3 plugin) -> `blendbsdf` of `diffuse` and a Beckmann `roughconductor`
  (material none, i.e. Fresnel 1) with alpha = sqrt(2 / (exponent + 2)) (the Beckmann width whose
  lobe matches a Phong lobe of that exponent), weights chosen so that the sum is
  kd * diffuse + ks * specular. Recorded as an approximation;
* `ward` (no Mitsuba 3 plugin) -> Beckmann `roughconductor` (material none) with the Ward
  alphas (both are Gaussian slope distributions of that RMS slope) and `specularReflectance`,
  blended with `diffuse` when `diffuseReflectance` is non-zero. Recorded as an approximation;
* conductors with no `material`/`eta`/`k`: `material="Cu"` made explicit (0.6's default; Mitsuba
  3's default is a perfect mirror);
* `alpha`/`distribution` given to smooth `dielectric`/`conductor`/`plastic` (which 0.6 ignored
  with a warning) are dropped; `extEta` of conductors (not in Mitsuba 3) is dropped when it is air
  (1.0), otherwise an error;
* `maxSmoothAngle` (no Mitsuba 3 equivalent): when render.py renders, the mesh is rewritten as a
  temporary PLY whose normals are rebuilt with that crease angle; elsewhere it is dropped and
  reported as an approximation;
* bitmap `filterType` `trilinear`/`ewa` (mipmapped in 0.6) -> `bilinear` (Mitsuba 3 has no
  mipmaps; noted);
* film: reduced to what defines the picture (render.py); samplers Mitsuba 3 lacks -> independent.

Everything else is passed through untouched; anything unknown that Mitsuba 3 refuses still stops
the load with Mitsuba's own message.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import re
import sys
import xml.etree.ElementTree as ET

PROPERTY_TAGS = {
    "integer", "float", "boolean", "string", "rgb", "spectrum", "vector", "point",
    "transform", "ref", "color", "srgb", "blackbody", "tensor",
}
OBJECT_TAGS = {
    "scene", "integrator", "sensor", "sampler", "film", "rfilter", "bsdf", "emitter", "shape",
    "texture", "medium", "phase", "volume", "spectrum_plugin",
}
# Properties that only existed in Mitsuba 0.x (after snake_case renaming), dropped per object tag.
OLD_ONLY_PROPS = {
    "integrator": {"strict_normals"},
    "emitter": {"sampling_weight"},
    "sampler": {"scramble", "dimension"},
}
# Integrators of Mitsuba 3 that take max_depth as the path integrator does.
MI3_INTEGRATORS = {"path", "volpath", "volpathmis", "direct", "ptracer", "prb", "prb_basic",
                   "prbvolpath", "aov", "depth", "moment", "direct_projective", "prb_projective"}
# 0.6 sun: apparent diameter in degrees (0.6 uses half of it as the cone half-angle).
SUN_APP_DIAMETER_06 = 0.5358


class TranslateError(Exception):
    pass


def camel_to_snake(name: str) -> str:
    # toWorld -> to_world, intIOR -> int_ior, maxDepth -> max_depth
    return re.sub(r"(?<=[a-z0-9])(?=[A-Z])", "_", name).lower()


def find_prop(elem: ET.Element, name: str) -> ET.Element | None:
    for c in elem:
        if c.tag in PROPERTY_TAGS and c.get("name") == name:
            return c
    return None


def del_prop(elem: ET.Element, name: str) -> ET.Element | None:
    p = find_prop(elem, name)
    if p is not None:
        elem.remove(p)
    return p


def add_prop(elem: ET.Element, tag: str, name: str, value: str) -> ET.Element:
    del_prop(elem, name)
    return ET.SubElement(elem, tag, {"name": name, "value": value})


def fmt(x: float) -> str:
    return repr(float(x))


def fmt3(v) -> str:
    return ", ".join(fmt(x) for x in v)


# ---------------------------------------------------------------------------------------------
# Names
# ---------------------------------------------------------------------------------------------

def upgrade_names(root: ET.Element, notes: list[str]) -> None:
    renamed = set()
    for e in root.iter():
        if e.tag in PROPERTY_TAGS or e.tag in OBJECT_TAGS:
            n = e.get("name")
            if n and n != camel_to_snake(n):
                renamed.add(f"{n}->{camel_to_snake(n)}")
                e.set("name", camel_to_snake(n))
    if renamed:
        notes.append("renamed " + ", ".join(sorted(renamed)))
    for e in root.iter():
        drop = OLD_ONLY_PROPS.get(e.tag, set())
        for c in list(e):
            if c.tag in PROPERTY_TAGS and c.get("name") in drop:
                notes.append(f"dropped {e.tag}.{c.get('name')}")
                e.remove(c)


# ---------------------------------------------------------------------------------------------
# Colours and transforms
# ---------------------------------------------------------------------------------------------

def srgb_to_linear(c: float) -> float:
    return c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4


def parse_triplet(value: str, what: str) -> list[float]:
    v = value.strip()
    if v.startswith("#"):
        if len(v) != 7:
            raise TranslateError(f"{what}: bad hex colour {value!r}")
        n = int(v[1:], 16)
        return [((n >> 16) & 255) / 255.0, ((n >> 8) & 255) / 255.0, (n & 255) / 255.0]
    toks = [t for t in re.split(r"[,\s]+", v) if t]
    try:
        xs = [float(t) for t in toks]
    except ValueError as e:
        raise TranslateError(f"{what}: cannot read {value!r} as a colour") from e
    if len(xs) == 1:
        return xs * 3
    if len(xs) == 3:
        return xs
    raise TranslateError(f"{what}: expected 1 or 3 numbers, got {value!r}")


def constant_rgb(elem: ET.Element | None, what: str) -> list[float] | None:
    """Linear RGB of a constant colour property (`rgb`, `srgb`, single-valued `spectrum`/`float`);
    None when the property is absent; an error when it is textured."""
    if elem is None:
        return None
    if elem.tag in ("rgb", "color"):
        return parse_triplet(elem.get("value", ""), what)
    if elem.tag == "srgb":
        return [srgb_to_linear(c) for c in parse_triplet(elem.get("value", ""), what)]
    if elem.tag in ("spectrum", "float"):
        v = elem.get("value", "")
        if ":" in v:
            raise TranslateError(f"{what}: sampled spectrum {v!r} is not translated here")
        return parse_triplet(v, what)
    raise TranslateError(f"{what}: <{elem.tag}> (textured) is not translated here")


def _rotation(axis, angle_deg: float):
    import numpy as np
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    t = math.radians(angle_deg)
    c, s = math.cos(t), math.sin(t)
    x, y, z = a
    r = np.array([
        [c + x * x * (1 - c), x * y * (1 - c) - z * s, x * z * (1 - c) + y * s],
        [y * x * (1 - c) + z * s, c + y * y * (1 - c), y * z * (1 - c) - x * s],
        [z * x * (1 - c) - y * s, z * y * (1 - c) + x * s, c + z * z * (1 - c)],
    ])
    m = np.eye(4)
    m[:3, :3] = r
    return m


def transform_matrix(t: ET.Element | None):
    """4x4 matrix of a Mitsuba `<transform>` (operations applied in document order, each one
    left-multiplied, as both Mitsuba versions do)."""
    import numpy as np
    m = np.eye(4)
    if t is None:
        return m
    for op in t:
        g = lambda k, d=0.0: float(op.get(k, d))  # noqa: E731
        if op.tag == "translate":
            s = np.eye(4)
            s[:3, 3] = [g("x"), g("y"), g("z")]
        elif op.tag == "scale":
            if op.get("value") is not None:
                v = parse_triplet(op.get("value"), "scale")
            else:
                v = [g("x", 1.0), g("y", 1.0), g("z", 1.0)]
            s = np.diag([v[0], v[1], v[2], 1.0])
        elif op.tag == "rotate":
            if op.get("value") is not None:
                axis = parse_triplet(op.get("value"), "rotate")
            else:
                axis = [g("x"), g("y"), g("z")]
            s = _rotation(axis, g("angle"))
        elif op.tag == "matrix":
            vals = [float(x) for x in re.split(r"[,\s]+", op.get("value").strip()) if x]
            if len(vals) == 9:
                s = np.eye(4)
                s[:3, :3] = np.array(vals).reshape(3, 3)
            elif len(vals) == 16:
                s = np.array(vals).reshape(4, 4)
            else:
                raise TranslateError(f"matrix with {len(vals)} values")
        elif op.tag == "lookat":
            o = np.array(parse_triplet(op.get("origin"), "lookat origin"))
            tg = np.array(parse_triplet(op.get("target"), "lookat target"))
            up = np.array(parse_triplet(op.get("up", "0 1 0"), "lookat up"))
            d = tg - o
            d /= np.linalg.norm(d)
            left = np.cross(up, d)
            left /= np.linalg.norm(left)
            nup = np.cross(d, left)
            s = np.eye(4)
            s[:3, 0], s[:3, 1], s[:3, 2], s[:3, 3] = left, nup, d, o
        else:
            raise TranslateError(f"transform operation <{op.tag}> is not translated here")
        m = s @ m
    return m


def matrix_transform_elem(name: str, m) -> ET.Element:
    t = ET.Element("transform", {"name": name})
    ET.SubElement(t, "matrix", {"value": " ".join(fmt(x) for x in m.reshape(-1))})
    return t


# ---------------------------------------------------------------------------------------------
# Integrator
# ---------------------------------------------------------------------------------------------

def fix_integrator(root: ET.Element, notes: list[str], approx: list[str]) -> None:
    for integ in [e for e in root if e.tag == "integrator"]:
        itype = integ.get("type")
        if itype in MI3_INTEGRATORS:
            continue
        keep = {"max_depth", "rr_depth", "hide_emitters"}
        kept = [c for c in integ if c.tag in PROPERTY_TAGS and c.get("name") in keep]
        dropped = sorted(c.get("name") for c in integ if c not in kept and c.get("name"))
        for c in list(integ):
            integ.remove(c)
        for c in kept:
            integ.append(c)
        integ.set("type", "path")
        depth = find_prop(integ, "max_depth")
        notes.append(f"integrator {itype} -> path (max_depth {depth.get('value') if depth is not None else 'default'}"
                     f" kept; dropped {', '.join(dropped) or 'nothing'})")


# ---------------------------------------------------------------------------------------------
# sRGB colours
# ---------------------------------------------------------------------------------------------

def fix_srgb(root: ET.Element, notes: list[str]) -> None:
    n = 0
    for e in root.iter("srgb"):
        lin = [srgb_to_linear(c) for c in parse_triplet(e.get("value", ""), f"<srgb name={e.get('name')}>")]
        e.tag = "rgb"
        e.set("value", fmt3(lin))
        n += 1
    if n:
        notes.append(f"{n} <srgb> colour(s) -> <rgb> (sRGB transfer function removed, as 0.6 does)")


# ---------------------------------------------------------------------------------------------
# sunsky
# ---------------------------------------------------------------------------------------------

def sun_coordinates_06(hour, minute, second, year, month, day, latitude, longitude, timezone):
    """(zenith angle, azimuth) in radians of the sun for a date, time and place, as Mitsuba 0.6
    computes them (Blanco-Muriel et al., "Computing the Solar Vector", Solar Energy 70(5), 2001)."""
    dec_hours = hour - timezone + (minute + second / 60.0) / 60.0
    # Julian day (integer arithmetic of the paper: divisions truncate towards zero).
    def idiv(a, b):
        return int(a / b)
    aux1 = idiv(month - 14, 12)
    aux2 = (idiv(1461 * (year + 4800 + aux1), 4) + idiv(367 * (month - 2 - 12 * aux1), 12)
            - idiv(3 * idiv(year + 4900 + aux1, 100), 4) + day - 32075)
    jd = aux2 - 0.5 + dec_hours / 24.0
    n = jd - 2451545.0
    omega = 2.1429 - 0.0010394594 * n
    mean_lon = 4.8950630 + 0.017202791698 * n
    anomaly = 6.2400600 + 0.0172019699 * n
    ecl_lon = (mean_lon + 0.03341607 * math.sin(anomaly) + 0.00034894 * math.sin(2 * anomaly)
               - 0.0001134 - 0.0000203 * math.sin(omega))
    ecl_obl = 0.4090928 - 6.2140e-9 * n + 0.0000396 * math.cos(omega)
    s = math.sin(ecl_lon)
    ra = math.atan2(math.cos(ecl_obl) * s, math.cos(ecl_lon))
    if ra < 0:
        ra += 2 * math.pi
    decl = math.asin(math.sin(ecl_obl) * s)
    gmst = 6.6974243242 + 0.0657098283 * n + dec_hours
    lmst = math.radians(gmst * 15 + longitude)
    lat = math.radians(latitude)
    ha = lmst - ra
    zenith = math.acos(math.cos(lat) * math.cos(ha) * math.cos(decl) + math.sin(decl) * math.sin(lat))
    az = math.atan2(-math.sin(ha), math.tan(decl) * math.cos(lat) - math.sin(lat) * math.cos(ha))
    if az < 0:
        az += 2 * math.pi
    zenith += (6371.01 / 149597890.0) * math.sin(zenith)  # parallax
    return zenith, az


def fix_sunsky(root: ET.Element, notes: list[str], approx: list[str]) -> None:
    import numpy as np
    for em in root.iter("emitter"):
        if em.get("type") not in ("sunsky", "sky", "sun"):
            continue
        kind = em.get("type")
        what = f"emitter {kind}"
        props = {c.get("name"): c for c in em if c.tag in PROPERTY_TAGS}
        num = lambda k, d: float(props[k].get("value")) if k in props else d  # noqa: E731
        to_world = transform_matrix(props.get("to_world"))
        lin = to_world[:3, :3]
        if "sun_direction" in props:
            p = props["sun_direction"]
            d = np.array([float(p.get("x", 0)), float(p.get("y", 0)), float(p.get("z", 0))])
            if not np.any(d):
                raise TranslateError(f"{what}: zero sunDirection")
            sun_world = d / np.linalg.norm(d)
            how = "sunDirection"
        else:
            zen, az = sun_coordinates_06(num("hour", 15.0), num("minute", 0.0), num("second", 0.0),
                                         int(num("year", 2010)), int(num("month", 7)), int(num("day", 10)),
                                         num("latitude", 35.6894), num("longitude", 139.6917),
                                         num("timezone", 9.0))
            local = np.array([math.sin(az) * math.sin(zen), math.cos(zen), -math.cos(az) * math.sin(zen)])
            sun_world = lin @ local
            sun_world /= np.linalg.norm(sun_world)
            how = f"time/place (zenith {math.degrees(zen):.2f} deg, azimuth {math.degrees(az):.2f} deg in 0.6's frame)"
        up = lin @ np.array([0.0, 1.0, 0.0])
        up /= np.linalg.norm(up)
        # Mitsuba 3 frame: z = up; x, y any orthonormal completion (the sky depends only on the
        # zenith angle and the angle to the sun).
        helper = np.array([1.0, 0.0, 0.0]) if abs(up[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        x = np.cross(helper, up)
        x /= np.linalg.norm(x)
        y = np.cross(up, x)
        m3 = np.eye(4)
        m3[:3, 0], m3[:3, 1], m3[:3, 2] = x, y, up
        scale = num("scale", 1.0)
        sun_scale = num("sun_scale", scale)
        sky_scale = num("sky_scale", scale)
        if kind == "sky":
            sun_scale = 0.0
        if kind == "sun":
            sky_scale = 0.0
        radius_scale = num("sun_radius_scale", 1.0)
        aperture = SUN_APP_DIAMETER_06 * radius_scale
        if aperture <= 0:
            aperture = 1e-3
            approx.append(f"{what}: sunRadiusScale=0 (a directional sun) -> sun_aperture 0.001 deg")
        turbidity = num("turbidity", 3.0)
        if "albedo" in props:
            albedo = constant_rgb(props["albedo"], f"{what} albedo")
        else:
            albedo = [0.2, 0.2, 0.2]  # 0.6 sky.cpp default
        for k in ("stretch", "extend"):
            if k in props and props[k].get("value") not in ("1", "1.0", "false"):
                approx.append(f"{what}: {k}={props[k].get('value')} has no Mitsuba 3 equivalent (ignored)")
        if "resolution" in props:
            notes.append(f"{what}: resolution dropped (Mitsuba 3 evaluates the model per direction; "
                         "0.6 rasterised it into an environment map)")
        for c in list(em):
            em.remove(c)
        em.set("type", "sunsky")
        ET.SubElement(em, "float", {"name": "turbidity", "value": fmt(turbidity)})
        ET.SubElement(em, "rgb", {"name": "albedo", "value": fmt3(albedo)})
        ET.SubElement(em, "vector", {"name": "sun_direction", "x": fmt(sun_world[0]),
                                     "y": fmt(sun_world[1]), "z": fmt(sun_world[2])})
        ET.SubElement(em, "float", {"name": "sun_scale", "value": fmt(sun_scale)})
        ET.SubElement(em, "float", {"name": "sky_scale", "value": fmt(sky_scale)})
        ET.SubElement(em, "float", {"name": "sun_aperture", "value": fmt(aperture)})
        em.append(matrix_transform_elem("to_world", m3))
        notes.append(f"{what} -> Mitsuba 3 sunsky: sun direction from {how} = "
                     f"({sun_world[0]:.5f}, {sun_world[1]:.5f}, {sun_world[2]:.5f}) world, up "
                     f"({up[0]:.5f}, {up[1]:.5f}, {up[2]:.5f}), turbidity {turbidity:g}, "
                     f"sun_scale {sun_scale:g}, sky_scale {sky_scale:g}, sun_aperture {aperture:.5g} deg, "
                     f"albedo {albedo[0]:g}")
        approx.append(f"{what}: Mitsuba 3's Hosek-Wilkie sky and solar radiance replace 0.6's sunsky "
                      "(Hosek-Wilkie sky rasterised to a 512x256 map, Preetham sun); direction, size, "
                      "scales, turbidity and albedo carried over")


# ---------------------------------------------------------------------------------------------
# BSDFs
# ---------------------------------------------------------------------------------------------

def _beckmann_conductor(alpha_u: float, alpha_v: float, ks: list[float]) -> ET.Element:
    b = ET.Element("bsdf", {"type": "roughconductor"})
    ET.SubElement(b, "string", {"name": "material", "value": "none"})
    ET.SubElement(b, "string", {"name": "distribution", "value": "beckmann"})
    if alpha_u == alpha_v:
        ET.SubElement(b, "float", {"name": "alpha", "value": fmt(alpha_u)})
    else:
        ET.SubElement(b, "float", {"name": "alpha_u", "value": fmt(alpha_u)})
        ET.SubElement(b, "float", {"name": "alpha_v", "value": fmt(alpha_v)})
    ET.SubElement(b, "rgb", {"name": "specular_reflectance", "value": fmt3(ks)})
    return b


def _sum_of(kd: list[float], spec: ET.Element, ks: list[float]) -> tuple[ET.Element, str]:
    """kd * diffuse + ks * spec as a blendbsdf (weights from the mean albedos)."""
    md, ms = sum(kd) / 3, sum(ks) / 3
    if ms <= 0:
        d = ET.Element("bsdf", {"type": "diffuse"})
        ET.SubElement(d, "rgb", {"name": "reflectance", "value": fmt3(kd)})
        return d, "diffuse only (specular reflectance 0)"
    if md <= 0:
        return spec, "specular only (diffuse reflectance 0)"
    t = ms / (md + ms)
    d = ET.Element("bsdf", {"type": "diffuse"})
    ET.SubElement(d, "rgb", {"name": "reflectance", "value": fmt3([c / (1 - t) for c in kd])})
    find_prop(spec, "specular_reflectance").set("value", fmt3([c / t for c in ks]))
    b = ET.Element("bsdf", {"type": "blendbsdf"})
    ET.SubElement(b, "float", {"name": "weight", "value": fmt(t)})
    b.append(d)
    b.append(spec)
    return b, f"blendbsdf(weight {t:.4g}) of diffuse and the specular lobe"


def _replace(parent: ET.Element, old: ET.Element, new: ET.Element) -> None:
    for k in ("id", "name"):
        if old.get(k) is not None:
            new.set(k, old.get(k))
    i = list(parent).index(old)
    parent.remove(old)
    parent.insert(i, new)


def fix_bsdfs(root: ET.Element, notes: list[str], approx: list[str]) -> None:
    parents = {c: p for p in root.iter() for c in p}
    for b in list(root.iter("bsdf")):
        t = b.get("type")
        label = f"bsdf {t}" + (f" '{b.get('id')}'" if b.get("id") else "")
        if t == "phong":
            kd = constant_rgb(find_prop(b, "diffuse_reflectance"), f"{label} diffuseReflectance") or [0.5] * 3
            ks = constant_rgb(find_prop(b, "specular_reflectance"), f"{label} specularReflectance") or [0.2] * 3
            n = float(find_prop(b, "exponent").get("value")) if find_prop(b, "exponent") is not None else 30.0
            alpha = math.sqrt(2.0 / (n + 2.0))
            new, how = _sum_of(kd, _beckmann_conductor(alpha, alpha, ks), ks)
            _replace(parents[b], b, new)
            approx.append(f"{label}: Phong (exponent {n:g}) -> Beckmann roughconductor (material none, "
                          f"alpha {alpha:.4g} = sqrt(2/(n+2))), {how}")
        elif t == "ward":
            kd = constant_rgb(find_prop(b, "diffuse_reflectance"), f"{label} diffuseReflectance") or [0.5] * 3
            ks = constant_rgb(find_prop(b, "specular_reflectance"), f"{label} specularReflectance") or [0.2] * 3
            a = find_prop(b, "alpha")
            au = find_prop(b, "alpha_u")
            av = find_prop(b, "alpha_v")
            a0 = float(a.get("value")) if a is not None else 0.1
            alpha_u = float(au.get("value")) if au is not None else a0
            alpha_v = float(av.get("value")) if av is not None else a0
            variant = find_prop(b, "variant")
            new, how = _sum_of(kd, _beckmann_conductor(alpha_u, alpha_v, ks), ks)
            _replace(parents[b], b, new)
            approx.append(f"{label}: Ward ({variant.get('value') if variant is not None else 'balanced'} variant, "
                          f"alpha {alpha_u:g}/{alpha_v:g}) -> Beckmann roughconductor (material none, same alphas), {how}")
        elif t in ("dielectric", "conductor", "plastic", "thindielectric"):
            for k in ("alpha", "alpha_u", "alpha_v", "distribution"):
                if del_prop(b, k) is not None:
                    notes.append(f"{label}: dropped '{k}' (0.6 ignores it on a smooth BSDF)")
        if t in ("conductor", "roughconductor"):
            if all(find_prop(b, k) is None for k in ("material", "eta", "k")):
                ET.SubElement(b, "string", {"name": "material", "value": "Cu"})
                notes.append(f"{label}: material Cu made explicit (0.6's default; Mitsuba 3's is a perfect mirror)")
            e = find_prop(b, "ext_eta")
            if e is not None:
                v = e.get("value", "").strip().lower()
                if v not in ("air", "vacuum", "1", "1.0", "1.000277"):
                    raise TranslateError(f"{label}: extEta={v} has no Mitsuba 3 equivalent")
                b.remove(e)
                notes.append(f"{label}: dropped extEta={v} (Mitsuba 3 conductors are in vacuum)")


def crease_normals(positions, faces, max_angle_deg: float):
    """Split vertices where the faces around them meet at more than `max_angle_deg` and give each
    copy the area-weighted normal of its faces (0.6's `maxSmoothAngle` rebuild). Returns
    (vertex index of each new vertex, new normals, new faces)."""
    import numpy as np
    p, f = np.asarray(positions, dtype=np.float64), np.asarray(faces, dtype=np.int64)
    fn = np.cross(p[f[:, 1]] - p[f[:, 0]], p[f[:, 2]] - p[f[:, 0]])  # |fn| = 2 area
    unit = fn / np.maximum(np.linalg.norm(fn, axis=1, keepdims=True), 1e-30)
    cos_max = math.cos(math.radians(max_angle_deg))
    incident: dict[int, list[tuple[int, int]]] = {}
    for fi in range(len(f)):
        for k in range(3):
            incident.setdefault(int(f[fi, k]), []).append((fi, k))
    src, normals = [], []
    new_faces = np.empty_like(f)
    for v, corners in incident.items():
        # Union-find of the faces around v: joined when their normals are within the angle.
        parent = list(range(len(corners)))

        def find(i):
            while parent[i] != i:
                parent[i] = parent[parent[i]]
                i = parent[i]
            return i
        for i in range(len(corners)):
            for j in range(i + 1, len(corners)):
                if float(unit[corners[i][0]] @ unit[corners[j][0]]) >= cos_max:
                    parent[find(i)] = find(j)
        groups: dict[int, list[int]] = {}
        for i in range(len(corners)):
            groups.setdefault(find(i), []).append(i)
        for members in groups.values():
            n = sum(fn[corners[i][0]] for i in members)
            n = n / max(float(np.linalg.norm(n)), 1e-30)
            idx = len(src)
            src.append(v)
            normals.append(n)
            for i in members:
                fi, k = corners[i]
                new_faces[fi, k] = idx
    return np.array(src), np.array(normals), new_faces


def crease_mesh_ply(sh: ET.Element, filename: str, angle: float, mesh_dir: str) -> str:
    """Load the mesh `sh` names with Mitsuba 3 (untransformed), rebuild its normals with the
    crease angle and write it as PLY into mesh_dir; returns the PLY path."""
    import mitsuba as mi
    import numpy as np
    if mi.variant() is None:
        mi.set_variant("scalar_rgb")
    d = {"type": sh.get("type"), "filename": filename}
    idx = find_prop(sh, "shape_index")
    if idx is not None:
        d["shape_index"] = int(idx.get("value"))
    mesh = mi.load_dict(d)
    params = mi.traverse(mesh)
    pos = np.array(params["vertex_positions"]).reshape(-1, 3)
    faces = np.array(params["faces"]).reshape(-1, 3)
    uv = np.array(params["vertex_texcoords"]).reshape(-1, 2) if mesh.has_vertex_texcoords() else None
    src, normals, new_faces = crease_normals(pos, faces, angle)
    out = mi.Mesh(f"crease_{os.path.basename(filename)}", len(src), len(new_faces),
                  has_vertex_normals=True, has_vertex_texcoords=uv is not None)
    op = mi.traverse(out)

    def put(key, arr, dtype):
        op[key] = type(op[key])(np.ascontiguousarray(arr.reshape(-1).astype(dtype)))
    put("vertex_positions", pos[src], np.float32)
    put("vertex_normals", normals, np.float32)
    if uv is not None:
        put("vertex_texcoords", uv[src], np.float32)
    put("faces", new_faces, np.uint32)
    op.update()
    os.makedirs(mesh_dir, exist_ok=True)
    path = os.path.join(mesh_dir, f"crease_{len(os.listdir(mesh_dir))}_{os.path.basename(filename)}.ply")
    out.write_ply(path)
    return path


def fix_shapes(root: ET.Element, notes: list[str], approx: list[str], scene_dir: str | None,
               mesh_dir: str | None) -> None:
    for sh in root.iter("shape"):
        p = find_prop(sh, "max_smooth_angle")
        if p is None:
            continue
        sh.remove(p)
        label = f"shape {sh.get('type')}" + (f" '{sh.get('id')}'" if sh.get("id") else "")
        fn = find_prop(sh, "filename")
        if mesh_dir is None or scene_dir is None or fn is None or sh.get("type") not in ("serialized", "obj", "ply"):
            approx.append(f"{label}: maxSmoothAngle={p.get('value')} dropped (Mitsuba 3 has no crease-angle "
                          "normals; the mesh's own normals, or smooth ones, are used)")
            continue
        filename = fn.get("value")
        if not os.path.isabs(filename):
            filename = os.path.normpath(os.path.join(scene_dir, filename))
        ply = crease_mesh_ply(sh, filename, float(p.get("value")), mesh_dir)
        sh.set("type", "ply")
        for k in ("shape_index", "face_normals", "flip_normals"):
            del_prop(sh, k)
        fn.set("value", ply)
        notes.append(f"{label}: maxSmoothAngle={p.get('value')}: normals rebuilt with that crease angle "
                     "(area-weighted per smooth group) into a temporary PLY")


def fix_textures(root: ET.Element, notes: list[str]) -> None:
    n = 0
    for tex in root.iter("texture"):
        p = find_prop(tex, "filter_type")
        if p is not None and p.get("value") not in ("bilinear", "nearest"):
            n += 1
            p.set("value", "bilinear")
    if n:
        notes.append(f"{n} bitmap filterType trilinear/ewa -> bilinear (Mitsuba 3 has no mipmaps)")


# ---------------------------------------------------------------------------------------------
# Entry points
# ---------------------------------------------------------------------------------------------

def translate_tree(root: ET.Element, notes: list[str], scene_dir: str | None = None,
                   mesh_dir: str | None = None) -> list[str]:
    """Translate a parsed Mitsuba 0.x scene (its `$params` already resolved) in place.
    Appends what it did to `notes`; returns the approximations (what renders differently).
    With `mesh_dir` (and `scene_dir`, the scene file's folder), meshes with `maxSmoothAngle` are
    rewritten as PLY files there with crease-angle normals (needs Mitsuba 3 to read the mesh);
    without it that parameter is dropped and reported as an approximation."""
    approx: list[str] = []
    upgrade_names(root, notes)
    fix_integrator(root, notes, approx)
    fix_srgb(root, notes)
    fix_sunsky(root, notes, approx)
    fix_bsdfs(root, notes, approx)
    fix_shapes(root, notes, approx, scene_dir, mesh_dir)
    fix_textures(root, notes)
    root.set("version", "3.0.0")
    return approx


def absolute_filenames(root: ET.Element, scene_dir: str) -> None:
    for e in root.iter("string"):
        if e.get("name") == "filename":
            v = e.get("value")
            if v and not os.path.isabs(v):
                e.set("value", os.path.normpath(os.path.join(scene_dir, v)))


def main(argv=None) -> int:
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from render import patch_scene  # the full pipeline (defaults, film, sampler) lives there

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene")
    ap.add_argument("-o", "--output", required=True, help="translated XML (never beside the scene)")
    ap.add_argument("--json", action="store_true", help="print notes and approximations as JSON")
    args = ap.parse_args(argv)
    out = os.path.abspath(args.output)
    if os.path.dirname(out) == os.path.dirname(os.path.abspath(args.scene)):
        raise SystemExit("refusing to write the translation beside the scene file")
    xml, info = patch_scene(args.scene)
    os.makedirs(os.path.dirname(out), exist_ok=True)
    with open(out, "w") as f:
        f.write(xml)
    if args.json:
        print(json.dumps({"notes": info["notes"], "approximations": info["approximations"],
                          "max_depth": info["max_depth"], "integrator": info["integrator"]}, indent=2))
    else:
        for n in info["notes"]:
            print("note:", n)
        for a in info["approximations"]:
            print("approximation:", a)
    return 0


if __name__ == "__main__":
    sys.exit(main())
