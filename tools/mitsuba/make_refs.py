#!/usr/bin/env python3
"""Make the committed Mitsuba 3 reference images in tests/refs/ and tests/refs/manifest.json.

    tools/mitsuba/setup.sh                                   # once
    .venv-mitsuba/bin/python tools/mitsuba/make_refs.py      # all references
    .venv-mitsuba/bin/python tools/mitsuba/make_refs.py --only bitterli --spp 8192

For every reference it renders (all 128x128, independent sampler, the scene's own rfilter):
  1. the reference itself       (spp = --spp, seed REF_SEED)           -> tests/refs/<name>.exr
  2. a second, independent one  (same spp, seed CHECK_SEED)             -> temp; relMSE(2, 1) is the
     reference's own noise level (twice its variance, in relMSE units);
  3. a 256-spp render           (seed LOW_SEED)                          -> temp; relMSE(3, 1) is what a
     typical test render at 256 spp is expected to show against the reference.
and records spp, max_depth, variant, versions, wall time, both relMSEs, the mean per channel and
the EXR's sha256 in tests/refs/manifest.json (entries for references not remade are kept).

relMSE = mean over pixels and channels of (a-b)^2 / (b^2 + 1e-2), b = the reference.

Built-in octolux scenes are first exported to Mitsuba XML with
    cargo run --release -p octolux-cli -- export <scene> -o <tmp>/scene.xml --max-depth D
(--octolux BIN uses an already built binary instead of cargo run).

--collection makes tests/refs/collection/*.exr and its manifest.json instead: the scenes of
../shared/scenes/bitterli-collection (Mitsuba 0.6 files, translated for Mitsuba 3 by translate.py)
and the generated test scenes of tests/scenes/ (tools/make_testdata.py), each 320 pixels wide
(COLLECTION_WIDTHS: `wrappers` 160) with
the file's aspect ratio and max depth, independent sampler, the file's rfilter:
    .venv-mitsuba/bin/python tools/mitsuba/make_refs.py --collection [--only box] [--spp 1024]
--tte makes the time-to-error bench's references the same way into tests/refs/tte/ (160 pixels
wide, the research scenes only, each at the spp of TTE_SPP: its noise about 2e-3 or below, except
`box`, lit through caustics, whose halves differ by fireflies at any affordable spp). Those spp are
meant for a GPU: the committed ones were made with `--variant cuda_ad_rgb` (sponza: `scalar_rgb` on
16 cores); each manifest entry records its variant, threads and wall time.
Each reference is the mean of two half-spp renders (seeds 1 and 2), stored as half-float EXR; the
relMSE between the halves (/4) is the reference's own noise. The translation's notes and its
approximations (phong, ward, sunsky: what Mitsuba 3 renders differently from 0.6) are recorded.
Renders run under `nice` (the machine is shared).
"""
from __future__ import annotations

import argparse
import datetime
import hashlib
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.abspath(os.path.join(HERE, "..", ".."))
REFS = os.path.join(REPO, "tests", "refs")
sys.path.insert(0, HERE)
import compare  # noqa: E402
import locations  # noqa: E402
from render import load_env_file  # noqa: E402

SHARED = locations.scenes_dir()  # $OCTOLUX_SHARED/scenes or <repo>/../shared/scenes

RES = 128
REF_SEED, CHECK_SEED, LOW_SEED = 1, 2, 3
LOW_SPP = 256

# name -> source and max_depth. "shared:<rel path>" are the read-only shared scenes,
# "builtin:<name>" are octolux built-in scenes exported by `octolux export`.
REFERENCES = {
    "cbox": {"source": "shared:mitsuba-tutorials-cbox/cbox.xml", "max_depth": 6,
             "why_depth": "the scene file's own default (max_depth=6)"},
    "bitterli": {"source": "shared:bitterli-cornell-box/scene_mitsuba.xml", "max_depth": 65,
                 "why_depth": "the scene file's maxDepth=65"},
    "cornell-box": {"source": "builtin:cornell-box", "max_depth": -1,
                    "why_depth": "unbounded (Russian roulette from depth 5, Mitsuba's default rr_depth)"},
    "cornell-spheres": {"source": "builtin:cornell-spheres", "max_depth": 8,
                        "why_depth": "fixed 8 (specular chains through the glass sphere)"},
}


