#!/usr/bin/env python3
"""Render a Mitsuba scene file with Mitsuba 3 and write a float32 RGB EXR.

Usage (after tools/mitsuba/setup.sh):

    .venv-mitsuba/bin/python tools/mitsuba/render.py SCENE.xml -o out.exr \
        [--variant llvm_ad_rgb|scalar_rgb|...] [--spp N] [--resolution WxH|N] \
        [--max-depth D] [--seed S] [--threads T] [--sampler keep|independent] \
        [--warmup] [-D name=value ...] [--write-patched patched.xml]

Prints one JSON object on stdout (wall time, samples/s, mean per channel, ...); logs go to stderr.

The scene file is never modified. A patched temporary copy is written and loaded instead:
  * `$name` parameters are resolved from the file's <default> tags (and -D overrides);
  * Mitsuba 0.5/0.6 dialect (scene version < 2): camelCase property names -> snake_case,
    ldrfilm -> hdrfilm (LDR-only parameters dropped), sobol/halton/hammersley/ldsampler ->
    independent, Mitsuba-0.x-only parameters (strictNormals, ...) dropped;
  * the film is reduced to what defines the picture (size, crop, rfilter, sample_border) and
    set to RGB float32 output;
  * --resolution keeps the framing: with an unchanged aspect ratio only the size changes; when
    the aspect ratio changes the field of view is pinned to the axis the original file referred to
    (fov_axis smaller/larger/diagonal resolved against the original size);
  * --max-depth is written into the integrator (path-like integrators);
  * relative `filename` values are made absolute so the copy loads from anywhere.

Large sample counts are split into passes (each with its own seed) whose images are averaged,
which keeps the JIT variants' wavefronts bounded (--max-wavefront).
"""
from __future__ import annotations

import argparse
import copy
import json
import math
import os
import re
import sys
import tempfile
import time
import xml.etree.ElementTree as ET

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from translate import (PROPERTY_TAGS, absolute_filenames, camel_to_snake, find_prop,  # noqa: E402,F401
                       translate_tree)

# Mitsuba 0.x samplers that Mitsuba 3 does not have (or whose semantics differ).
OLD_SAMPLERS = {"sobol", "halton", "hammersley", "ldsampler"}
FILM_KEEP = {
    "width", "height", "crop_offset_x", "crop_offset_y", "crop_width", "crop_height",
    "sample_border",
}
MI3_DEFAULT_FILM = (768, 576)


def log(msg: str) -> None:
    print(f"[render.py] {msg}", file=sys.stderr, flush=True)


def parse_version(v: str | None) -> tuple[int, ...]:
    if not v:
        return (3, 0, 0)
    try:
        return tuple(int(x) for x in v.split("."))
    except ValueError:
        return (3, 0, 0)


def set_prop(elem: ET.Element, tag: str, name: str, value) -> None:
    p = find_prop(elem, name)
    if p is None:
        p = ET.SubElement(elem, tag)
        p.set("name", name)
    p.tag = tag
    p.set("value", str(value))


def del_prop(elem: ET.Element, name: str) -> None:
    for c in list(elem):
        if c.tag in PROPERTY_TAGS and c.get("name") == name:
            elem.remove(c)


def resolve_params(root: ET.Element, overrides: dict[str, str]) -> dict[str, str]:
    params: dict[str, str] = {}
    for d in list(root):
        if d.tag == "default":
            params[d.get("name")] = d.get("value")
            root.remove(d)
    params.update(overrides)
    pat = re.compile(r"\$([A-Za-z_][A-Za-z0-9_]*)")

    def sub(s: str) -> str:
        return pat.sub(lambda m: params.get(m.group(1), m.group(0)), s)

    for e in root.iter():
        for k, v in list(e.attrib.items()):
            if "$" in v:
                e.set(k, sub(v))
    return params


