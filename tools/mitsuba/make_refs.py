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
SHARED = os.environ.get("OCTOLUX_SHARED_SCENES", "/work/shared/scenes")
sys.path.insert(0, HERE)
import compare  # noqa: E402
from render import load_env_file  # noqa: E402

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


def render(scene: str, out: str, spp: int, seed: int, max_depth: int, variant: str, threads: int | None) -> dict:
    cmd = [sys.executable, os.path.join(HERE, "render.py"), scene, "-o", out, "--spp", str(spp),
           "--resolution", f"{RES}x{RES}", "--max-depth", str(max_depth), "--seed", str(seed),
           "--variant", variant, "--sampler", "independent", "--quiet"]
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
        source_desc = os.path.relpath(scene, os.path.dirname(SHARED))  # scenes/<...>
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
        "command": (f".venv-mitsuba/bin/python tools/mitsuba/render.py {scene if kind == 'shared' else '<tmp>/scene.xml'}"
                    f" -o tests/refs/{name}.exr --spp {spp} --resolution {RES}x{RES} --max-depth {depth}"
                    f" --seed {REF_SEED} --variant {variant} --sampler independent"),
        "date": datetime.date.today().isoformat(),
    }
    return entry


def main(argv=None) -> int:
    load_env_file()  # OCTOLUX_MI_VARIANT / DRJIT_LIBLLVM_PATH from tools/mitsuba/setup.sh
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--only", action="append", choices=sorted(REFERENCES), help="make only these (repeatable)")
    ap.add_argument("--spp", type=int, default=8192, help="reference spp (default 8192)")
    ap.add_argument("--variant", default=os.environ.get("OCTOLUX_MI_VARIANT", "llvm_ad_rgb"))
    ap.add_argument("--threads", type=int, default=None)
    ap.add_argument("--octolux", default=None, help="octolux binary for `export` (default: cargo run --release)")
    ap.add_argument("--keep-tmp", action="store_true")
    args = ap.parse_args(argv)

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
