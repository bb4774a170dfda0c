#!/usr/bin/env python3
"""Path-tracer speed: octolux vs Mitsuba 3 (llvm_ad_rgb, optionally scalar_rgb), samples per
second at 1 and 2 threads, and time to first sample, in one table of ratios.

    python3 bench/pt_speed.py                       # every case below, threads 1 and 2
    python3 bench/pt_speed.py --case bitterli:65 --case box --threads 2 --json target/pt_speed.json
    python3 bench/pt_speed.py --variants llvm_ad_rgb,scalar_rgb --skip-octolux
    python3 bench/pt_speed.py --variants llvm_ad_rgb,llvm_ad_rgb@avx2   # also as on an AVX2 machine

A variant `VARIANT@TARGET` runs VARIANT with Dr.Jit's LLVM backend compiled for TARGET
(tools/mitsuba/render.py --llvm-target): `llvm_ad_rgb@avx2` is what an AVX2 machine without
AVX-512 runs (8 lanes), measured on this host's cores, clock and caches.

Cases are SCENE[:MAX_DEPTH] with SCENE one of
  cornell-box, cornell-spheres  octolux's built-in scenes (Mitsuba renders the XML that
               `octolux export SCENE` writes), at --resolution;
  bitterli     ../shared/scenes/bitterli-cornell-box/scene_mitsuba.xml, at --resolution;
  cbox         ../shared/scenes/mitsuba-tutorials-cbox/cbox.xml, at --resolution;
  box, classroom, dining-room, sponza, torus, veach-lamp
               ../shared/scenes/bitterli-collection/SCENE/scene.xml at the resolution and
               max_depth of its reference (tests/refs/collection/manifest.json: 320 wide, the
               file's maxDepth);
  envmap, mirrored, wrappers, manylights
               the generated test scenes tests/scenes/SCENE/scene.xml (tools/make_testdata.py),
               likewise at their reference's resolution and max_depth;
  mesh1m       a generated height field of 1 002 528 triangles (binary PLY written to a temporary
               folder, never committed) under an area light and a constant sky, at --resolution.
  spheres1k    1000 analytic spheres of radius 0.04 at random (fixed seed) before a wall under a
               small area light (generated XML), at --resolution.
Without MAX_DEPTH a case takes its default (the reference's, or -1 for the built-in boxes).

Each (case, thread count) runs octolux then each Mitsuba variant, alternately. Reported:
  samples/s   wall-clock samples per second of the render phase (octolux: out.json
              `samples_per_second`; Mitsuba: tools/mitsuba/render.py, JIT variants after one
              untimed 1-spp warm-up pass so that kernel compilation is not counted);
  x           the speed-up from 1 to 2 threads (wall);
  cpu         samples per CPU-second (user+sys of the child process) x threads, less sensitive
              to other load on a shared machine (octolux: out.json `timings.render_cpu_s`,
              the process's CPU time around the render phase; Mitsuba: process_time() around
              the render);
  TTFS        time to first sample: octolux's load + prepare (acceleration build) + integrator
              build from out.json, against Mitsuba's `mi.load_file` (parse, meshes, Embree
              build) from render.py; both at the largest thread count. Wall seconds, and CPU
              seconds (user+sys): octolux's from a separate 4x4-pixel, 1-spp run of the same
              scene (nearly all of it loading), Mitsuba's from process_time() around load_file.
  per-sample efficiency (the cases with a reference in tests/refs/collection, at the largest
              thread count): relMSE of each renderer's image at this spp against the reference
              (`octolux compare`), less the reference's own noise σ²_ref (its manifest's
              self_noise.ref_rel_mse), times the render's CPU seconds: the error a CPU-second of
              that renderer buys at equal spp (lower is better; relMSE falls as 1/spp, so the
              product does not depend on spp). `eff ratio` = octolux / Mitsuba.
Needs tools/mitsuba/setup.sh for the Mitsuba half and `cargo build --release -p octolux-cli` for
octolux (or --build).
"""
from __future__ import annotations

import argparse
import json
import math
import os
import random
import resource
import statistics
import struct
import subprocess
import sys
import tempfile

REPO = os.path.abspath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
sys.path.insert(0, os.path.join(REPO, "tools", "mitsuba"))
import locations  # noqa: E402  (tools/mitsuba/locations.py: $OCTOLUX_SHARED or <repo>/../shared)