def get_num(elem: ET.Element | None, name: str, default):
    if elem is None:
        return default
    p = find_prop(elem, name)
    if p is None:
        return default
    return type(default)(float(p.get("value")))


def fix_framing(sensor: ET.Element, w0: int, h0: int, w: int, h: int, notes: list[str]) -> None:
    if w * h0 == h * w0:
        return  # same aspect ratio: every fov_axis mode keeps the framing
    fovp = find_prop(sensor, "fov")
    if fovp is None:
        notes.append(f"WARNING aspect ratio changed ({w0}x{h0} -> {w}x{h}) and the sensor has no "
                     "explicit fov (focal_length or default); framing may differ")
        return
    fov = float(fovp.get("value"))
    axp = find_prop(sensor, "fov_axis")
    axis = (axp.get("value") if axp is not None else "x").lower()
    if axis == "smaller":
        axis = "x" if w0 <= h0 else "y"
    elif axis == "larger":
        axis = "x" if w0 >= h0 else "y"
    elif axis == "diagonal":
        t = math.tan(math.radians(fov) / 2) * w0 / math.hypot(w0, h0)
        fov = math.degrees(2 * math.atan(t))
        axis = "x"
    set_prop(sensor, "float", "fov", repr(fov))
    set_prop(sensor, "string", "fov_axis", axis)
    notes.append(f"WARNING aspect ratio changed ({w0}x{h0} -> {w}x{h}): pinned fov={fov:.6g} on axis {axis}")


def patch_scene(path: str, *, resolution=None, max_depth=None, spp=None, sampler_mode="keep",
                overrides=None, rfilter=None, mesh_dir=None) -> tuple[str, dict]:
    """Return (patched xml text, info dict)."""
    tree = ET.parse(path)
    root = tree.getroot()
    if root.tag != "scene":
        raise SystemExit(f"{path}: root element is <{root.tag}>, expected <scene>")
    scene_dir = os.path.dirname(os.path.abspath(path))
    notes: list[str] = []
    version = root.get("version")
    params = resolve_params(root, overrides or {})
    approximations: list[str] = []
    if parse_version(version)[0] < 2:
        notes.append(f"scene version {version}: translating the Mitsuba 0.x dialect (translate.py)")
        approximations = translate_tree(root, notes, scene_dir, mesh_dir)

    absolute_filenames(root, scene_dir)

    sensors = [e for e in root if e.tag == "sensor"]
    if not sensors:
        raise SystemExit(f"{path}: no <sensor>")
    sensor = sensors[0]

    # Sampler.
    sampler = sensor.find("sampler")
    if sampler is None:
        sampler = ET.SubElement(sensor, "sampler", {"type": "independent"})
    stype = sampler.get("type")
    if stype in OLD_SAMPLERS or (sampler_mode == "independent" and stype != "independent"):
        notes.append(f"sampler {stype} -> independent")
        count = find_prop(sampler, "sample_count")
        for c in list(sampler):
            sampler.remove(c)
        sampler.set("type", "independent")
        if count is not None:
            sampler.append(count)
    if spp is not None:
        set_prop(sampler, "integer", "sample_count", spp)
    spp_eff = get_num(sampler, "sample_count", 4)

    # Film.
    film = sensor.find("film")
    if film is None:
        film = ET.SubElement(sensor, "film", {"type": "hdrfilm"})
    if film.get("type") not in ("hdrfilm", "ldrfilm"):
        notes.append(f"WARNING film type {film.get('type')} replaced by hdrfilm")
    if film.get("type") != "hdrfilm":
        notes.append(f"film {film.get('type')} -> hdrfilm")
    film.set("type", "hdrfilm")
    for c in list(film):
        if c.tag in PROPERTY_TAGS and c.get("name") not in FILM_KEEP:
            film.remove(c)
    w0 = get_num(film, "width", MI3_DEFAULT_FILM[0])
    h0 = get_num(film, "height", MI3_DEFAULT_FILM[1])
    w, h = (w0, h0) if resolution is None else resolution
    if (w, h) != (w0, h0):
        fix_framing(sensor, w0, h0, w, h, notes)
        for key, scale in (("crop_offset_x", w / w0), ("crop_width", w / w0),
                           ("crop_offset_y", h / h0), ("crop_height", h / h0)):
            p = find_prop(film, key)
            if p is not None:
                p.set("value", str(int(round(float(p.get("value")) * scale))))
                notes.append(f"WARNING scaled film.{key}")
    set_prop(film, "integer", "width", w)
    set_prop(film, "integer", "height", h)
    set_prop(film, "string", "pixel_format", "rgb")
    set_prop(film, "string", "component_format", "float32")
    if rfilter is not None:
        for c in list(film):
            if c.tag == "rfilter":
                film.remove(c)
        ET.SubElement(film, "rfilter", {"type": rfilter})
    rf = film.find("rfilter")
    rfilter_eff = rf.get("type") if rf is not None else "gaussian (default)"

    # Integrator.
    integrators = [e for e in root if e.tag == "integrator"]
    if not integrators:
        integrators = [ET.Element("integrator", {"type": "path"})]
        root.insert(0, integrators[0])
        notes.append("no integrator: added path")
    depth_eff = None
    for integ in integrators[0].iter("integrator"):
        has = find_prop(integ, "max_depth") is not None
        if max_depth is not None and (has or integ.get("type") in ("path", "volpath", "volpathmis", "prb", "direct_projective", "prb_projective")):
            set_prop(integ, "integer", "max_depth", max_depth)
        if depth_eff is None and find_prop(integ, "max_depth") is not None:
            depth_eff = get_num(integ, "max_depth", -1)
    if depth_eff is None and integrators[0].get("type") in ("path", "volpath"):
        depth_eff = -1  # Mitsuba 3 default

    info = {
        "source_version": version,
        "integrator": integrators[0].get("type"),
        "max_depth": depth_eff,
        "width": w,
        "height": h,
        "spp": spp_eff,
        "rfilter": rfilter_eff,
        "sampler": sampler.get("type"),
        "params": params,
        "notes": notes,
        "approximations": approximations,
    }
    ET.indent(tree)
    return ET.tostring(root, encoding="unicode"), info


