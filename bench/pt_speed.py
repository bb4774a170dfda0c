#!/usr/bin/env python3
"""Path-tracer speed: octolux vs Mitsuba 3 (llvm_ad_rgb and scalar_rgb), samples per second.

    python3 bench/pt_speed.py                      # default cases, 2 threads, 512x512
    python3 bench/pt_speed.py --skip-octolux       # Mitsuba half only
    python3 bench/pt_speed.py --case bitterli:65 --spp 64 --json target/pt_speed.json

Cases are SCENE:MAX_DEPTH with SCENE one of
  cornell-box  octolux's built-in scene (octolux renders it by name; Mitsuba renders the XML that
               `octolux export cornell-box` writes),
  bitterli     ../shared/scenes/bitterli-cornell-box/scene_mitsuba.xml (both read the same file;
               tools/mitsuba/render.py patches the Mitsuba 0.5 dialect for Mitsuba 3).
Defaults: cornell-box:-1, bitterli:-1, bitterli:65.

octolux:  target/release/octolux render <scene> --integrator path --spp N --resolution WxH
          --max-depth D --threads T -o <tmp>/x.exr   (samples/s from <tmp>/x.json, `samples_per_second`)
Mitsuba:  .venv-mitsuba/bin/python tools/mitsuba/render.py <xml> --variant V --spp N --resolution WxH
          --max-depth D --threads T --warmup  (JIT variants: one untimed warm-up pass so that kernel
          compilation is not counted; samples/s = W*H*spp / render time)
Needs tools/mitsuba/setup.sh for the Mitsuba half and `cargo build --release -p octolux-cli` for
octolux (or --build).
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile

REPO = os.path.abspath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
sys.path.insert(0, os.path.join(REPO, "tools", "mitsuba"))
import locations  # noqa: E402  (tools/mitsuba/locations.py: $OCTOLUX_SHARED or <repo>/../shared)

SHARED = locations.scenes_dir()
BITTERLI = os.path.join(SHARED, "bitterli-cornell-box", "scene_mitsuba.xml")
MI_PY = locations.mitsuba_python()
MI_RENDER = os.path.join(REPO, "tools", "mitsuba", "render.py")
DEFAULT_CASES = ["cornell-box:-1", "bitterli:-1", "bitterli:65"]
VARIANTS = ["llvm_ad_rgb", "scalar_rgb"]


def log(msg: str) -> None:
    print(f"[pt_speed] {msg}", file=sys.stderr, flush=True)


def run(cmd: list[str], **kw) -> subprocess.CompletedProcess:
    log("$ " + " ".join(cmd))
    return subprocess.run(cmd, cwd=REPO, text=True, stdout=subprocess.PIPE, **kw)


def children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def octolux_speed(binary: str, scene: str, spp: int, res: str, depth: int, threads: int, tmp: str,
                  verbose: bool) -> dict:
    out = os.path.join(tmp, "x.exr")
    c0 = children_cpu()
    p = run([binary, "render", scene, "--integrator", "path", "--spp", str(spp), "--resolution", res,
             "--max-depth", str(depth), "--threads", str(threads), "--quiet", "-o", out],
            stderr=None if verbose else subprocess.DEVNULL)
    cpu = children_cpu() - c0
    if p.returncode != 0:
        raise RuntimeError(f"octolux exited with {p.returncode}")
    with open(os.path.join(tmp, "x.json")) as f:
        stats = json.load(f)
    sps = float(stats["samples_per_second"])
    t = stats.get("timings", {})
    # CPU time of the render phase, estimated as the process's CPU time scaled by render_s / total_s.
    cpu_render = cpu * t["render_s"] / t["total_s"] if t.get("total_s") else cpu
    samples = sps * t["render_s"] if t.get("render_s") else None
    return {"samples_per_second": sps, "samples_per_cpu_second": samples / cpu_render if samples and cpu_render > 0 else None,
            "stats": stats}


def mitsuba_speed(xml: str, variant: str, spp: int, res: str, depth: int, threads: int, verbose: bool) -> dict:
    cmd = [MI_PY, MI_RENDER, xml, "--variant", variant, "--spp", str(spp), "--resolution", res,
           "--max-depth", str(depth), "--threads", str(threads), "--sampler", "independent", "--quiet",
           "--passes", "1"]
    if not variant.startswith("scalar"):
        cmd += ["--warmup", "--warmup-spp", "1"]
    p = run(cmd, stderr=None if verbose else subprocess.DEVNULL)
    if p.returncode != 0:
        raise RuntimeError(f"render.py ({variant}) exited with {p.returncode}")
    return json.loads(p.stdout.strip().splitlines()[-1])


def med(values):
    v = [x for x in values if x]
    return statistics.median(v) if v else None


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--case", action="append", help="SCENE:MAX_DEPTH (repeatable; default: %s)" % ", ".join(DEFAULT_CASES))
    ap.add_argument("--spp", type=int, default=32, help="spp for octolux and Mitsuba llvm (default 32)")
    ap.add_argument("--spp-scalar", type=int, default=None, help="spp for Mitsuba scalar_rgb (default: --spp)")
    ap.add_argument("--resolution", default="512x512")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=1, help="runs per measurement; the median is reported")
    ap.add_argument("--variants", default=",".join(VARIANTS))
    ap.add_argument("--octolux", default=os.path.join(REPO, "target", "release", "octolux"))
    ap.add_argument("--build", action="store_true", help="cargo build --release -p octolux-cli first")
    ap.add_argument("--skip-octolux", action="store_true")
    ap.add_argument("--skip-mitsuba", action="store_true")
    ap.add_argument("--json", help="also write all results here")
    ap.add_argument("--verbose", action="store_true", help="show the renderers' stderr")
    args = ap.parse_args(argv)

    cases = []
    for c in args.case or DEFAULT_CASES:
        scene, depth = c.rsplit(":", 1)
        if scene not in ("cornell-box", "bitterli"):
            ap.error(f"unknown scene '{scene}' (cornell-box or bitterli)")
        cases.append((scene, int(depth)))
    variants = [v for v in args.variants.split(",") if v] if not args.skip_mitsuba else []
    spp_scalar = args.spp_scalar or args.spp

    if args.build and not args.skip_octolux:
        subprocess.run(["cargo", "build", "--release", "-p", "octolux-cli"], cwd=REPO, check=True)
    need_octolux_bin = not args.skip_octolux or any(s == "cornell-box" for s, _ in cases) and variants
    if need_octolux_bin and not os.path.exists(args.octolux):
        sys.exit(f"octolux binary not found: {args.octolux} (cargo build --release -p octolux-cli, or --build)")
    if variants and not os.path.exists(MI_PY):
        sys.exit(f"{MI_PY} missing: run tools/mitsuba/setup.sh")

    results = []
    load0 = os.getloadavg()
    with tempfile.TemporaryDirectory(prefix="octolux-ptspeed-") as tmp:
        exported: dict[int, str] = {}

        def mitsuba_xml(scene: str, depth: int) -> str:
            if scene == "bitterli":
                return BITTERLI
            if depth not in exported:
                d = os.path.join(tmp, f"export-{depth}")
                os.makedirs(d, exist_ok=True)
                xml = os.path.join(d, "scene.xml")
                p = run([args.octolux, "export", "cornell-box", "-o", xml, "--max-depth", str(depth)])
                if p.returncode != 0:
                    raise RuntimeError("octolux export failed")
                exported[depth] = xml
            return exported[depth]

        for scene, depth in cases:
            row = {"scene": scene, "max_depth": depth, "resolution": args.resolution, "threads": args.threads}
            if not args.skip_octolux:
                try:
                    runs = [octolux_speed(args.octolux, "cornell-box" if scene == "cornell-box" else BITTERLI,
                                          args.spp, args.resolution, depth, args.threads, tmp, args.verbose)
                            for _ in range(args.repeat)]
                    row["octolux"] = {"spp": args.spp,
                                      "samples_per_second": statistics.median(r["samples_per_second"] for r in runs),
                                      "samples_per_cpu_second": med(r["samples_per_cpu_second"] for r in runs),
                                      "all_samples_per_second": [r["samples_per_second"] for r in runs]}
                except Exception as e:  # keep going: report what worked
                    log(f"octolux {scene}:{depth} failed: {e}")
                    row["octolux"] = {"error": str(e)}
            for v in variants:
                spp = spp_scalar if v.startswith("scalar") else args.spp
                try:
                    xml = mitsuba_xml(scene, depth)
                    runs = [mitsuba_speed(xml, v, spp, args.resolution, depth, args.threads, args.verbose)
                            for _ in range(args.repeat)]
                    row[v] = {"spp": spp,
                              "samples_per_second": statistics.median(r["samples_per_second"] for r in runs),
                              "samples_per_cpu_second": med(r.get("samples_per_cpu_second") for r in runs),
                              "all_samples_per_second": [r["samples_per_second"] for r in runs],
                              "mean_rgb": runs[0]["mean_rgb"], "threads": runs[0]["threads"],
                              "mitsuba_version": runs[0]["mitsuba_version"]}
                except Exception as e:
                    log(f"mitsuba {v} {scene}:{depth} failed: {e}")
                    row[v] = {"error": str(e)}
            results.append(row)

    # Table.
    def sps(row, key):
        r = row.get(key) or {}
        return r.get("samples_per_second")

    head = f"{'scene':12s} {'depth':>5s} {'octolux MS/s':>13s}"
    for v in variants:
        head += f" {v + ' MS/s':>17s} {'oct/' + v.split('_')[0]:>11s}"
    print(f"# {args.resolution}, {args.threads} threads, spp: octolux/llvm {args.spp}, scalar {spp_scalar}")
    print(head)
    for row in results:
        o = sps(row, "octolux")
        line = f"{row['scene']:12s} {row['max_depth']:5d} {(f'{o / 1e6:.3f}' if o else '-'):>13s}"
        for v in variants:
            m = sps(row, v)
            ratio = f"{o / m:.2f}x" if (o and m) else "-"
            line += f" {(f'{m / 1e6:.3f}' if m else 'failed'):>17s} {ratio:>11s}"
        print(line)
    # The same per CPU-second of the render (x threads): less sensitive to other load on the machine.
    print(f"# per CPU-second x {args.threads} (estimate of an otherwise idle machine; load average was "
          f"{load0[0]:.2f} at start, {os.getloadavg()[0]:.2f} at end)")
    print(head)
    for row in results:
        o = (row.get("octolux") or {}).get("samples_per_cpu_second")
        o = o * args.threads if o else None
        line = f"{row['scene']:12s} {row['max_depth']:5d} {(f'{o / 1e6:.3f}' if o else '-'):>13s}"
        for v in variants:
            m = (row.get(v) or {}).get("samples_per_cpu_second")
            m = m * args.threads if m else None
            ratio = f"{o / m:.2f}x" if (o and m) else "-"
            line += f" {(f'{m / 1e6:.3f}' if m else 'failed'):>17s} {ratio:>11s}"
        print(line)
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"args": vars(args), "loadavg_start": load0, "loadavg_end": os.getloadavg(),
                       "results": results}, f, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
