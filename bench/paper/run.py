#!/usr/bin/env python3
"""Reproduce the paper's evaluation (Pacanowski, Granier & Schlick 2005, §9) with one command.

    python3 bench/paper/run.py [--scenes cornell-box cornell-spheres] [--photons 1000000] [--out out/paper]

Writes into --out:
  tables.md / tables.json   analogues of the paper's tables 1-3 for octree, Ward (photon samples)
                            and Christensen, from the same photons (same count, same seed):
                            t_c (photon tracing + cache build), t_v (render), F_m (bytes), sample
                            counts, and the relMSE against a path-traced reference (a column the
                            paper did not have);
  fig2-<scene>-*.png        irradiance maps of each method (same exposure) and the full octree render;
  fig3-<scene>-*.png        epsilon 0.2 vs 0.6, and an alpha sweep, with their relMSE in tables.md;
  fig4-*.png                octree built on a coarse sphere, rendered on a fine one (our own
                            geometry, so the command needs no shared folder), against a path-traced
                            reference of the fine scene.
References: tests/refs/<scene>.exr (Mitsuba 3) when present, else an octolux path render at --ref-spp.
"""
from __future__ import annotations

import argparse
import json
import math
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
BIN = ROOT / "target" / "release" / "octolux"
RES = "128x128"


def octolux(*args: str) -> None:
    subprocess.run([str(BIN), *args], check=True)


def render(scene: str, out: Path, integrator: str, spp: int, extra: list[str], max_depth: int) -> dict:
    octolux("render", scene, "--integrator", integrator, "--spp", str(spp), "--resolution", RES, "--max-depth", str(max_depth),
            "--seed", "1", "-q", "-o", str(out), *extra)
    return json.loads(out.with_suffix(".json").read_text())


def compare(img: Path, ref: Path) -> dict:
    return json.loads(subprocess.run([str(BIN), "compare", str(img), str(ref)], check=True, capture_output=True, text=True).stdout)