def parse_resolution(s: str) -> tuple[int, int]:
    if "x" in s.lower():
        a, b = s.lower().split("x")
        return int(a), int(b)
    return int(s), int(s)


def load_env_file() -> None:
    """Pick up DRJIT_LIBLLVM_PATH / OCTOLUX_MI_VARIANT written by setup.sh (unless already set)."""
    here = os.path.dirname(os.path.abspath(__file__))
    for cand in (os.path.join(sys.prefix, "mitsuba-env.sh"),
                 os.path.join(here, "..", "..", ".venv-mitsuba", "mitsuba-env.sh")):
        if os.path.exists(cand):
            for line in open(cand):
                m = re.match(r"\s*export\s+(\w+)='([^']*)'", line)
                if m:
                    os.environ.setdefault(m.group(1), m.group(2))
            return


def default_variant() -> str:
    return os.environ.get("OCTOLUX_MI_VARIANT", "llvm_ad_rgb")


# `--llvm-target` presets: (LLVM CPU, features, vector width). `avx2`: a Haswell-class core without
# AVX-512, the JIT's 8 lanes instead of an AVX-512 host's 16.
LLVM_TARGETS = {
    "avx2": ("haswell", "+sse4.2,+avx,+avx2,+fma,+f16c,+bmi,+bmi2,+popcnt,+lzcnt,+movbe,-avx512f", 8),
}


