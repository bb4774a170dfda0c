#!/usr/bin/env python3
"""Mitsuba XML -> renderer-neutral scene dump (the input of lux_render.py). Runs in its own process.

    .venv-peers/bin/python bench/peers/mi_translate.py SCENE.xml OUT_DIR [--resolution WxH] [--max-depth D]

The scene is read by Mitsuba 3 itself (after tools/mitsuba/render.py's patch_scene, so the Mitsuba 0.5
dialect and `$param` defaults work exactly as for the Mitsuba renders), so geometry, transforms and
material parameters are the ones Mitsuba renders:

* meshes (OBJ, PLY, cube, ...): world-space vertex positions and faces as Mitsuba holds them
  (vertex normals too when the mesh has them);
* analytic shapes: `rectangle` -> 2 triangles, `sphere` -> a UV sphere (--sphere-segments) with exact
  normals, `disk` -> a triangle fan; winding chosen so the geometric normal is Mitsuba's normal;
* BSDFs: diffuse (reflectance), twosided(diffuse), conductor with eta=0, k=1 (a perfect mirror,
  Mitsuba's material="none") times specular_reflectance, dielectric (relative eta, specular
  reflectance/transmittance); anything else is an error, not a silent approximation;
* area emitters: constant RGB radiance;
* camera: perspective to_world, x_fov, film size, rfilter, plus the integrator's max_depth.

Writes OUT_DIR/scene.json and OUT_DIR/mesh_<i>.npz (float32 points, uint32 triangles, optional normals).
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.abspath(os.path.join(HERE, "..", ".."))
sys.path.insert(0, os.path.join(REPO, "tools", "mitsuba"))
import render as mi_render  # noqa: E402  (tools/mitsuba/render.py: patch_scene, parse_resolution)


def rgb_of(v) -> list[float]:
    a = np.array(v, dtype=np.float64).reshape(-1)
    if a.size == 1:
        a = np.repeat(a, 3)
    return [float(x) for x in a[:3]]


def class_name(obj) -> str:
    return str(obj).split("[", 1)[0].strip()


def params_of(obj) -> dict:
    import mitsuba as mi
    return {k: v for k, v in mi.traverse(obj).items()}


def bsdf_desc(bsdf) -> dict:
    name = class_name(bsdf)
    p = params_of(bsdf)
    if name in ("TwoSided", "TwoSidedBSDF"):
        # twosided(diffuse): both sides use brdf_0 (Mitsuba's one-argument form); LuxCore's matte is
        # two-sided anyway.
        inner = {k.split(".", 1)[1]: v for k, v in p.items() if k.startswith("brdf_0.")}
        if "reflectance.value" not in inner:
            raise SystemExit(f"unsupported twosided BSDF: {bsdf}")
        return {"type": "diffuse", "reflectance": rgb_of(inner["reflectance.value"]), "twosided": True}
    if name == "SmoothDiffuse":
        if "reflectance.value" not in p:
            raise SystemExit(f"unsupported (textured?) diffuse BSDF: {bsdf}")
        return {"type": "diffuse", "reflectance": rgb_of(p["reflectance.value"]), "twosided": False}
    if name == "SmoothConductor":
        eta = rgb_of(p.get("eta.value", 0.0))
        k = rgb_of(p.get("k.value", 1.0))
        if max(eta) != 0.0 or min(k) != 1.0:
            raise SystemExit(f"only perfect-mirror conductors (material='none') are translated: {bsdf}")
        return {"type": "mirror", "reflectance": rgb_of(p.get("specular_reflectance.value", 1.0))}
    if name == "SmoothDielectric":
        return {"type": "glass", "eta": float(np.array(p["eta"]).reshape(-1)[0]),
                "reflectance": rgb_of(p.get("specular_reflectance.value", 1.0)),
                "transmittance": rgb_of(p.get("specular_transmittance.value", 1.0))}
    raise SystemExit(f"BSDF {name} is not translated: {bsdf}")


def matrix_of(transform) -> np.ndarray:
    return np.array(transform.matrix, dtype=np.float64).reshape(4, 4)


def apply(m: np.ndarray, pts: np.ndarray) -> np.ndarray:
    return pts @ m[:3, :3].T + m[:3, 3]


def tessellate(kind: str, m: np.ndarray, segments: int):
    """(points, triangles, normals or None) of an analytic shape under to_world m (world space)."""
    if kind == "Rectangle":
        local = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], dtype=np.float64)
        tris = np.array([[0, 1, 2], [0, 2, 3]], dtype=np.int64)
        normals = None
        # Mitsuba's normal: the inverse transpose applied to +z; flip the winding when m mirrors.
        if np.linalg.det(m[:3, :3]) < 0:
            tris = tris[:, ::-1]
        return apply(m, local), tris, normals
    if kind == "Disk":
        n = segments
        ang = np.linspace(0, 2 * math.pi, n, endpoint=False)
        local = np.concatenate([[[0, 0, 0]], np.stack([np.cos(ang), np.sin(ang), np.zeros(n)], 1)])
        tris = np.array([[0, 1 + i, 1 + (i + 1) % n] for i in range(n)], dtype=np.int64)
        if np.linalg.det(m[:3, :3]) < 0:
            tris = tris[:, ::-1]
        return apply(m, local), tris, None
    if kind == "Sphere":
        center = m[:3, 3]
        lin = m[:3, :3]
        sv = np.linalg.svd(lin, compute_uv=False)
        if sv.max() - sv.min() > 1e-5 * sv.max():
            raise SystemExit("non-uniformly scaled sphere")
        r = float(sv.mean())
        nt, nphi = segments // 2, segments
        theta = np.linspace(0, math.pi, nt + 1)
        phi = np.linspace(0, 2 * math.pi, nphi, endpoint=False)
        st, ct = np.sin(theta)[:, None], np.cos(theta)[:, None]
        dirs = np.stack([st * np.cos(phi)[None, :], st * np.sin(phi)[None, :], np.broadcast_to(ct, (nt + 1, nphi))], -1)
        dirs = dirs.reshape(-1, 3)
        idx = lambda i, j: i * nphi + (j % nphi)  # noqa: E731
        tris = []
        for i in range(nt):
            for j in range(nphi):
                a, b, c, d = idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)
                # outward winding: (a, b, c) has normal along +dirs for a sphere parametrised this way
                if i != nt - 1:
                    tris.append((a, b, c))
                if i != 0:
                    tris.append((a, c, d))
        tris = np.array(tris, dtype=np.int64)
        pts = center + r * dirs
        # make sure the winding gives outward geometric normals
        p0, p1, p2 = pts[tris[:, 0]], pts[tris[:, 1]], pts[tris[:, 2]]
        ng = np.cross(p1 - p0, p2 - p0)
        out = np.einsum("ij,ij->i", ng, (p0 + p1 + p2) / 3 - center)
        if np.mean(out > 0) < 0.5:
            tris = tris[:, ::-1]
        return pts, tris, dirs.copy()
    raise SystemExit(f"shape {kind} is not translated")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene")
    ap.add_argument("out_dir")
    ap.add_argument("--resolution", type=mi_render.parse_resolution, default=None)
    ap.add_argument("--max-depth", type=int, default=None)
    ap.add_argument("--sphere-segments", type=int, default=128, help="longitude segments of a tessellated sphere")
    ap.add_argument("-D", dest="defines", action="append", default=[], metavar="NAME=VALUE")
    args = ap.parse_args(argv)

    overrides = dict(d.split("=", 1) for d in args.defines)
    xml, info = mi_render.patch_scene(args.scene, resolution=args.resolution, max_depth=args.max_depth,
                                      overrides=overrides)
    mi_render.load_env_file()
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    mi.set_log_level(mi.LogLevel.Error)
    with tempfile.TemporaryDirectory(prefix="octolux-peers-") as td:
        tmp = os.path.join(td, "scene.xml")
        with open(tmp, "w") as f:
            f.write(xml)
        scene = mi.load_file(tmp)

    os.makedirs(args.out_dir, exist_ok=True)
    shapes, bsdfs = [], []
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for i, sh in enumerate(scene.shapes()):
        kind = class_name(sh)
        if sh.is_mesh():
            pts = np.array(sh.vertex_positions_buffer(), dtype=np.float64).reshape(-1, 3)
            tris = np.array(sh.faces_buffer(), dtype=np.int64).reshape(-1, 3)
            nrm = (np.array(sh.vertex_normals_buffer(), dtype=np.float64).reshape(-1, 3)
                   if sh.has_vertex_normals() else None)
            source = "mesh"
        else:
            pts, tris, nrm = tessellate(kind, matrix_of(params_of(sh)["to_world"]), args.sphere_segments)
            source = f"tessellated {kind}"
        lo, hi = np.minimum(lo, pts.min(0)), np.maximum(hi, pts.max(0))
        mesh_file = f"mesh_{i:03d}.npz"
        arrays = {"points": pts.astype(np.float32), "triangles": tris.astype(np.uint32)}
        if nrm is not None:
            arrays["normals"] = nrm.astype(np.float32)
        np.savez(os.path.join(args.out_dir, mesh_file), **arrays)
        b = bsdf_desc(sh.bsdf())
        if b not in bsdfs:
            bsdfs.append(b)
        entry = {"id": sh.id(), "kind": kind, "source": source, "mesh": mesh_file,
                 "triangles": int(len(tris)), "bsdf": bsdfs.index(b)}
        if sh.emitter() is not None:
            e = sh.emitter()
            ep = params_of(e)
            if class_name(e) != "AreaLight" or "radiance.value" not in ep:
                raise SystemExit(f"emitter not translated: {e}")
            entry["radiance"] = rgb_of(ep["radiance.value"])
        shapes.append(entry)
    others = [class_name(e) for e in scene.emitters() if class_name(e) != "AreaLight"]
    if others:
        raise SystemExit(f"emitters not translated: {others}")

    sensor = scene.sensors()[0]
    if class_name(sensor) != "PerspectiveCamera":
        raise SystemExit(f"sensor {class_name(sensor)} not translated")
    sp = params_of(sensor)
    film = sensor.film()
    size = [int(x) for x in film.size()]
    m = matrix_of(sensor.world_transform())
    rf = film.rfilter()
    desc = {
        "source_scene": os.path.abspath(args.scene),
        "width": size[0], "height": size[1],
        "camera": {
            "to_world": m.tolist(),
            "origin": m[:3, 3].tolist(),
            "target": (m[:3, 3] + m[:3, 2]).tolist(),
            "up": m[:3, 1].tolist(),
            "x_fov": float(np.array(sp["x_fov"]).reshape(-1)[0]),
            "mirrored": bool(np.linalg.det(m[:3, :3]) < 0),
            "near_clip": float(sp["near_clip"]), "far_clip": float(sp["far_clip"]),
        },
        "rfilter": {"type": class_name(rf), "radius": float(rf.radius())},
        "max_depth": info["max_depth"],
        "integrator": info["integrator"],
        "bbox": [lo.tolist(), hi.tolist()],
        "bsdfs": bsdfs,
        "shapes": shapes,
        "patch_notes": info["notes"],
        "has_specular": any(b["type"] in ("mirror", "glass") for b in bsdfs),
    }
    with open(os.path.join(args.out_dir, "scene.json"), "w") as f:
        json.dump(desc, f, indent=1)
    print(json.dumps({"out": os.path.abspath(args.out_dir), "shapes": len(shapes), "bsdfs": len(bsdfs),
                      "triangles": sum(s["triangles"] for s in shapes), "has_specular": desc["has_specular"]}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
