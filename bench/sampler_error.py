#!/usr/bin/env python3
"""Error at equal spp: independent vs Sobol' sampling (`octolux render --sampler`).

    .venv-mitsuba/bin/python bench/sampler_error.py     # default cases, spp 4, 16, 64
    .venv-mitsuba/bin/python bench/sampler_error.py --spp 16 --case cornell-box:path --json x.json

(any Python with numpy and the `mitsuba` package, which reads the EXR files; tools/mitsuba/setup.sh)

For each case and spp, both samplers render with seeds 1 and 2 (the photon seed held at 7, so
that a cache integrator's photon maps and caches are the same in every render and only its
camera and gather samples change). Reported per sampler:
  relMSE      mean over the two seeds of the relMSE against the reference (tests/refs/, Mitsuba 3;
              a cache integrator's bias is included): mean over pixels and channels of
              (a - r)² / (r² + 1e-2), as `octolux compare` computes it;
  trimmed     the same without the 0.1% largest per-pixel terms (fireflies decide the plain
              relMSE of the collection's caustic scenes at low spp, whatever the sampler);
  noise       relMSE between the two seeds' images / 2, denominator from the reference (the
              sampler's variance alone, as a fraction of the squared pixel value).
and the ratios independent / Sobol' of each (above 1: Sobol' is better).

Cases are SCENE:INTEGRATOR with SCENE one of cornell-box, bitterli, cbox (128x128, references
at 8192 spp) or box, veach-lamp, torus (../shared/scenes/bitterli-collection, 320 wide, the
references' depth). Needs `cargo build --release -p octolux-cli`.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile

REPO = os.path.abspath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
sys.path.insert(0, os.path.join(REPO, "bench"))
import scenes  # noqa: E402  (bench/scenes.json: the one table of scene aliases)


def _case(name: str) -> tuple:
    e = scenes.get(name)
    return (e["scene"], "x".join(map(str, e["resolution"])), e["max_depth"], e["reference"])


# name: (what octolux renders, resolution, max_depth, reference)
SCENES = {name: _case(name) for name in ["cornell-box", "bitterli", "cbox", "box", "veach-lamp", "torus"]}
DEFAULT_CASES = ["cornell-box:path", "bitterli:path", "box:path", "cornell-box:octree", "box:octree"]
SAMPLERS = ["independent", "sobol"]


def log(msg: str) -> None:
    print(f"[sampler_error] {msg}", file=sys.stderr, flush=True)


def read_exr(path: str):
    import mitsuba as mi
    import numpy as np

    if not mi.variant():
        mi.set_variant("scalar_rgb")
    return np.array(mi.Bitmap(path), dtype=np.float64)[..., :3]


def rel_terms(a, b, ref):
    """Per-pixel relMSE terms of a against b, normalised by the reference."""
    return (((a - b) ** 2) / (ref ** 2 + 1e-2)).mean(axis=-1).ravel()


def trimmed_mean(t, frac=1e-3):
    import numpy as np

    k = int(len(t) * (1.0 - frac))
    return float(np.partition(t, k - 1)[:k].mean())


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--case", action="append", help="SCENE:INTEGRATOR (default: %s)" % ", ".join(DEFAULT_CASES))
    ap.add_argument("--spp", default="4,16,64", help="comma-separated spp (default 4,16,64)")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--octolux", default=os.path.join(REPO, "target", "release", "octolux"))
    ap.add_argument("--json", help="also write all results here")
    args = ap.parse_args(argv)
    if not os.path.exists(args.octolux):
        sys.exit(f"octolux binary not found: {args.octolux} (cargo build --release -p octolux-cli)")
    rows = []
    with tempfile.TemporaryDirectory(prefix="octolux-samplererr-") as tmp:
        for case in args.case or DEFAULT_CASES:
            name, _, integrator = case.partition(":")
            scene, res, depth, ref = SCENES[name]
            if scene != "cornell-box" and not os.path.exists(scene):
                print(f"skip: {scene} missing", file=sys.stderr)
                continue
            for spp in [int(s) for s in args.spp.split(",") if s]:
                row = {"scene": name, "integrator": integrator or "path", "spp": spp, "resolution": res}
                for sampler in SAMPLERS:
                    imgs = []
                    for seed in (1, 2):
                        out = os.path.join(tmp, f"{sampler}-{seed}.exr")
                        cmd = [args.octolux, "render", scene, "--integrator", integrator or "path", "--spp", str(spp),
                               "--resolution", res, "--max-depth", str(depth), "--seed", str(seed),
                               "--sampler", sampler, "--threads", str(args.threads), "--quiet", "-o", out]
                        if integrator and integrator != "path":
                            cmd += ["--set", "photons.seed=7"]
                        log("$ " + " ".join(cmd))
                        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                        imgs.append(out)
                    r = read_exr(ref)
                    a, b = read_exr(imgs[0]), read_exr(imgs[1])
                    rel = [float(rel_terms(x, r, r).mean()) for x in (a, b)]
                    trim = [trimmed_mean(rel_terms(x, r, r)) for x in (a, b)]
                    pair = rel_terms(a, b, r)
                    row[sampler] = {"rel_mse": sum(rel) / 2, "rel_mse_seeds": rel, "trimmed": sum(trim) / 2,
                                    "noise": float(pair.mean()) / 2, "noise_trimmed": trimmed_mean(pair) / 2}
                rows.append(row)
                i, s = row["independent"], row["sobol"]
                log(f"{name}:{row['integrator']} {spp} spp: relMSE {i['rel_mse']:.3e} / {s['rel_mse']:.3e}, "
                    f"trimmed {i['trimmed']:.3e} / {s['trimmed']:.3e}, noise {i['noise']:.3e} / {s['noise']:.3e}")
    print("| scene | integrator | spp | relMSE ind. | relMSE sobol | ratio | trimmed ind. | trimmed sobol | ratio "
          "| noise ind. | noise sobol | ratio |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        i, s = r["independent"], r["sobol"]
        cells = [r["scene"], r["integrator"], str(r["spp"])]
        for k in ("rel_mse", "trimmed", "noise"):
            cells += [f"{i[k]:.3e}", f"{s[k]:.3e}", f"{i[k] / s[k]:.2f}x" if s[k] > 0 else "-"]
        print("| " + " | ".join(cells) + " |")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