sys.path.insert(0, os.path.join(REPO, "bench"))
from machine import cpu_line  # noqa: E402

MI_PY = locations.mitsuba_python()
MI_RENDER = os.path.join(REPO, "tools", "mitsuba", "render.py")
COLLECTION_MANIFEST = os.path.join(REPO, "tests", "refs", "collection", "manifest.json")
sys.path.insert(0, os.path.join(REPO, "bench"))
import scenes  # noqa: E402  (bench/scenes.json: the one table of scene aliases)

# the speed bench's own depths (unbounded on the boxes, to measure long paths); files from the table
BUILTIN = {"cornell-box": -1, "cornell-spheres": 8}
FILES = {"bitterli": (scenes.get("bitterli")["scene"], -1), "cbox": (scenes.get("cbox")["scene"], 6)}
COLLECTION = ["box", "classroom", "dining-room", "sponza", "torus", "veach-lamp"]
TEST_SCENES = ["envmap", "mirrored", "wrappers", "manylights"]
DEFAULT_CASES = ["cornell-box", "cornell-spheres", "bitterli", "bitterli:65", "cbox"] + COLLECTION + TEST_SCENES + ["mesh1m", "spheres1k"]
VARIANTS = ["llvm_ad_rgb"]
MESH_N = 709  # vertices per side: 2 * 708^2 = 1 002 528 triangles


def log(msg: str) -> None:
    print(f"[pt_speed] {msg}", file=sys.stderr, flush=True)


def run(cmd: list[str], **kw) -> subprocess.CompletedProcess:
    log("$ " + " ".join(cmd))
    return subprocess.run(cmd, cwd=REPO, text=True, stdout=subprocess.PIPE, **kw)


def children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def scene_head(max_depth: int, origin: str) -> str:
    """The start of a generated scene's XML: the path integrator, a camera at `origin` looking
    at the origin, 16 independent samples on a 512x512 film."""
    return f"""<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="{max_depth}"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="40"/>
    <transform name="to_world"><lookat origin="{origin}" target="0, 0, 0" up="0, 1, 0"/></transform>
    <sampler type="independent"><integer name="sample_count" value="16"/></sampler>
    <film type="hdrfilm"><integer name="width" value="512"/><integer name="height" value="512"/></film>
  </sensor>
"""


def write_spheres_scene(folder: str) -> str:
    """1000 small analytic spheres before a wall, a small area light (Mitsuba 3 XML)."""
    rng = random.Random(1)
    spheres = []
    for _ in range(1000):
        x, y, z = (rng.uniform(-1.2, 1.2) for _ in range(3))
        spheres.append(f'  <shape type="sphere"><point name="center" x="{x:.4f}" y="{y:.4f}" z="{z:.4f}"/>'
                       '<float name="radius" value="0.04"/><ref id="w"/></shape>')
    xml = os.path.join(folder, "spheres1k.xml")
    with open(xml, "w") as f:
        f.write(scene_head(6, "0, 0, 4") + """  <bsdf type="diffuse" id="w"><rgb name="reflectance" value="0.7, 0.7, 0.7"/></bsdf>
  <shape type="rectangle"><transform name="to_world"><scale value="3"/><translate value="0, 0, -1.5"/></transform><ref id="w"/></shape>
  <shape type="rectangle">
    <transform name="to_world"><scale value="0.5"/><rotate x="1" angle="90"/><translate value="0, 1.4, 0"/></transform>
    <emitter type="area"><rgb name="radiance" value="10, 10, 10"/></emitter>
  </shape>
""" + "\n".join(spheres) + "\n</scene>\n")
    return xml