def sphere_ply(path: Path, center: tuple[float, float, float], radius: float, subdiv: int) -> int:
    """Write an icosphere as ascii PLY; returns its triangle count."""
    t = (1 + 5 ** 0.5) / 2
    verts = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    verts = [tuple(c / math.sqrt(sum(x * x for x in v)) for c in v) for v in verts]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6), (7, 1, 8),
             (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(subdiv):
        cache: dict[tuple[int, int], int] = {}

        def mid(a: int, b: int) -> int:
            key = (min(a, b), max(a, b))
            if key not in cache:
                m = [(verts[a][i] + verts[b][i]) / 2 for i in range(3)]
                n = math.sqrt(sum(x * x for x in m))
                verts.append(tuple(x / n for x in m))
                cache[key] = len(verts) - 1
            return cache[key]

        new = []
        for a, b, c in faces:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            new += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = new
    with path.open("w") as f:
        f.write(f"ply\nformat ascii 1.0\nelement vertex {len(verts)}\nproperty float x\nproperty float y\nproperty float z\n")
        f.write(f"property float nx\nproperty float ny\nproperty float nz\nelement face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n")
        for v in verts:
            f.write(" ".join(f"{center[i] + radius * v[i]:.6f}" for i in range(3)) + " " + " ".join(f"{x:.6f}" for x in v) + "\n")
        for a, b, c in faces:
            f.write(f"3 {a} {b} {c}\n")
    return len(faces)


def fig4_scenes(out: Path) -> tuple[Path, Path, int, int]:
    """cornell-box without blocks plus a diffuse sphere, coarse (80 triangles) and fine (20480)."""
    base = out / "fig4"
    base.mkdir(parents=True, exist_ok=True)
    octolux("export", "cornell-spheres", "-o", str(base / "box.xml"))
    xml = (base / "box.xml").read_text()
    # drop the two analytic spheres of cornell-spheres, keep the box and the light
    xml = re.sub(r"\s*<shape type=\"sphere\".*?</shape>", "", xml, flags=re.S)
    counts = []
    paths = []
    for name, sub in (("coarse", 1), ("fine", 5)):
        counts.append(sphere_ply(base / f"sphere_{name}.ply", (278.0, 120.0, 280.0), 120.0, sub))
        shape = f'<shape type="ply"><string name="filename" value="sphere_{name}.ply"/><bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.8, 0.8"/></bsdf></shape>'
        p = base / f"scene_{name}.xml"
        p.write_text(xml.replace("</scene>", shape + "\n</scene>"))
        paths.append(p)
    return paths[0], paths[1], counts[0], counts[1]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", nargs="+", default=["cornell-box", "cornell-spheres"])
    ap.add_argument("--photons", type=int, default=1_000_000)
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--ref-spp", type=int, default=1024)
    ap.add_argument("--out", type=Path, default=ROOT / "out" / "paper")
    args = ap.parse_args()
    if not BIN.exists():
        subprocess.run(["cargo", "build", "--release", "-p", "octolux-cli"], cwd=ROOT, check=True)
    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    manifest = json.loads((ROOT / "tests" / "refs" / "manifest.json").read_text())["references"]
    ph = ["--photons", str(args.photons)]
    results: dict = {"photons": args.photons, "spp": args.spp, "resolution": RES, "scenes": {}}
    md = [f"# The paper's evaluation, reproduced\n\n{args.photons} photons (same photons and seed for every method), {RES}, {args.spp} spp. "
          "relMSE against a path-traced reference.\n"]
    for scene in args.scenes:
        max_depth = int(manifest[scene]["max_depth"]) if scene in manifest else -1
        ref = ROOT / "tests" / "refs" / f"{scene}.exr"
        if not ref.exists():
            ref = out / f"ref-{scene}.exr"
            render(scene, ref, "path", args.ref_spp, [], max_depth)
        rows = {}
        for method in ("octree", "ward", "christensen"):
            img = out / f"{scene}-{method}.exr"
            st = render(scene, img, method, args.spp, ph, max_depth)
            b = st["build"]
            rows[method] = {
                "t_c_s": b["t_c_s"], "t_v_s": st["timings"]["render_s"], "F_m_bytes": b["bytes"],
                "samples": {k: b[k] for k in ("m_e", "m_a") if k in b} | ({"m_v": b["global"]["valid_leaves"]} if method == "octree" else {}),
                "rel_mse": compare(img, ref)["rel_mse"],
            }
            render(scene, out / f"fig2-{scene}-{method}-irradiance.exr", method, 4, ph + ["--view", "irradiance"], max_depth)
        octolux("render", scene, "--integrator", "octree", "--spp", str(args.spp), "--resolution", RES, "--max-depth", str(max_depth), "-q",
                "-o", str(out / f"fig2-{scene}-octree-render.exr"), *ph)
        fig3 = {}
        def both(key: str, v: str) -> list[str]:  # the key in the global and the caustic octree
            return ["--set", f"global.{key}={v}", "--set", f"caustic.{key}={v}"]

        for label, extra in (("epsilon-0.2", both("epsilon", "0.2")), ("epsilon-0.6", both("epsilon", "0.6")),
                             ("alpha-0.5", both("alpha", "0.5")), ("alpha-1.0", both("alpha", "1.0")), ("alpha-1.5", both("alpha", "1.5")),
                             ("alpha-3.0", both("alpha", "3.0"))):
            img = out / f"fig3-{scene}-{label}.exr"
            render(scene, img, "octree", args.spp, ph + extra, max_depth)
            fig3[label] = compare(img, ref)["rel_mse"]
        results["scenes"][scene] = {"table": rows, "fig3_rel_mse": fig3, "reference": str(ref.relative_to(ROOT) if ref.is_relative_to(ROOT) else ref)}
        md.append(f"\n## {scene}\n\n| method | t_c (s) | t_v (s) | F_m (KB) | samples | relMSE |\n|---|---|---|---|---|---|")
        for m, r in rows.items():
            md.append(f"| {m} | {r['t_c_s']:.3f} | {r['t_v_s']:.3f} | {r['F_m_bytes'] / 1024:.0f} | {r['samples']} | {r['rel_mse']:.2e} |")
        md.append("\nFigure 2: " + " ".join(f"![{m}](fig2-{scene}-{m}-irradiance.png)" for m in rows) + f" ![octree render](fig2-{scene}-octree-render.png)\n")
        md.append("Figure 3 (octree relMSE): " + ", ".join(f"{k} {v:.2e}" for k, v in fig3.items()) + "\n")
        md.append(" ".join(f"![{k}](fig3-{scene}-{k}.png)" for k in fig3) + "\n")
    # figure 4
    coarse, fine, n_coarse, n_fine = fig4_scenes(out)
    fref = out / "fig4-reference-fine.exr"
    render(str(fine), fref, "path", args.ref_spp, [], -1)
    f4 = {}
    for label, cache in (("built-on-fine", fine), ("built-on-coarse", coarse)):
        img = out / f"fig4-{label}.exr"
        render(str(fine), img, "octree", args.spp, ph + ["--cache-scene", str(cache)], -1)
        f4[label] = compare(img, fref)["rel_mse"]
    results["fig4"] = {"coarse_triangles": n_coarse, "fine_triangles": n_fine, "rel_mse": f4}
    md.append(f"\n## Figure 4: cache built on a coarse sphere ({n_coarse} triangles), rendered on a fine one ({n_fine})\n")
    md.append("relMSE against a path-traced reference of the fine scene: " + ", ".join(f"{k} {v:.2e}" for k, v in f4.items()) + "\n")
    md.append("![fine](fig4-built-on-fine.png) ![coarse](fig4-built-on-coarse.png) ![reference](fig4-reference-fine.png)\n")
    (out / "tables.json").write_text(json.dumps(results, indent=2))
    (out / "tables.md").write_text("\n".join(md) + "\n")
    print((out / "tables.md").read_text())
    return 0


if __name__ == "__main__":
    sys.exit(main())