def set_llvm_target(spec: str) -> int:
    """Point Dr.Jit's LLVM backend at another CPU (`jit_llvm_set_target` of libdrjit-core, by
    ctypes: Dr.Jit's Python API does not expose it): a preset of LLVM_TARGETS or
    CPU:FEATURES:WIDTH. Returns the vector width the backend then uses."""
    import ctypes

    import drjit as dr

    if spec in LLVM_TARGETS:
        cpu, features, width = LLVM_TARGETS[spec]
    else:
        try:
            cpu, features, w = spec.split(":")
            width = int(w)
        except ValueError:
            raise SystemExit(f"--llvm-target {spec!r}: expected one of {sorted(LLVM_TARGETS)} or CPU:FEATURES:WIDTH")
    lib = ctypes.CDLL(os.path.join(os.path.dirname(dr.__file__), "libdrjit-core.so"))
    try:
        set_target, get_width = lib._Z19jit_llvm_set_targetPKcS0_j, lib._Z21jit_llvm_vector_widthv
    except AttributeError:
        raise SystemExit(f"--llvm-target: this Dr.Jit ({dr.__version__}) has no jit_llvm_set_target to call")
    set_target.argtypes, set_target.restype = [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_uint32], None
    get_width.restype = ctypes.c_uint32
    set_target(cpu.encode(), features.encode(), width)
    if get_width() != width:
        raise SystemExit(f"--llvm-target {spec!r}: the backend kept vector width {get_width()}")
    return width


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene")
    ap.add_argument("-o", "--output", help="output EXR (float32 RGB)")
    ap.add_argument("--variant", default=None, help="Mitsuba variant (default: $OCTOLUX_MI_VARIANT or llvm_ad_rgb)")
    ap.add_argument("--spp", type=int, default=None, help="samples per pixel (default: the scene's)")
    ap.add_argument("--resolution", type=parse_resolution, default=None, help="WxH or N (NxN)")
    ap.add_argument("--max-depth", type=int, default=None)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--threads", type=int, default=None, help="CPU threads (default: all)")
    ap.add_argument("--sampler", choices=["keep", "independent"], default="keep",
                    help="keep the scene's sampler (0.x-only ones become independent) or force independent")
    ap.add_argument("--rfilter", default=None, help="override the reconstruction filter type")
    ap.add_argument("--max-wavefront", type=int, default=1 << 24,
                    help="max samples (pixels*spp) per pass for JIT variants (default 2^24)")
    ap.add_argument("--passes", type=int, default=None, help="force this many passes")
    ap.add_argument("--warmup", action="store_true",
                    help="render one untimed pass first (JIT compile, caches), then the timed render")
    ap.add_argument("--warmup-spp", type=int, default=None,
                    help="spp of the warm-up pass (default: that of the first timed pass)")
    ap.add_argument("-D", dest="defines", action="append", default=[], metavar="NAME=VALUE",
                    help="override a <default> parameter of the scene")
    ap.add_argument("--write-patched", help="also save the patched XML here")
    ap.add_argument("--quiet", action="store_true", help="Mitsuba log level: errors only")
    ap.add_argument("--llvm-target", default=None, metavar="PRESET|CPU:FEATURES:WIDTH",
                    help="LLVM variants: compile for another CPU than the host's, e.g. `avx2` (8 lanes, no "
                         "AVX-512) to measure what an AVX2 machine would run")
    args = ap.parse_args(argv)

    overrides = dict(d.split("=", 1) for d in args.defines)
    load_env_file()
    import drjit as dr
    import mitsuba as mi
    import numpy as np

    variant = args.variant or default_variant()
    if args.threads:
        dr.set_thread_count(args.threads)
    mi.set_variant(variant)
    llvm_width = set_llvm_target(args.llvm_target) if args.llvm_target else None
    mi.set_log_level(mi.LogLevel.Error if args.quiet else mi.LogLevel.Warn)
    fr = mi.file_resolver() if hasattr(mi, "file_resolver") else mi.Thread.thread().file_resolver()
    fr.prepend(os.path.dirname(os.path.abspath(args.scene)))

    with tempfile.TemporaryDirectory(prefix="octolux-mi-") as td:
        xml, info = patch_scene(args.scene, resolution=args.resolution, max_depth=args.max_depth,
                                spp=args.spp, sampler_mode=args.sampler, overrides=overrides,
                                rfilter=args.rfilter, mesh_dir=os.path.join(td, "meshes"))
        for n in info["notes"]:
            log(n)
        for a in info["approximations"]:
            log("APPROXIMATION " + a)
        if args.write_patched:
            with open(args.write_patched, "w") as f:
                f.write(xml)
        tmp = os.path.join(td, "scene.xml")
        with open(tmp, "w") as f:
            f.write(xml)
        t0, c0 = time.perf_counter(), time.process_time()
        scene = mi.load_file(tmp)
        load_s, load_cpu_s = time.perf_counter() - t0, time.process_time() - c0

    w, h, spp = info["width"], info["height"], info["spp"]
    jit = not variant.startswith("scalar")
    if args.passes:
        passes = args.passes
    elif jit:
        passes = max(1, math.ceil(w * h * spp / args.max_wavefront))
    else:
        passes = 1
    # Equal pass sizes (the last takes the remainder).
    per = [spp // passes + (1 if i < spp % passes else 0) for i in range(passes)]
    if args.seed >= (1 << 16) or passes >= (1 << 16):
        raise SystemExit("seed and pass count must be < 65536")

    def seed_of(i: int) -> int:
        return args.seed if passes == 1 else (args.seed << 16) + i

    def render_pass(s: int, n: int):
        img = mi.render(scene, seed=s, spp=n)
        a = np.array(img, dtype=np.float32)  # forces evaluation
        return a

    warm_s = None
    if args.warmup:
        t0 = time.perf_counter()
        render_pass(0xFFFF, args.warmup_spp or per[0])
        warm_s = time.perf_counter() - t0

    t0 = time.perf_counter()
    c0 = time.process_time()
    acc = None
    for i, n in enumerate(per):
        a = render_pass(seed_of(i), n).astype(np.float64) * n
        acc = a if acc is None else acc + a
    render_s = time.perf_counter() - t0
    render_cpu_s = time.process_time() - c0
    img = (acc / spp).astype(np.float32)[..., :3]

    if args.output:
        os.makedirs(os.path.dirname(os.path.abspath(args.output)), exist_ok=True)
        bmp = mi.Bitmap(np.ascontiguousarray(img), pixel_format=mi.Bitmap.PixelFormat.RGB)
        bmp.write(args.output)

    out = {
        "scene": os.path.abspath(args.scene),
        "output": os.path.abspath(args.output) if args.output else None,
        "variant": variant,
        "mitsuba_version": mi.__version__,
        "llvm_target": args.llvm_target,
        "llvm_vector_width": llvm_width,
        "drjit_version": dr.__version__,
        "threads": dr.thread_count(),
        "width": w,
        "height": h,
        "spp": spp,
        "passes": passes,
        "seed": args.seed,
        "max_depth": info["max_depth"],
        "integrator": info["integrator"],
        "rfilter": info["rfilter"],
        "sampler": info["sampler"],
        "load_s": round(load_s, 4),
        "load_cpu_s": round(load_cpu_s, 4),
        "warmup_s": None if warm_s is None else round(warm_s, 4),
        "render_s": round(render_s, 4),
        "render_cpu_s": round(render_cpu_s, 4),
        "samples_per_second": w * h * spp / render_s,
        "samples_per_cpu_second": w * h * spp / render_cpu_s if render_cpu_s > 0 else None,
        "mean_rgb": [float(x) for x in img.reshape(-1, 3).astype(np.float64).mean(axis=0)],
        "finite": bool(np.isfinite(img).all()),
        "patch_notes": info["notes"],
        "approximations": info["approximations"],
    }
    print(json.dumps(out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