def write_mesh_scene(folder: str) -> str:
    """A 1M-triangle height field (binary PLY), an area light and a constant sky (Mitsuba 3 XML)."""
    n = MESH_N
    ply = os.path.join(folder, "terrain.ply")
    with open(ply, "wb") as f:
        f.write((f"ply\nformat binary_little_endian 1.0\nelement vertex {n * n}\nproperty float x\n"
                 f"property float y\nproperty float z\nelement face {2 * (n - 1) ** 2}\n"
                 "property list uchar int vertex_indices\nend_header\n").encode())
        verts = bytearray()
        for j in range(n):
            z = -1.0 + 2.0 * j / (n - 1)
            for i in range(n):
                x = -1.0 + 2.0 * i / (n - 1)
                y = 0.08 * math.sin(9.0 * x) * math.cos(7.0 * z) + 0.03 * math.sin(31.0 * (x + z))
                verts += struct.pack("<fff", x, y, z)
        f.write(verts)
        tri = struct.Struct("<Biii")
        faces = bytearray()
        for j in range(n - 1):
            for i in range(n - 1):
                a = j * n + i
                faces += tri.pack(3, a, a + n, a + 1)
                faces += tri.pack(3, a + 1, a + n, a + n + 1)
        f.write(faces)
    xml = os.path.join(folder, "mesh1m.xml")
    with open(xml, "w") as f:
        f.write(scene_head(-1, "0, 1.6, -2.6") + """  <shape type="ply">
    <string name="filename" value="terrain.ply"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.6, 0.55, 0.5"/></bsdf>
  </shape>
  <shape type="rectangle">
    <transform name="to_world"><scale value="0.4"/><rotate x="1" angle="90"/><translate value="0.5, 1.5, 0.3"/></transform>
    <emitter type="area"><rgb name="radiance" value="20, 19, 17"/></emitter>
  </shape>
  <emitter type="constant"><rgb name="radiance" value="0.3, 0.35, 0.45"/></emitter>
</scene>
""")
    return xml


def octolux_speed(binary: str, scene: str, spp: int, res: str, depth: int, threads: int, tmp: str,
                  verbose: bool, sampler: str, extra: list[str]) -> dict:
    out = os.path.join(tmp, "x.exr")
    c0 = children_cpu()
    p = run([binary, "render", scene, "--integrator", "path", "--spp", str(spp), "--resolution", res,
             "--max-depth", str(depth), "--threads", str(threads), "--sampler", sampler, "--quiet", "-o", out] + extra,
            stderr=None if verbose else subprocess.DEVNULL)
    cpu = children_cpu() - c0
    if p.returncode != 0:
        raise RuntimeError(f"octolux exited with {p.returncode}")
    with open(os.path.join(tmp, "x.json")) as f:
        stats = json.load(f)
    sps = float(stats["samples_per_second"])
    t = stats.get("timings", {})
    # CPU time of the render phase: octolux's own clock around it (timings.render_cpu_s), else
    # the process's CPU time scaled by render_s / total_s.
    if t.get("render_cpu_s") is not None:
        cpu_render = float(t["render_cpu_s"])
    else:
        cpu_render = cpu * t["render_s"] / t["total_s"] if t.get("total_s") else cpu
    samples = sps * t["render_s"] if t.get("render_s") else None
    ttfs = sum(t.get(k) or 0.0 for k in ("load_s", "prepare_s", "build_s"))
    return {"samples_per_second": sps, "samples_per_cpu_second": samples / cpu_render if samples and cpu_render > 0 else None,
            "ttfs_s": ttfs, "timings": t, "render_cpu_s": cpu_render, "image": out}


def octolux_ttfs_cpu(binary: str, scene: str, depth: int, threads: int, tmp: str) -> float | None:
    """CPU seconds (user+sys) of a 4x4-pixel, 1-spp render: the scene's load and preparation."""
    c0 = children_cpu()
    p = run([binary, "render", scene, "--integrator", "path", "--spp", "1", "--resolution", "4x4",
             "--max-depth", str(depth), "--threads", str(threads), "--quiet", "-o", os.path.join(tmp, "ttfs.exr")],
            stderr=subprocess.DEVNULL)
    return children_cpu() - c0 if p.returncode == 0 else None


def mitsuba_speed(xml: str, variant: str, spp: int, res: str, depth: int, threads: int, verbose: bool,
                  out: str | None = None) -> dict:
    # `VARIANT@TARGET`: the variant with its LLVM backend compiled for TARGET (render.py
    # --llvm-target, e.g. llvm_ad_rgb@avx2: 8 lanes, what an AVX2 machine runs)
    variant, _, target = variant.partition("@")
    cmd = [MI_PY, MI_RENDER, xml, "--variant", variant, "--spp", str(spp), "--resolution", res,
           "--max-depth", str(depth), "--threads", str(threads), "--sampler", "independent", "--quiet",
           "--passes", "1"] + (["-o", out] if out else []) + (["--llvm-target", target] if target else [])
    if not variant.startswith("scalar"):
        cmd += ["--warmup", "--warmup-spp", "1"]
    p = run(cmd, stderr=None if verbose else subprocess.DEVNULL)
    if p.returncode != 0:
        raise RuntimeError(f"render.py ({variant}) exited with {p.returncode}")
    r = json.loads(p.stdout.strip().splitlines()[-1])
    r["ttfs_s"] = r.get("load_s")
    r["ttfs_cpu_s"] = r.get("load_cpu_s")
    r["image"] = out
    return r


