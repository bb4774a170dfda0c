#!/usr/bin/env python3
"""Flicker of a camera animation on a static scene (issue 13, item 3; table in docs/lab/2026-11-30-baking.md).

    .venv-peers/bin/python bench/flicker.py [--quick] [--scenes cbox bitterli] [--out DIR]

One command, every step in its own process, for each scene: a linear camera move (a two-key
camera path, so LuxCore gets the very same cameras), then

* reference  octolux `path`, REF_SPP spp, every frame;
* baked      `octolux bake` once (photon seed 0), then `render --cache --camera-path`;
* rebuilt    `render --integrator octree` frame by frame, photon seed 1000 + i: photons and
             octree anew every frame;
* path       octolux `path` at equal time: the spp whose per-frame render time matches the
             baked octree's per-frame time (its render plus the bake shared over the frames);
* pgi-baked  LuxCore PATHCPU + PhotonGI, its cache saved by frame 1 (path.photongi.persistent.file)
             and loaded by every other frame: LuxCore's own bake;
* pgi-frame  LuxCore PATHCPU + PhotonGI, its cache rebuilt every frame with seed i;

the pixels' seed is 1 in every frame (what `render --camera-path` does; --pixel-seed per-frame
gives frame i seed i, as frames rendered apart with different seeds), so that the baked and
rebuilt octrees differ only in their photons; each frame rendered with the same spp and photon count for the four cache methods, and
`octolux flicker` (crates/octolux/src/flicker.rs) measures each sequence against the
reference: temporal relMSE of frame differences and the spread of static points' errors over
frames. LuxCore's frames are shifted one row up (bench/peers/lux_render.py: its film is one row
lower than Mitsuba's and octolux's) and every measure leaves a 1-pixel border out.

Times: each renderer's own clock (octolux timings.render_s and the bake's t_c_s; LuxCore's
Start()..HasDone() less its BVH build), and the CPU time (user + system) of the processes.
Outputs under --out (default target/flicker/): results.json, results.md, the frames.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tools" / "mitsuba"))
import locations  # noqa: E402  (tools/mitsuba/locations.py: $OCTOLUX_SHARED or <repo>/../shared)

PEERS = ROOT / "bench" / "peers"

# name -> scene file, max_depth (bench/peers' choices), camera move (two keys), fov along x.
sys.path.insert(0, str(ROOT / "bench"))
import scenes as aliases  # noqa: E402  (bench/scenes.json: the one table of scene aliases)

SCENES = {
    "cbox": {
        "xml": Path(aliases.get("cbox")["scene"]), "max_depth": aliases.get("cbox")["max_depth"], "fov": 39.3077,
        "keys": [([-0.45, -0.05, 4.0], [0.0, 0.0, 0.0]), ([0.45, 0.1, 3.7], [0.0, 0.05, 0.0])],
    },
    "bitterli": {
        "xml": Path(aliases.get("bitterli")["scene"]), "max_depth": aliases.get("bitterli")["max_depth"], "fov": 19.5,
        "keys": [([-0.5, 0.95, 6.8], [0.0, 1.0, 0.0]), ([0.5, 1.1, 6.5], [0.0, 1.0, 0.0])],
    },
}
METHODS = ["baked", "rebuilt", "path", "pgi-baked", "pgi-frame", "irr-baked", "irr-rebuilt"]


def log(msg: str) -> None:
    print(f"[flicker {time.strftime('%H:%M:%S')}] {msg}", file=sys.stderr, flush=True)


def run(cmd: list, quiet: bool = True) -> tuple[str, float, float]:
    """Run cmd; (stdout, wall s, CPU s of the child: user + system)."""
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, cwd=ROOT)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode != 0:
        raise RuntimeError(f"failed ({p.returncode}): {' '.join(map(str, cmd))}\n{p.stderr[-3000:]}")
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    return p.stdout, wall, cpu


def last_json(stdout: str) -> dict:
    for line in reversed(stdout.strip().splitlines()):
        if line.strip().startswith("{"):
            return json.loads(line)
    raise RuntimeError(f"no JSON in output:\n{stdout[-2000:]}")


def camera_at(spec: dict, frames: int, i: int) -> tuple[list[float], list[float]]:
    """Position and target of frame i (from 1): linear between the two keys, as octolux's
    Catmull-Rom path is for two keys."""
    (p0, t0), (p1, t1) = spec["keys"]
    s = (i - 1) / (frames - 1)
    lerp = lambda a, b: [float(x + (y - x) * s) for x, y in zip(a, b)]  # noqa: E731
    return lerp(p0, p1), lerp(t0, t1)


def write_path(spec: dict, frames: int, path: Path) -> None:
    keys = [{"time": k * (frames - 1) / frames, "position": p, "target": t, "up": [0, 1, 0], "fov": spec["fov"]}
            for k, (p, t) in enumerate(spec["keys"])]
    path.write_text(json.dumps({"fps": frames, "keyframes": keys}, indent=1))


def octolux_frames(args, spec, cam_path, outdir: Path, name: str, common: list, photon_seed_per_frame: bool,
                   seed: int = 1) -> dict:
    """Render the frames into outdir/NAME_i.exr: one process for all frames, or (a photon seed
    per frame, or --pixel-seed per-frame) one process per frame. The pixel seed is 1 for every
    frame (what `render --camera-path` does), or i with --pixel-seed per-frame."""
    outdir.mkdir(parents=True, exist_ok=True)
    render_s = wall = cpu = build_s = 0.0
    per_frame = photon_seed_per_frame or args.pixel_seed == "per-frame"
    for i in range(1, args.frames + 1) if per_frame else [None]:
        cmd = [args.bin, "render", spec["xml"], "--camera-path", cam_path, "--resolution", args.res,
               "--max-depth", spec["max_depth"], "--threads", args.threads, "-q", "-o", outdir / f"{name}.exr"] + common
        if i:
            cmd += ["--frames", f"{i}..{i}", "--seed", i if args.pixel_seed == "per-frame" else seed]
            if photon_seed_per_frame:
                cmd += ["--set", f"photons.seed={1000 + i}"]
        else:
            cmd += ["--seed", seed]
        _, w, c = run(cmd)
        wall, cpu = wall + w, cpu + c
    for i in range(1, args.frames + 1):
        st = json.loads((outdir / f"{name}_{i:04d}.json").read_text())
        render_s += st["timings"]["render_s"]
        build_s += (st.get("build") or {}).get("t_c_s") or 0.0
    return {"render_s": render_s, "build_s": build_s, "wall_s": wall, "cpu_s": cpu}


def luxcore_frames(args, spec, dump: Path, outdir: Path, pgi_file: Path | None) -> dict:
    import mitsuba as mi  # converting .npy to EXR only (never pyluxcore in this process)
    mi.set_variant("scalar_rgb")
    outdir.mkdir(parents=True, exist_ok=True)
    d = json.loads((dump / "scene.json").read_text())
    for s in d["shapes"]:
        s["mesh"] = str((dump / s["mesh"]).resolve())
    rec = {"render_s": 0.0, "build_s": 0.0, "wall_s": 0.0, "cpu_s": 0.0, "memory_bytes": None}
    if pgi_file and pgi_file.exists():
        pgi_file.unlink()
    for i in range(1, args.frames + 1):
        # LuxCore's engine seed also seeds PhotonGI's photons: a new one per frame when the cache
        # is rebuilt per frame (or with --pixel-seed per-frame), else 1 as octolux's pixels.
        seed = i if (pgi_file is None or args.pixel_seed == "per-frame") else 1
        fd = outdir / f"dump_{i:04d}"
        fd.mkdir(exist_ok=True)
        origin, target = camera_at(spec, args.frames, i)
        d["camera"].update({"origin": origin, "target": target, "up": [0.0, 1.0, 0.0], "x_fov": spec["fov"]})
        (fd / "scene.json").write_text(json.dumps(d))
        npy = outdir / f"lux_{i:04d}.npy"
        cmd = [sys.executable, PEERS / "lux_render.py", fd, "-o", npy, "--spp", args.spp, "--pgi", "auto",
               "--threads", args.threads, "--seed", seed, "--photons", args.photons]
        if pgi_file:
            cmd += ["-P", f"path.photongi.persistent.file={pgi_file}"]
        out, w, c = run(cmd)
        j = last_json(out)
        pg = j.get("photongi") or {}
        rec["render_s"] += j["wall_s"] - (j.get("accel_build_s") or 0.0)
        rec["build_s"] += pg.get("build_s") or 0.0
        rec["memory_bytes"] = pg.get("memory_bytes") or rec["memory_bytes"]
        rec["wall_s"] += w
        rec["cpu_s"] += c
        img = np.load(npy).astype(np.float32)[..., :3]
        img = np.concatenate([img[1:], img[-1:]], axis=0)  # LuxCore's row y + 1 is octolux's row y
        mi.Bitmap(np.ascontiguousarray(img)).write(str(outdir / f"lux_{i:04d}.exr"))
        npy.unlink()
        shutil.rmtree(fd)
    return rec


def flicker(args, spec, cam_path, frames: Path, ref: Path) -> dict:
    out, _, _ = run([args.bin, "flicker", frames, "--reference", ref, "--scene", spec["xml"], "--camera-path", cam_path,
                     "--border", 1, "--points", 2048])
    return json.loads(out)["flicker"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="32x32, 4 frames, 4 spp, 64 reference spp: a smoke test")
    ap.add_argument("--scenes", nargs="+", default=list(SCENES), choices=list(SCENES))
    ap.add_argument("--methods", nargs="+", default=METHODS, choices=METHODS)
    ap.add_argument("--frames", type=int, default=8)
    ap.add_argument("--res", default="64x64")
    ap.add_argument("--spp", type=int, default=64, help="spp of the cache methods")
    ap.add_argument("--ref-spp", type=int, default=2048)
    ap.add_argument("--photons", type=int, default=1_000_000)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--pixel-seed", choices=["fixed", "per-frame"], default="fixed",
                    help="fixed: seed 1 for the pixels of every frame (render --camera-path's way); "
                         "per-frame: seed i for frame i (frames rendered apart)")
    ap.add_argument("--bin", type=Path, default=ROOT / "target" / "release" / "octolux")
    ap.add_argument("--out", type=Path, default=ROOT / "target" / "flicker")
    ap.add_argument("--reuse", action="store_true",
                    help="keep a scene folder of an earlier run with the same settings (its reference, its bake, "
                         "the results of the methods not asked for) and run only --methods")
    args = ap.parse_args(argv)
    if args.quick:
        args.frames, args.res, args.spp, args.ref_spp, args.photons = 4, "32x32", 4, 64, 100_000
    w, h = (int(v) for v in args.res.split("x"))
    results = {"settings": {k: str(v) for k, v in vars(args).items()}, "scenes": {}}
    if args.reuse and (args.out / "results.json").exists():
        results["scenes"] = json.loads((args.out / "results.json").read_text())["scenes"]
    for name in args.scenes:
        spec = SCENES[name]
        if not Path(spec["xml"]).exists():
            print(f"skip: {spec['xml']} not found", file=sys.stderr)
            continue
        sd = args.out / name
        res = {}
        if args.reuse and (sd / "reference" / f"ref_{args.frames:04d}.exr").exists():
            old = json.loads((args.out / "results.json").read_text()) if (args.out / "results.json").exists() else {}
            res = {k: v for k, v in old.get("scenes", {}).get(name, {}).items() if k not in args.methods}
            log(f"{name}: reusing {sd}: its reference, bake and {sorted(res)}")
        else:
            shutil.rmtree(sd, ignore_errors=True)
            sd.mkdir(parents=True)
            write_path(spec, args.frames, sd / "path.json")
            log(f"{name}: reference, path {args.ref_spp} spp")
            ref_args = argparse.Namespace(**{**vars(args), "pixel_seed": "fixed"})
            res["reference"] = octolux_frames(ref_args, spec, sd / "path.json", sd / "reference", "ref",
                                              ["--integrator", "path", "--spp", args.ref_spp], False, seed=1000)
        cam_path = sd / "path.json"
        common = ["--spp", args.spp]
        if any(m in args.methods for m in ("baked", "path")) or not (sd / "lighting.oxc").exists():
            log(f"{name}: bake + render --cache")
            oxc = sd / "lighting.oxc"
            _, bw, bc = run([args.bin, "bake", spec["xml"], "-o", oxc, "--photons", args.photons, "--max-depth",
                             spec["max_depth"], "--threads", args.threads, "--seed", 0])
            r = octolux_frames(args, spec, cam_path, sd / "baked", "f", ["--cache", oxc] + common, False)
            r.update({"bake_wall_s": bw, "bake_cpu_s": bc, "cache_bytes": oxc.stat().st_size})
            res["baked"] = r
        if "rebuilt" in args.methods:
            log(f"{name}: octree rebuilt per frame")
            res["rebuilt"] = octolux_frames(args, spec, cam_path, sd / "rebuilt", "f",
                                            ["--integrator", "octree", "--photons", args.photons] + common, True)
        if "path" in args.methods:
            # Equal time: the baked octree's per-frame time (render + bake / frames), path's
            # speed measured on frame 1 at 16 spp.
            b = res["baked"]
            target = (b["render_s"] + b["bake_wall_s"]) / args.frames
            pd = sd / "probe"
            pd.mkdir()
            run([args.bin, "render", spec["xml"], "--camera-path", cam_path, "--resolution", args.res, "--max-depth",
                 spec["max_depth"], "--threads", args.threads, "-q", "-o", pd / "p.exr", "--integrator", "path",
                 "--spp", 16, "--frames", "1..1"])
            per_spp = json.loads((pd / "p_0001.json").read_text())["timings"]["render_s"] / 16
            spp = max(1, round(target / per_spp))
            log(f"{name}: path at equal time: {spp} spp (target {target:.3f} s/frame)")
            r = octolux_frames(args, spec, cam_path, sd / "path", "f", ["--integrator", "path", "--spp", spp], False)
            r["spp"] = spp
            res["path"] = r
        if "irr-baked" in args.methods or "irr-rebuilt" in args.methods:
            # The lighting alone: the global octree's irradiance at the first diffuse hit
            # (`--view irradiance`: no light sampling, only the pixel filter's jitter), against
            # the same view of a bake with 10x the photons.
            log(f"{name}: the lighting alone (--view irradiance), reference baked with {10 * args.photons} photons")
            view = ["--view", "irradiance", "--spp", 16]
            oxc10 = sd / "lighting-10x.oxc"
            run([args.bin, "bake", spec["xml"], "-o", oxc10, "--photons", 10 * args.photons, "--max-depth",
                 spec["max_depth"], "--threads", args.threads, "--seed", 7])
            octolux_frames(args, spec, cam_path, sd / "irr-reference", "r", ["--cache", oxc10] + view, False)
            res["irr-baked"] = octolux_frames(args, spec, cam_path, sd / "irr-baked", "f",
                                              ["--cache", sd / "lighting.oxc"] + view, False)
            res["irr-baked"]["spp"] = 16
            res["irr-rebuilt"] = octolux_frames(args, spec, cam_path, sd / "irr-rebuilt", "f",
                                                ["--integrator", "octree", "--photons", args.photons] + view, True)
            res["irr-rebuilt"]["spp"] = 16
        dump = None
        if any(m.startswith("pgi") for m in args.methods):
            dump = sd / "dump"
            run([sys.executable, PEERS / "mi_translate.py", spec["xml"], dump, "--resolution", args.res,
                 "--max-depth", spec["max_depth"]])
        if "pgi-baked" in args.methods:
            log(f"{name}: LuxCore PhotonGI, one persistent cache")
            res["pgi-baked"] = luxcore_frames(args, spec, dump, sd / "pgi-baked", (sd / "cache.pgi").resolve())
        if "pgi-frame" in args.methods:
            log(f"{name}: LuxCore PhotonGI rebuilt per frame")
            res["pgi-frame"] = luxcore_frames(args, spec, dump, sd / "pgi-frame", None)
        for m in METHODS:
            if m in res:
                folder = sd / m
                ref = sd / ("irr-reference" if m.startswith("irr-") else "reference")
                res[m]["flicker"] = flicker(args, spec, cam_path, folder, ref)
                log(f"{name} {m}: {res[m]['flicker']}")
        results["scenes"][name] = res
        (args.out / "results.json").write_text(json.dumps(results, indent=1))
    md = markdown(results, args)
    (args.out / "results.md").write_text(md)
    print(md)
    return 0


LABEL = {"baked": "octree, baked once (`render --cache`)", "rebuilt": "octree rebuilt per frame (new seed)",
         "path": "octolux `path`, equal time", "pgi-baked": "LuxCore PhotonGI, one cache file (.pgi)",
         "pgi-frame": "LuxCore PhotonGI, rebuilt per frame",
         "irr-baked": "lighting alone (`--view irradiance`): octree baked once",
         "irr-rebuilt": "lighting alone (`--view irradiance`): octree rebuilt per frame"}


def markdown(results: dict, args) -> str:
    rows = ["| scene | method | spp | frame relMSE | temporal relMSE | ratio | static-point rel. std | "
            "x rebuilt (temporal / static) | s/frame (own clock) | CPU s/frame |",
            "|---|---|---|---|---|---|---|---|---|---|"]
    for name, res in results["scenes"].items():
        for m in METHODS:
            if m not in res:
                continue
            reb = res.get("irr-rebuilt" if m.startswith("irr-") else "rebuilt", {}).get("flicker")
            r, f = res[m], res[m]["flicker"]
            n = args.frames
            # octolux's render_s leaves the photons and octree out (build_s); LuxCore's includes them.
            own = r["render_s"] + (r["build_s"] if m.endswith("rebuilt") else 0.0) + r.get("bake_wall_s", 0.0)
            t = own / n
            cpu = (r["cpu_s"] + r.get("bake_cpu_s", 0.0)) / n
            rel = "" if not reb else f"{f['temporal_rel_mse'] / reb['temporal_rel_mse']:.3f} / " \
                                     f"{f['static_rel_std'] / reb['static_rel_std']:.3f}"
            rows.append(f"| {name} | {LABEL[m]} | {r.get('spp', args.spp)} | {f['frame_rel_mse']:.2e} | "
                        f"{f['temporal_rel_mse']:.2e} | {f['temporal_ratio']:.2f} | {f['static_rel_std']:.4f} | {rel} | "
                        f"{t:.2f} | {cpu:.2f} |")
        if "reference" in res:
            f0 = res.get("baked", {}).get("flicker")
            if f0:
                rows.append(f"| {name} | (reference's own static-point spread) | {args.ref_spp} | | | | "
                            f"{f0['static_rel_std_reference']:.4f} | | | |")
    return "\n".join(rows) + "\n"


if __name__ == "__main__":
    sys.exit(main())