def log(msg: str) -> None:
    print(f"[make_refs] {msg}", file=sys.stderr, flush=True)


def sha256(path: str) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        h.update(f.read())
    return h.hexdigest()


def export_digest(xml: str) -> str:
    """sha256 over the exported XML and every file in meshes/ beside it (sorted by name)."""
    h = hashlib.sha256()
    d = os.path.dirname(xml)
    files = [xml] + sorted(os.path.join(r, f) for r, _, fs in os.walk(os.path.join(d, "meshes")) for f in fs)
    for path in files:
        h.update(os.path.relpath(path, d).encode() + b"\0")
        with open(path, "rb") as f:
            h.update(f.read())
    return h.hexdigest()


def export_builtin(name: str, out_dir: str, max_depth: int, octolux: str | None) -> tuple[str, str]:
    xml = os.path.join(out_dir, "scene.xml")
    if octolux:
        cmd = [octolux, "export", name, "-o", xml, "--max-depth", str(max_depth)]
    else:
        cmd = ["cargo", "run", "--release", "-q", "-p", "octolux-cli", "--", "export", name,
               "-o", xml, "--max-depth", str(max_depth)]
    log("export: " + " ".join(cmd))
    subprocess.run(cmd, cwd=REPO, check=True)
    shown = " ".join(["cargo", "run", "--release", "-p", "octolux-cli", "--"] + cmd[cmd.index("export"):])
    return xml, shown.replace(xml, "<tmp>/scene.xml")


def git_head() -> str | None:
    try:
        head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=REPO, text=True, capture_output=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--", "crates"], cwd=REPO, text=True,
                               capture_output=True).stdout.strip()
        return head + (" (crates/ modified)" if dirty else "") if head else None
    except OSError:
        return None


def render(scene: str, out: str, spp: int, seed: int, max_depth: int, variant: str, threads: int | None,
           resolution: tuple[int, int] = (RES, RES)) -> dict:
    cmd = [sys.executable, os.path.join(HERE, "render.py"), scene, "-o", out, "--spp", str(spp),
           "--resolution", f"{resolution[0]}x{resolution[1]}", "--max-depth", str(max_depth), "--seed", str(seed),
           "--variant", variant, "--sampler", "independent", "--quiet"]
    if os.nice(0) < 10:
        cmd = ["nice", "-n", str(10 - os.nice(0))] + cmd  # renders share the machine: lower priority
    if threads:
        cmd += ["--threads", str(threads)]
    log(f"render {os.path.basename(out)}: spp={spp} seed={seed} max_depth={max_depth} variant={variant}")
    p = subprocess.run(cmd, check=True, stdout=subprocess.PIPE, text=True)
    info = json.loads(p.stdout.strip().splitlines()[-1])
    log(f"  {info['render_s']:.1f} s, {info['samples_per_second'] / 1e6:.3f} M samples/s, mean {['%.5f' % x for x in info['mean_rgb']]}")
    return info