def rel_mse(binary: str, image: str | None, ref: str) -> float | None:
    """relMSE of `image` against `ref` by `octolux compare` (the tests' definition)."""
    if not image or not os.path.exists(image):
        return None
    p = subprocess.run([binary, "compare", image, ref], cwd=REPO, text=True, capture_output=True)
    try:
        return float(json.loads(p.stdout)["rel_mse"])
    except (ValueError, KeyError):
        return None


def med(values):
    v = [x for x in values if x]
    return statistics.median(v) if v else None


def collection_setup() -> tuple[dict, dict]:
    """Per collection and test scene: (resolution, max_depth) of its reference; and per scene
    with a reference: (reference EXR, its own noise σ²_ref)."""
    try:
        with open(COLLECTION_MANIFEST) as f:
            refs = json.load(f)["references"]
    except (OSError, KeyError, ValueError):
        refs = {}
    out, ref_files = {}, {}
    for name in COLLECTION + TEST_SCENES:
        r = refs.get(name, {})
        res = r.get("resolution") or [320, 240]
        out[name] = (f"{res[0]}x{res[1]}", int(r.get("max_depth", -1)))
        if r.get("file"):
            ref_files[name] = (os.path.join(os.path.dirname(COLLECTION_MANIFEST), r["file"]),
                               float(r.get("self_noise", {}).get("ref_rel_mse") or 0.0))
    return out, ref_files


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--case", action="append", help="SCENE[:MAX_DEPTH] (repeatable; default: %s)" % ", ".join(DEFAULT_CASES))
    ap.add_argument("--spp", type=int, default=16, help="spp of every render (default 16)")
    ap.add_argument("--resolution", default="512x512", help="for the cases without a reference resolution")
    ap.add_argument("--threads", default="1,2", help="comma-separated thread counts (default 1,2)")
    ap.add_argument("--sampler", default="independent", choices=["independent", "sobol"],
                    help="octolux's sampler (default independent, as Mitsuba's here)")
    ap.add_argument("--repeat", type=int, default=1, help="runs per measurement; the median is reported")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="passed to octolux render as --set (e.g. light_selection=power)")
    ap.add_argument("--variants", default=",".join(VARIANTS), help="Mitsuba variants (default llvm_ad_rgb)")
    ap.add_argument("--octolux", default=os.path.join(REPO, "target", "release", "octolux"))
    ap.add_argument("--build", action="store_true", help="cargo build --release -p octolux-cli first")
    ap.add_argument("--skip-octolux", action="store_true")
    ap.add_argument("--skip-mitsuba", action="store_true")
    ap.add_argument("--json", help="also write all results here")
    ap.add_argument("--verbose", action="store_true", help="show the renderers' stderr")
    args = ap.parse_args(argv)

    coll, ref_files = collection_setup()
    cases = []
    for c in args.case or DEFAULT_CASES:
        scene, _, depth = c.partition(":")
        if scene in BUILTIN:
            res, d = args.resolution, BUILTIN[scene]
        elif scene in FILES:
            res, d = args.resolution, FILES[scene][1]
        elif scene in coll:
            res, d = coll[scene]
        elif scene == "mesh1m":
            res, d = args.resolution, -1
        elif scene == "spheres1k":
            res, d = args.resolution, 6
        else:
            ap.error(f"unknown scene '{scene}'")
        cases.append((scene, int(depth) if depth else d, res))
    threads = [int(t) for t in args.threads.split(",") if t]
    variants = [v for v in args.variants.split(",") if v] if not args.skip_mitsuba else []

    if args.build and not args.skip_octolux:
        subprocess.run(["cargo", "build", "--release", "-p", "octolux-cli"], cwd=REPO, check=True)
    need_octolux_bin = not args.skip_octolux or (variants and any(s in BUILTIN for s, _, _ in cases))
    if need_octolux_bin and not os.path.exists(args.octolux):
        sys.exit(f"octolux binary not found: {args.octolux} (cargo build --release -p octolux-cli, or --build)")
    if variants and not os.path.exists(MI_PY):
        sys.exit(f"{MI_PY} missing: run tools/mitsuba/setup.sh")

    results = []
    load0 = os.getloadavg()
    with tempfile.TemporaryDirectory(prefix="octolux-ptspeed-") as tmp:
        exported: dict[tuple, str] = {}
        mesh: list[str] = []

        def scene_files(scene: str, depth: int) -> tuple[str, str]:
            """(what octolux renders, the XML Mitsuba renders)."""
            if scene in BUILTIN:
                key = (scene, depth)
                if key not in exported and variants:
                    d = os.path.join(tmp, f"export-{scene}-{depth}")
                    os.makedirs(d, exist_ok=True)
                    xml = os.path.join(d, "scene.xml")
                    p = run([args.octolux, "export", scene, "-o", xml, "--max-depth", str(depth)])
                    if p.returncode != 0:
                        raise RuntimeError("octolux export failed")
                    exported[key] = xml
                return scene, exported.get(key, "")
            if scene in FILES:
                return FILES[scene][0], FILES[scene][0]
            if scene == "spheres1k":
                xml = os.path.join(tmp, "spheres1k.xml")
                return (xml, xml) if os.path.exists(xml) else (write_spheres_scene(tmp),) * 2
            if scene == "mesh1m":
                if not mesh:
                    log(f"writing the {2 * (MESH_N - 1) ** 2}-triangle mesh")
                    mesh.append(write_mesh_scene(tmp))
                return mesh[0], mesh[0]
            f = scenes.get(scene)["scene"]
            return f, f

        for scene, depth, res in cases:
            row = {"scene": scene, "max_depth": depth, "resolution": res, "spp": args.spp}
            try:
                ours, theirs = scene_files(scene, depth)
            except Exception as e:
                log(f"{scene}: {e}")
                row["error"] = str(e)
                results.append(row)
                continue
            if not os.path.exists(ours) and scene not in BUILTIN:
                print(f"skip: {ours} missing", file=sys.stderr)
                continue
            ref = ref_files.get(scene)
            for t in threads:
                if not args.skip_octolux:
                    try:
                        extra = [a for kv in args.set for a in ("--set", kv)]
                        runs = [octolux_speed(args.octolux, ours, args.spp, res, depth, t, tmp, args.verbose, args.sampler, extra)
                                for _ in range(args.repeat)]
                        row[f"octolux@{t}"] = {"samples_per_second": med(r["samples_per_second"] for r in runs),
                                               "samples_per_cpu_second": med(r["samples_per_cpu_second"] for r in runs),
                                               "ttfs_s": med(r["ttfs_s"] for r in runs),
                                               "all": runs}
                        if t == max(threads):
                            if ref:
                                row[f"octolux@{t}"]["rel_mse"] = rel_mse(args.octolux, runs[-1]["image"], ref[0])
                                row[f"octolux@{t}"]["render_cpu_s"] = med(r["render_cpu_s"] for r in runs)
                            row[f"octolux@{t}"]["ttfs_cpu_s"] = med(octolux_ttfs_cpu(args.octolux, ours, depth, t, tmp)
                                                                    for _ in range(args.repeat))
                    except Exception as e:  # keep going: report what worked
                        log(f"octolux {scene}:{depth} failed: {e}")
                        row[f"octolux@{t}"] = {"error": str(e)}
                for v in variants:
                    try:
                        out = os.path.join(tmp, f"mi-{v}.exr") if (ref and t == max(threads)) else None
                        runs = [mitsuba_speed(theirs, v, args.spp, res, depth, t, args.verbose, out) for _ in range(args.repeat)]
                        row[f"{v}@{t}"] = {"samples_per_second": med(r["samples_per_second"] for r in runs),
                                           "samples_per_cpu_second": med(r.get("samples_per_cpu_second") for r in runs),
                                           "ttfs_s": med(r["ttfs_s"] for r in runs),
                                           "ttfs_cpu_s": med(r["ttfs_cpu_s"] for r in runs),
                                           "mean_rgb": runs[0]["mean_rgb"], "mitsuba_version": runs[0]["mitsuba_version"],
                                           "all": runs}
                        if out and os.path.exists(args.octolux):
                            row[f"{v}@{t}"]["rel_mse"] = rel_mse(args.octolux, out, ref[0])
                            row[f"{v}@{t}"]["render_cpu_s"] = med(r.get("render_cpu_s") for r in runs)
                    except Exception as e:
                        log(f"mitsuba {v} {scene}:{depth} failed: {e}")
                        row[f"{v}@{t}"] = {"error": str(e)}
            if ref:
                row["ref_rel_mse"] = ref[1]
            results.append(row)

    def get(row, key, t, field="samples_per_second"):
        return (row.get(f"{key}@{t}") or {}).get(field)

    def fmt(x, spec=".2f", unit=""):
        return f"{x:{spec}}{unit}" if x else "-"

    def ratio(a, b):
        return f"{a / b:.2f}x" if (a and b) else "-"

    tmax = max(threads)
    print(f"# {cpu_line()}")
    v = subprocess.run([args.octolux, "--version"], capture_output=True, text=True).stdout.strip().splitlines()
    print(f"# octolux {' / '.join(v[1:]) or 'version unknown'} (intersection: Embree from 65 536 triangles, its own dispatch)")
    print(f"# path tracer, {args.spp} spp; MS/s = 1e6 samples per wall second; cpu = per CPU-second x threads;"
          f" load average {load0[0]:.2f} at start, {os.getloadavg()[0]:.2f} at end")
    for v in variants:
        short = v.split("_")[0]
        cols = ["scene", "depth", "res"]
        for t in threads:
            cols += [f"oct@{t}", f"{short}@{t}", f"ratio@{t}"]
        if len(threads) > 1:
            cols += [f"oct x{threads[0]}->{tmax}", f"{short} x{threads[0]}->{tmax}"]
        cols += [f"cpu ratio@{tmax}", "TTFS oct s", f"TTFS {short} s", "TTFS ratio", "TTFS oct cpu s",
                 f"TTFS {short} cpu s", "TTFS cpu ratio", "relMSE oct", f"relMSE {short}", "ref σ²",
                 "eff oct", f"eff {short}", "eff ratio"]
        lines = [cols]
        for row in results:
            line = [row["scene"], str(row["max_depth"]), row["resolution"]]
            for t in threads:
                o, m = get(row, "octolux", t), get(row, v, t)
                line += [fmt(o and o / 1e6, ".3f"), fmt(m and m / 1e6, ".3f"), ratio(o, m)]
            if len(threads) > 1:
                line += [ratio(get(row, "octolux", tmax), get(row, "octolux", threads[0])),
                         ratio(get(row, v, tmax), get(row, v, threads[0]))]
            oc, mc = get(row, "octolux", tmax, "samples_per_cpu_second"), get(row, v, tmax, "samples_per_cpu_second")
            to, tm = get(row, "octolux", tmax, "ttfs_s"), get(row, v, tmax, "ttfs_s")
            line += [ratio(oc, mc), fmt(to, ".3f"), fmt(tm, ".3f"), ratio(tm, to)]
            to, tm = get(row, "octolux", tmax, "ttfs_cpu_s"), get(row, v, tmax, "ttfs_cpu_s")
            line += [fmt(to, ".3f"), fmt(tm, ".3f"), ratio(tm, to)]
            # per-sample efficiency: (relMSE - σ²_ref) x render CPU seconds
            ro, rm, sref = get(row, "octolux", tmax, "rel_mse"), get(row, v, tmax, "rel_mse"), row.get("ref_rel_mse")
            co, cm = get(row, "octolux", tmax, "render_cpu_s"), get(row, v, tmax, "render_cpu_s")
            eo = max(ro - sref, 0.0) * co if (ro is not None and sref is not None and co) else None
            em = max(rm - sref, 0.0) * cm if (rm is not None and sref is not None and cm) else None
            line += [fmt(ro, ".2e"), fmt(rm, ".2e"), fmt(sref, ".1e"), fmt(eo, ".2e"), fmt(em, ".2e"), ratio(eo, em)]
            lines.append(line)
        widths = [max(len(r[i]) for r in lines) for i in range(len(cols))]
        print(f"# octolux vs Mitsuba 3 {v} (ratio = octolux / Mitsuba speed; TTFS ratio = Mitsuba / octolux time)")
        for r in lines:
            print("| " + " | ".join(c.rjust(w) for c, w in zip(r, widths)) + " |")
    if not variants:
        for row in results:
            print(row["scene"], row["max_depth"], row["resolution"],
                  " ".join(f"{t}T {fmt(get(row, 'octolux', t), '.0f')}" for t in threads))
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"args": vars(args), "cpu": cpu_line(), "loadavg_start": load0, "loadavg_end": os.getloadavg(),
                       "results": results}, f, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