def make_one(name: str, cfg: dict, spp: int, variant: str, threads: int | None, octolux: str | None,
             tmp: str) -> dict:
    src = cfg["source"]
    kind, what = src.split(":", 1)
    export_cmd = None
    if kind == "shared":
        scene = os.path.join(SHARED, what)
        source_desc = "scenes/" + what  # relative to the shared folder
    else:
        d = os.path.join(tmp, name)
        os.makedirs(d, exist_ok=True)
        scene, export_cmd = export_builtin(what, d, cfg["max_depth"], octolux)
        source_desc = f"octolux built-in scene '{what}' exported to Mitsuba XML"
    depth = cfg["max_depth"]
    os.makedirs(REFS, exist_ok=True)
    ref_path = os.path.join(REFS, f"{name}.exr")
    tmp_ref = os.path.join(tmp, f"{name}.ref.exr")
    check_path = os.path.join(tmp, f"{name}.check.exr")
    low_path = os.path.join(tmp, f"{name}.256.exr")

    t0 = time.time()
    ref = render(scene, tmp_ref, spp, REF_SEED, depth, variant, threads)
    chk = render(scene, check_path, spp, CHECK_SEED, depth, variant, threads)
    low = render(scene, low_path, LOW_SPP, LOW_SEED, depth, variant, threads)
    a_ref = compare.read_exr(tmp_ref)
    self_noise = compare.compare(compare.read_exr(check_path), a_ref)
    low_cmp = compare.compare(compare.read_exr(low_path), a_ref)
    shutil.copyfile(tmp_ref, ref_path)
    ratio = low_cmp["rel_mse"] / self_noise["rel_mse"] if self_noise["rel_mse"] > 0 else None
    log(f"{name}: self-noise relMSE {self_noise['rel_mse']:.3e}, 256spp relMSE {low_cmp['rel_mse']:.3e}, "
        f"ratio {ratio:.1f}  ({time.time() - t0:.0f} s total)")
    entry = {
        "file": f"{name}.exr",
        "sha256": sha256(ref_path),
        "source_scene": source_desc,
        "export_command": export_cmd,
        "export_sha256": export_digest(scene) if export_cmd else None,
        "octolux_git_head": git_head() if export_cmd else None,
        "renderer": "Mitsuba 3 (pip package `mitsuba`)",
        "mitsuba_version": ref["mitsuba_version"],
        "drjit_version": ref["drjit_version"],
        "variant": variant,
        "integrator": ref["integrator"],
        "max_depth": ref["max_depth"],
        "max_depth_reason": cfg["why_depth"],
        "spp": spp,
        "passes": ref["passes"],
        "sampler": ref["sampler"],
        "rfilter": ref["rfilter"],
        "resolution": [RES, RES],
        "seed": REF_SEED,
        "threads": ref["threads"],
        "wall_time_s": ref["render_s"],
        "samples_per_second": ref["samples_per_second"],
        "mean_rgb": compare.compare(a_ref, a_ref)["mean_a"],
        "self_noise": {
            "what": f"relMSE between an independent render (seed {CHECK_SEED}, same spp) and the reference",
            "rel_mse": self_noise["rel_mse"],
            "rmse": self_noise["rmse"],
            "mean_rgb_other": self_noise["mean_a"],
        },
        "at_256spp": {
            "what": f"relMSE of a {LOW_SPP}-spp Mitsuba render (seed {LOW_SEED}) against the reference",
            "rel_mse": low_cmp["rel_mse"],
            "rmse": low_cmp["rmse"],
            "mean_rgb": low_cmp["mean_a"],
            "wall_time_s": low["render_s"],
        },
        "noise_ratio_256spp_over_self": ratio,
        "command": (f".venv-mitsuba/bin/python tools/mitsuba/render.py {locations.shown(scene) if kind == 'shared' else '<tmp>/scene.xml'}"
                    f" -o tests/refs/{name}.exr --spp {spp} --resolution {RES}x{RES} --max-depth {depth}"
                    f" --seed {REF_SEED} --variant {variant} --sampler independent"),
        "date": datetime.date.today().isoformat(),
    }
    return entry


# ---------------------------------------------------------------------------------------------
# The research-scene collection and the generated test scenes (--collection)
# ---------------------------------------------------------------------------------------------

COLLECTION_DIR = os.path.join(REFS, "collection")
COLLECTION_WIDTH = 320
COLLECTION_SPP = 1024
# Block sizes k at which each collection reference's own noise is also measured (k x k means).
NOISE_BLOCKS = (4, 8, 16)
# name -> scene. "shared:" under the shared scenes folder (Mitsuba 0.6 files, translated by
# translate.py on the fly), "repo:" in this repository (written by tools/make_testdata.py).
COLLECTION = {
    "box": "shared:bitterli-collection/box/scene.xml",
    "classroom": "shared:bitterli-collection/classroom/scene.xml",
    "dining-room": "shared:bitterli-collection/dining-room/scene.xml",
    "sponza": "shared:bitterli-collection/sponza/scene.xml",
    "torus": "shared:bitterli-collection/torus/scene.xml",
    "veach-lamp": "shared:bitterli-collection/veach-lamp/scene.xml",
    "envmap": "repo:tests/scenes/envmap/scene.xml",
    "mirrored": "repo:tests/scenes/mirrored/scene.xml",
    "wrappers": "repo:tests/scenes/wrappers/scene.xml",
    "manylights": "repo:tests/scenes/manylights/scene.xml",
}
# Widths other than COLLECTION_WIDTH (small generated scenes, to keep their tests fast).
COLLECTION_WIDTHS = {"wrappers": 160}
# --tte: the time-to-error bench's references (bench/time_to_error.py), 160 pixels wide, each with
# the spp that brings its own noise to about 1e-3 relMSE or below (scaled from the 320-wide
# references' noise at 1024 spp), so that errors down to 0.01 can be told from the reference's.
TTE_DIR = os.path.join(REFS, "tte")
TTE_WIDTH = 160
TTE_SPP = {"sponza": 8192, "dining-room": 32768, "veach-lamp": 131072, "torus": 262144, "box": 262144,
           "classroom": 65536}


def collection_scene(src: str) -> str:
    kind, what = src.split(":", 1)
    return os.path.join(SHARED, what) if kind == "shared" else os.path.join(REPO, what)


def write_half_exr(path: str, img) -> str:
    """Half-float RGB EXR (float32 when a value would not fit); returns the format used."""
    import mitsuba as mi
    import numpy as np
    big = float(np.nanmax(np.abs(img))) if img.size else 0.0
    fmt = "float16" if big < 60000.0 else "float32"
    arr = np.ascontiguousarray(img.astype(np.float16 if fmt == "float16" else np.float32))
    tmp = path + ".tmp.exr"
    mi.Bitmap(arr, pixel_format=mi.Bitmap.PixelFormat.RGB).write(tmp)
    os.replace(tmp, path)
    return fmt


def make_collection_one(name: str, spp: int, variant: str, threads: int | None, tmp: str,
                        out_dir: str = COLLECTION_DIR, width: int | None = None) -> dict:
    from render import patch_scene
    import numpy as np
    scene = collection_scene(COLLECTION[name])
    _, info = patch_scene(scene)
    w0, h0 = info["width"], info["height"]
    width = width or COLLECTION_WIDTHS.get(name, COLLECTION_WIDTH)
    res = (width, max(1, round(width * h0 / w0)))
    depth = info["max_depth"] if info["max_depth"] is not None else -1
    half = spp // 2
    t0 = time.time()
    runs, imgs = [], []
    for seed in (REF_SEED, CHECK_SEED):
        out = os.path.join(tmp, f"{name}.{seed}.exr")
        runs.append(render(scene, out, half, seed, depth, variant, threads, res))
        imgs.append(compare.read_exr(out))
    ref = 0.5 * (imgs[0] + imgs[1])
    norm = ref * ref + compare.REL_EPS
    halves = float(np.mean((imgs[0] - imgs[1]) ** 2 / norm))
    # The same noise measured on k x k block means (box-filter downsample): what a comparison at a
    # reduced resolution needs (agreement_collection.rs compares `box`, lit by caustics only, so).
    h, w, _ = ref.shape
    blocks = {}
    for k in NOISE_BLOCKS:
        if w % k == 0 and h % k == 0:
            def down(x, k=k):
                return x.reshape(h // k, k, w // k, k, 3).mean(axis=(1, 3))
            rd = down(ref)
            hb = float(np.mean((down(imgs[0]) - down(imgs[1])) ** 2 / (rd * rd + compare.REL_EPS)))
            blocks[str(k)] = {"rel_mse_halves": hb, "ref_rel_mse": hb / 4}
    os.makedirs(out_dir, exist_ok=True)
    path = os.path.join(out_dir, f"{name}.exr")
    fmt = write_half_exr(path, ref)
    stored = compare.read_exr(path)
    quant = float(np.mean((stored - ref) ** 2 / norm))
    log(f"{name}: {res[0]}x{res[1]}, {spp} spp, halves relMSE {halves:.3e} -> reference noise {halves / 4:.3e}"
        f" ({time.time() - t0:.0f} s)")
    r0 = runs[0]
    shown = locations.shown(scene)
    return {
        "file": f"{name}.exr",
        "format": f"{fmt} RGB OpenEXR, linear (mean of the two half renders)",
        "sha256": sha256(path),
        "source_scene": shown,
        "translation": {
            "by": "tools/mitsuba/translate.py (through render.py)" if r0["patch_notes"] else None,
            "notes": [n for n in r0["patch_notes"] if not n.startswith("renamed ")],
            "approximations": r0["approximations"],
        },
        "renderer": "Mitsuba 3 (pip package `mitsuba`)",
        "mitsuba_version": r0["mitsuba_version"],
        "drjit_version": r0["drjit_version"],
        "variant": variant,
        "integrator": r0["integrator"],
        "max_depth": depth,
        "max_depth_reason": "the scene file's maxDepth" if info["max_depth"] is not None else "Mitsuba 3's default (-1)",
        "spp": spp,
        "halves": [{"spp": half, "seed": r["seed"], "wall_time_s": r["render_s"],
                    "mean_rgb": r["mean_rgb"]} for r in runs],
        "sampler": r0["sampler"],
        "rfilter": r0["rfilter"],
        "resolution": list(res),
        "file_resolution": [w0, h0],
        "threads": r0["threads"],
        "wall_time_s": round(sum(r["render_s"] for r in runs), 3),
        "samples_per_second": res[0] * res[1] * 2 * half / sum(r["render_s"] for r in runs),
        "mean_rgb": [float(x) for x in ref.reshape(-1, 3).mean(axis=0)],
        "self_noise": {
            "what": ("rel_mse_halves: relMSE between the two independent half-spp renders (seeds "
                     f"{REF_SEED}, {CHECK_SEED}; normalised by the reference); ref_rel_mse = rel_mse_halves / 4 "
                     "is the reference's own expected relMSE against the exact image (the mean of two halves "
                     "has half a half's variance, and the halves differ by twice it)"),
            "rel_mse_halves": halves,
            "ref_rel_mse": halves / 4,
            "storage_rel_mse": quant,
            "blocks": blocks,
            "blocks_what": ("the same two numbers after averaging both halves (and normalising by the "
                            "reference averaged likewise) over k x k pixel blocks, per k"),
        },
        "command": (f".venv-mitsuba/bin/python tools/mitsuba/make_refs.py "
                    f"{'--tte' if out_dir == TTE_DIR else '--collection'} --only {name} --spp {spp}"
                    f"  (= render.py {shown} --spp {half} --resolution {res[0]}x{res[1]} --max-depth {depth}"
                    f" --seed {REF_SEED}|{CHECK_SEED} --variant {variant} --sampler independent, averaged)"),
        "date": datetime.date.today().isoformat(),
    }


def main_collection(args) -> int:
    tte = args.tte
    out_dir = TTE_DIR if tte else COLLECTION_DIR
    manifest_path = os.path.join(out_dir, "manifest.json")
    manifest = {}
    if os.path.exists(manifest_path):
        with open(manifest_path) as f:
            manifest = json.load(f)
    manifest["about"] = {
        "made_by": f"tools/mitsuba/make_refs.py {'--tte' if tte else '--collection'} (see its docstring)",
        "rel_mse": "mean over pixels and channels of (a-b)^2 / (b^2 + 1e-2), b = the reference",
        "noise": ("each reference is the mean of two independent half-spp renders; their relMSE / 4 is "
                  "the reference's own noise (self_noise.ref_rel_mse), used by "
                  "crates/octolux-cli/tests/agreement_collection.rs in its bound"),
        "size": (f"{TTE_WIDTH} pixels wide, the scene file's aspect ratio" if tte else
                 f"{COLLECTION_WIDTH} pixels wide (except {COLLECTION_WIDTHS}), the scene file's aspect ratio"),
        "scenes": "shared: scenes read from ../shared/scenes (never copied); tests/scenes: made by tools/make_testdata.py",
    }
    refs = manifest.setdefault("references", {})
    names = args.only or (list(TTE_SPP) if tte else list(COLLECTION))
    tmp = tempfile.mkdtemp(prefix="octolux-refs-")
    try:
        for name in names:
            scene = collection_scene(COLLECTION[name])
            if not os.path.exists(scene):
                log(f"skip: {name}: {scene} is absent")
                continue
            spp = args.spp or (TTE_SPP.get(name, 16384) if tte else COLLECTION_SPP)
            refs[name] = make_collection_one(name, spp, args.variant, args.threads, tmp, out_dir, TTE_WIDTH if tte else None)
            manifest["references"] = dict(sorted(refs.items()))
            with open(manifest_path, "w") as f:
                json.dump(manifest, f, indent=2)
                f.write("\n")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    for name in names:
        e = refs.get(name)
        if e:
            print(f"{name:12s} {e['resolution'][0]}x{e['resolution'][1]} spp={e['spp']:5d} depth={e['max_depth']:3d} "
                  f"wall={e['wall_time_s']:7.1f}s ref_noise={e['self_noise']['ref_rel_mse']:.3e} "
                  f"mean={['%.5f' % x for x in e['mean_rgb']]} approx={len(e['translation']['approximations'])}")
    return 0


def main(argv=None) -> int:
    load_env_file()  # OCTOLUX_MI_VARIANT / DRJIT_LIBLLVM_PATH from tools/mitsuba/setup.sh
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--collection", action="store_true",
                    help=f"the research scenes and generated test scenes -> tests/refs/collection/ ({COLLECTION_SPP} spp)")
    ap.add_argument("--tte", action="store_true",
                    help="the time-to-error bench's references -> tests/refs/tte/ (160 wide, spp per scene: TTE_SPP)")
    ap.add_argument("--only", action="append", choices=sorted(set(REFERENCES) | set(COLLECTION)),
                    help="make only these (repeatable)")
    ap.add_argument("--spp", type=int, default=None, help="reference spp (default 8192; --collection: 1024)")
    ap.add_argument("--variant", default=os.environ.get("OCTOLUX_MI_VARIANT", "llvm_ad_rgb"))
    ap.add_argument("--threads", type=int, default=None)
    ap.add_argument("--octolux", default=None, help="octolux binary for `export` (default: cargo run --release)")
    ap.add_argument("--keep-tmp", action="store_true")
    args = ap.parse_args(argv)
    if args.collection or args.tte:
        return main_collection(args)
    if args.only and not set(args.only) <= set(REFERENCES):
        ap.error("--only: names of the collection need --collection")
    args.spp = args.spp or 8192

    manifest_path = os.path.join(REFS, "manifest.json")
    manifest = {}
    if os.path.exists(manifest_path):
        with open(manifest_path) as f:
            manifest = json.load(f)
    manifest.setdefault("about", {
        "made_by": "tools/mitsuba/make_refs.py (see its docstring)",
        "rel_mse": "mean over pixels and channels of (a-b)^2 / (b^2 + 1e-2), b = the reference",
        "noise_check": (f"each reference is rendered twice (seeds {REF_SEED} and {CHECK_SEED}); their relMSE is "
                        f"the reference's own noise. A {LOW_SPP}-spp render (seed {LOW_SEED}) against the reference "
                        "shows the noise of a typical test render; the aim is a ratio >= 10."),
        "images": "128x128 float32 RGB OpenEXR, linear, as written by Mitsuba's hdrfilm (develop())",
    })
    refs = manifest.setdefault("references", {})

    names = args.only or list(REFERENCES)
    tmp = tempfile.mkdtemp(prefix="octolux-refs-")
    try:
        for name in names:
            refs[name] = make_one(name, REFERENCES[name], args.spp, args.variant, args.threads,
                                  args.octolux, tmp)
            os.makedirs(REFS, exist_ok=True)
            with open(manifest_path, "w") as f:
                json.dump(manifest, f, indent=2)
                f.write("\n")
    finally:
        if args.keep_tmp:
            log(f"kept {tmp}")
        else:
            shutil.rmtree(tmp, ignore_errors=True)
    for name in names:
        e = refs[name]
        print(f"{name:16s} spp={e['spp']:6d} depth={e['max_depth']:3d} wall={e['wall_time_s']:7.1f}s "
              f"self={e['self_noise']['rel_mse']:.3e} 256spp={e['at_256spp']['rel_mse']:.3e} "
              f"ratio={e['noise_ratio_256spp_over_self']:.1f} mean={['%.5f' % x for x in e['mean_rgb']]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
