#!/usr/bin/env python3
"""Time to error on every reference scene: the octree (its default `mode=terminate` and the
paper's `mode=paper`) against octolux path and Mitsuba 3 path, and optionally the baselines, in
one run.

    .venv-peers/bin/python bench/time_to_error.py --budget 60     # the four methods, ten scenes
    .venv-peers/bin/python bench/time_to_error.py --scenes cornell-box box --budget 10
    .venv-peers/bin/python bench/time_to_error.py --methods octree path ward --scenes cbox
    .venv-peers/bin/python bench/time_to_error.py --plot-only target/tte/results.json
    .venv-peers/bin/python bench/time_to_error.py --methods path --path-variant split4=split=4

Scenes: the six of ../shared/scenes/bitterli-collection/ at the resolution and max depth of their
time-to-error references (tests/refs/tte/manifest.json, 160 wide, each with its own noise at about
2e-3 or below, except box's 0.09: it is lit through caustics) and the four of
tests/refs/manifest.json (cornell-box, cornell-spheres, cbox, bitterli; 128x128).
Methods, each a ladder of runs, one process per run, all threads of the machine:
  octree, octree-unbiased (--set mode=unbiased): the octree modes that trace paths on
      (photons, spp) = (12.5e3, 1), (5e4, 4), (2e5, 16), (8e5, 64), (1.6e6, 256), (3.2e6, 1024), ...
  octree-paper (--set mode=paper), ward, christensen, photonmap
      (photons, spp) = (1e5, 1), (3e5, 4), (1e6, 16), (2e6, 64), (4e6, 256), (8e6, 1024)
  path (octolux), mitsuba (Mitsuba 3 path, llvm_ad_rgb, tools/mitsuba/render.py, independent sampler)
      spp = 1, 4, 16, 64, 256, 1024, 4096, 16384
A ladder stops when its spent cost plus the next rung's predicted cost (this rung's times the
growth) would pass --budget CPU seconds (a second rung is run up to 3x the budget).

Cost of a run = CPU seconds (user + system, all threads) of producing the image from the loaded
scene: the photon pass and cache build included. octolux: the child's CPU (wait4) minus the CPU
of a setup run of the same scene (load, prepare, 1 spp at 8x8: measured once per scene);
Mitsuba: the process's CPU inside the render loop (render.py's render_cpu_s, after an untimed
1-spp warm-up that compiles the kernels). CPU time is the headline because the machine is
shared; the renderers' own wall clocks are recorded too (octolux build_s + render_s, Mitsuba
render_s).

Error = relMSE against the Mitsuba 3 reference (octolux compare: mean of (a-b)^2/(b^2+1e-2))
minus the reference's own expected relMSE (its manifest's self-noise), an estimate of the
error against the exact image. Each curve is interpolated log-log at the targets; the unbiased
path tracers are extrapolated past their last rung as error ~ 1/cost (marked ~); a cache that
never reaches a target is biased there and its floor (lowest error seen) is reported.

Writes target/tte/results.json, target/tte/results.md, and with --plot docs/img/time_to_error.png;
--write-docs writes results.md between the tte markers of the run's dated lab record,
docs/lab/<date of the run>-time-to-error.md (created when absent; text around the markers kept).
"""
from __future__ import annotations

import argparse
import json
import math
import os
import re
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
# OCTOLUX_BIN: a copy of the binary, so that a rebuild during a long run does not change it
BIN = Path(os.environ.get("OCTOLUX_BIN", ROOT / "target" / "release" / "octolux"))
OUT = ROOT / "target" / "tte"
sys.path.insert(0, str(ROOT / "bench"))
import scenes as aliases  # noqa: E402  (bench/scenes.json: the one table of scene aliases)
from machine import cpu_line  # noqa: E402
MI_PYTHON = Path(os.environ.get("OCTOLUX_MI_PYTHON", ROOT / ".venv-mitsuba" / "bin" / "python"))
RENDER_PY = ROOT / "tools" / "mitsuba" / "render.py"
LAB = ROOT / "docs" / "lab"
IMG = ROOT / "docs" / "img" / "time_to_error.png"
COLLECTION = ["box", "classroom", "dining-room", "sponza", "torus", "veach-lamp"]
CLASSIC = ["cornell-box", "cornell-spheres", "cbox", "bitterli"]
CACHES = ["octree", "octree-paper", "octree-unbiased", "ward", "christensen", "photonmap"]
METHODS = ["octree", "octree-paper", "octree-unbiased", "path", "mitsuba", "ward", "christensen", "photonmap"]
DEFAULT_METHODS = ["octree", "octree-paper", "octree-unbiased", "path", "mitsuba"]
# --set flags of the octree variants (the integrator is `octree`)
# the methods whose error keeps falling as 1/cost past their last rung
UNBIASED = ["path", "mitsuba", "octree-unbiased"]
VARIANTS = {"octree-paper": ["--set", "mode=paper"], "octree-unbiased": ["--set", "mode=unbiased"]}
CACHE_RUNGS = [(100_000, 1), (300_000, 4), (1_000_000, 16), (2_000_000, 64), (4_000_000, 256), (8_000_000, 1024)]
# The octree modes that trace paths on past the cache (terminate, unbiased): photons 4x per rung,
# as the spp, up to 800k (the cache's noise, 1/photons, and the samples', 1/spp, keep their ratio:
# the optimum of error = A/photons + B/spp at a cost linear in both), then 2x: past about 1M
# photons the cache's error is below the samples' and more photons only cost (docs/lab,
# 2026-12-04-time-to-error.md: the all-doubling and all-4x ladders measured).
TRACED_RUNGS = [(12_500, 1), (50_000, 4), (200_000, 16), (800_000, 64), (1_600_000, 256), (3_200_000, 1024),
                (6_400_000, 4096)]
TRACED = ["octree", "octree-unbiased"]
SPP_RUNGS = [1, 4, 16, 64, 256, 1024, 4096, 16384]
TARGETS = [1.0, 0.3, 0.1, 0.03, 0.01, 0.003, 0.001]
SEED = 7
BEGIN, END = "<!-- tte:begin (bench/time_to_error.py --write-docs) -->", "<!-- tte:end -->"


def _add(spec: str, table: dict[str, list[str]], lists: tuple[list[str], ...]) -> str:
    """NAME=KEY=VALUE[,KEY=VALUE...]: NAME's --set options in `table`, NAME in each of `lists`."""
    name, _, keys = spec.partition("=")
    table[name] = [a for kv in filter(None, keys.split(",")) for a in ("--set", kv)]
    for lst in lists:
        if name not in lst:
            lst.append(name)
    return name


def add_variant(spec: str) -> str:
    """--variant NAME=KEY=VALUE[,KEY=VALUE...]: an octree method with these --set keys (traced ladder)."""
    return _add(spec, VARIANTS, (CACHES, METHODS, TRACED))


# --path-variant: path-tracer methods with --set keys (the spp ladder, unbiased)
PATH_VARIANTS: dict[str, list[str]] = {}


def add_path_variant(spec: str) -> str:
    """--path-variant NAME=KEY=VALUE[,KEY=VALUE...]: the path tracer with these --set keys."""
    return _add(spec, PATH_VARIANTS, (METHODS, UNBIASED))


def log(msg: str) -> None:
    print(f"[tte {time.strftime('%H:%M:%S')}] {msg}", file=sys.stderr, flush=True)


def scenes() -> dict[str, dict]:
    """name -> {scene (octolux argument), mi_scene (Mitsuba file or None: export), ref, res, depth, ref_noise}."""
    out = {}
    coll = json.loads((ROOT / "tests/refs/collection/manifest.json").read_text())["references"]
    tte_manifest = ROOT / "tests/refs/tte/manifest.json"
    tte = json.loads(tte_manifest.read_text())["references"] if tte_manifest.exists() else {}
    for name in COLLECTION:
        folder, r = ("tests/refs/tte", tte[name]) if name in tte else ("tests/refs/collection", coll[name])
        path = aliases.get(name)["scene"]
        out[name] = {"scene": str(path), "mi_scene": str(path), "ref": str(ROOT / folder / r["file"]),
                     "res": r["resolution"], "depth": int(r["max_depth"]),
                     "ref_noise": float(r["self_noise"]["ref_rel_mse"])}
    old = json.loads((ROOT / "tests/refs/manifest.json").read_text())["references"]
    for name in CLASSIC:
        r = old[name]
        alias = aliases.get(name)
        builtin, path = alias["builtin"], alias["scene"]
        # self_noise.rel_mse compares two independent full renders: the reference's own
        # expected relMSE against the exact image is half of it.
        out[name] = {"scene": path, "mi_scene": None if builtin else path, "ref": str(ROOT / "tests/refs" / r["file"]),
                     "res": r["resolution"], "depth": int(r["max_depth"]),
                     "ref_noise": float(r["self_noise"]["rel_mse"]) / 2}
    return out


def measured(cmd: list[str]) -> tuple[float, float, str]:
    """Run a command; returns (CPU s of the child: user + system, from RUSAGE_CHILDREN deltas; wall s; stdout)."""
    import resource

    def cpu() -> float:
        r = resource.getrusage(resource.RUSAGE_CHILDREN)
        return r.ru_utime + r.ru_stime

    c0, t0 = cpu(), time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True)
    wall, used = time.perf_counter() - t0, cpu() - c0
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed ({p.returncode}): {p.stderr.strip()[-800:]}")
    return used, wall, p.stdout


def compare(img: Path, ref: str) -> dict:
    return json.loads(subprocess.run([str(BIN), "compare", str(img), ref], check=True, capture_output=True, text=True).stdout)


def octolux_cmd(sc: dict, method: str, spp: int, photons: int | None, out: Path, res=None) -> list[str]:
    w, h = res or sc["res"]
    integrator = "octree" if method in VARIANTS else "path" if method in PATH_VARIANTS else method
    cmd = [str(BIN), "render", sc["scene"], "--integrator", integrator, "--spp", str(spp), "--resolution", f"{w}x{h}",
           "--max-depth", str(sc["depth"]), "--seed", str(SEED), "-q", "-o", str(out)]
    return cmd + VARIANTS.get(method, PATH_VARIANTS.get(method, [])) + (["--photons", str(photons)] if photons else [])


def setup_cpu(name: str, sc: dict) -> float:
    """CPU of loading and preparing the scene in octolux (a path render of 1 spp at 8x8), min of two."""
    out = OUT / "runs" / f"{name}-setup.exr"
    out.parent.mkdir(parents=True, exist_ok=True)
    return min(measured(octolux_cmd(sc, "path", 1, None, out, res=(8, 8)))[0] for _ in range(2))


def mitsuba_scene(name: str, sc: dict) -> str:
    if sc["mi_scene"]:
        return sc["mi_scene"]
    xml = OUT / "export" / f"{name}.xml"
    xml.parent.mkdir(parents=True, exist_ok=True)
    subprocess.run([str(BIN), "export", name, "-o", str(xml), "--max-depth", str(sc["depth"])], check=True,
                   capture_output=True)
    return str(xml)


def run_rung(name: str, sc: dict, method: str, rung, setup: float) -> dict:
    out = OUT / "runs" / f"{name}-{method}-{'-'.join(map(str, rung if isinstance(rung, tuple) else (rung,)))}.exr"
    out.parent.mkdir(parents=True, exist_ok=True)
    if method == "mitsuba":
        spp = rung
        w, h = sc["res"]
        cmd = [str(MI_PYTHON), str(RENDER_PY), mitsuba_scene(name, sc), "-o", str(out), "--spp", str(spp),
               "--resolution", f"{w}x{h}", "--max-depth", str(sc["depth"]), "--seed", str(SEED),
               "--sampler", "independent", "--warmup", "--warmup-spp", "1", "--quiet"]
        child_cpu, child_wall, stdout = measured(cmd)
        info = json.loads(stdout.strip().splitlines()[-1])
        cost, wall, extra = info["render_cpu_s"], info["render_s"], {"spp": spp}
    else:
        photons, spp = rung if method in CACHES else (None, rung)
        child_cpu, child_wall, _ = measured(octolux_cmd(sc, method, spp, photons, out))
        stats = json.loads(out.with_suffix(".json").read_text())
        t = stats["timings"]
        cost, wall = max(child_cpu - setup, 1e-3), t.get("build_s", 0.0) + t["render_s"]
        extra = {"spp": spp, "photons": photons}
        b = stats.get("build") or {}
        for k in ("global_photons", "caustic_photons", "t_photons_s", "t_octree_s", "t_c_s", "bytes"):
            if k in b:
                extra[k] = b[k]
        if "cache_query_share" in stats:
            extra["query_share"] = stats["cache_query_share"]
    err = compare(out, sc["ref"])
    rel = err["rel_mse"]
    return {"method": method, "cost_cpu_s": cost, "wall_s": wall, "child_cpu_s": child_cpu, "child_wall_s": child_wall,
            "rel_mse": rel, "error": rel - sc["ref_noise"], "mean_ratio": err.get("mean_ratio"), **extra}


def ladder(name: str, sc: dict, method: str, budget: float, setup: float) -> list[dict]:
    rungs = TRACED_RUNGS if method in TRACED else CACHE_RUNGS if method in CACHES else SPP_RUNGS
    growth = 3.8 if method in CACHES else 4.0
    pts, spent = [], 0.0
    for i, rung in enumerate(rungs):
        try:
            p = run_rung(name, sc, method, rung, setup)
        except (RuntimeError, subprocess.CalledProcessError, json.JSONDecodeError, KeyError) as e:
            log(f"{name} {method} {rung}: FAILED {e}")
            break
        pts.append(p)
        spent += p["cost_cpu_s"]
        log(f"{name:15} {method:11} {str(rung):14} cpu {p['cost_cpu_s']:8.2f} s  wall {p['wall_s']:7.2f} s  "
            f"relMSE {p['rel_mse']:.3e}  error {p['error']:.3e}")
        # At least two rungs (a curve), unless the second alone would be far over budget.
        nxt = spent + growth * p["cost_cpu_s"]
        if nxt > budget and (i >= 1 or nxt > 3 * budget):
            break
    return pts


def time_at(pts: list[dict], target: float, unbiased: bool) -> tuple[float | None, str]:
    """CPU cost at which the curve reaches `target` (log-log interpolation): (cost, how)."""
    c = [(p["cost_cpu_s"], p["error"]) for p in sorted(pts, key=lambda p: p["cost_cpu_s"])]
    if not c:
        return None, "none"
    if c[0][1] <= target:
        return c[0][0], "first rung"
    for (t0, e0), (t1, e1) in zip(c, c[1:]):
        if e0 > target >= e1 and e1 > 0:
            a = (math.log(target) - math.log(e0)) / (math.log(e1) - math.log(e0))
            return math.exp(math.log(t0) + a * (math.log(t1) - math.log(t0))), "interpolated"
        if e0 > target >= e1:  # e1 <= 0: below the reference's noise
            return t1, "at the reference noise"
    t1, e1 = c[-1]
    if unbiased and e1 > 0:
        return t1 * e1 / target, "extrapolated"
    return None, "not reached"


def run_share(name: str, p: dict) -> float:
    """Cache-query share of an octree run, from its out.json (results of older versions lack it)."""
    f = OUT / "runs" / f"{name}-octree-{p.get('photons')}-{p.get('spp')}.json"
    try:
        return float(json.loads(f.read_text()).get("cache_query_share") or 0.0)
    except (OSError, ValueError):
        return 0.0


def methods_in(results: dict) -> list[str]:
    """The known methods, then any other (a --variant) that the results hold curves of."""
    seen = {m for r in results["scenes"].values() for m, pts in r["curves"].items() if pts}
    return [m for m in METHODS if m in seen] + sorted(seen - set(METHODS))


def summarise(results: dict) -> str:
    lines = []
    METHODS = methods_in(results)
    label = {"mitsuba": "Mitsuba 3"}
    lines.append("| scene | res | ref noise | target | " + " | ".join(label.get(m, m) for m in METHODS)
                 + " | octree vs Mitsuba | octree vs path |")
    lines.append("|---" * (6 + len(METHODS)) + "|")
    heads = []
    for name, r in results["scenes"].items():
        sc = r["scene"]
        floor = {m: min((p["error"] for p in r["curves"].get(m, [])), default=None) for m in METHODS}
        best = None
        for target in TARGETS:
            if target < 2 * sc["ref_noise"]:
                continue
            cells, times = [], {}
            for m in METHODS:
                t, how = time_at(r["curves"].get(m, []), target, m in UNBIASED)
                times[m] = (t, how)
                if t is None:
                    cells.append("—" if how == "none" else f"floor {floor[m]:.2g}" if floor[m] is not None else "—")
                else:
                    cells.append({"extrapolated": "~", "first rung": "≤"}.get(how, "") + f"{t:.3g}")
            none = (None, "none")
            (to, ho), (tm, hm), (tp, _) = times.get("octree", none), times.get("mitsuba", none), times.get("path", none)
            if ho == "first rung" and hm == "first rung":
                continue  # above both curves: says nothing
            sp = f"{tm / to:.2g}x" if to and tm else "—"
            spp = f"{tp / to:.2g}x" if to and tp else "—"
            if to and tm and ho != "first rung":
                best = (target, tm / to)
            lines.append(f"| {name} | {sc['res'][0]}x{sc['res'][1]} | {sc['ref_noise']:.2g} | {target:g} | "
                         + " | ".join(cells) + f" | {sp} | {spp} |")
        oc = sorted(r["curves"].get("octree", []), key=lambda p: p["cost_cpu_s"])
        trend = oc[-1]["error"] / oc[-2]["error"] if len(oc) >= 2 and oc[-2]["error"] > 0 else None
        share = max((p.get("query_share") or run_share(name, p) for p in oc), default=None)
        heads.append((name, best, floor.get("octree"), trend, share))
    lines.append("")
    lines.append("CPU seconds (user + system, both cores) to reach each error (relMSE minus the reference's own "
                 "noise); ~ = extrapolated as 1/cost past the last rung (unbiased path tracers only); "
                 "≤ = already at the first rung; floor = the lowest error of a cache that never reached the target within the budget.")
    lines.append("")
    lines.append("| scene | octree's equal-error speed-up over Mitsuba 3 path (at the lowest target it reaches) "
                 "| octree's lowest error | its last rung / the one before | octree query share (wall) |")
    lines.append("|---|---|---|---|---|")
    for name, best, fl, trend, share in heads:
        sp = f"{best[1]:.2g}x at {best[0]:g}" if best else "no common target"
        f = "—" if fl is None else f"{fl:.3g}"
        t = "—" if trend is None else f"{trend:.2f}" + (" (flat: bias floor)" if trend > 0.8 else "")
        q = "—" if not share else f"{share:.0%}" + (" (loaded machine)" if share > 1 else "")
        lines.append(f"| {name} | {sp} | {f} | {t} | {q} |")
    return "\n".join(lines) + "\n"


def plot(results: dict, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    names = list(results["scenes"])
    METHODS = methods_in(results)
    cols = 4
    rows = math.ceil(len(names) / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4 * cols, 3.3 * rows), squeeze=False)
    style = {"octree": ("C3", "o"), "octree-paper": ("C5", "P"), "octree-unbiased": ("C6", "*"), "path": ("C0", "s"), "mitsuba": ("k", "^"), "ward": ("C2", "v"),
             "christensen": ("C4", "D"), "photonmap": ("C1", "x")}
    for ax, name in zip(axes.flat, names):
        r = results["scenes"][name]
        for m in METHODS:
            pts = sorted(r["curves"].get(m, []), key=lambda p: p["cost_cpu_s"])
            if pts:
                c, s = style.get(m, (f"C{7 + METHODS.index(m) % 3}", "d"))
                ax.loglog([p["cost_cpu_s"] for p in pts], [max(p["error"], 1e-5) for p in pts], color=c, marker=s,
                          label="Mitsuba 3 path" if m == "mitsuba" else m, lw=1.2, ms=4)
        ax.axhline(r["scene"]["ref_noise"], color="0.6", ls=":", lw=1)
        ax.set_title(name, fontsize=10)
        ax.set_xlabel("CPU s (build + render)", fontsize=8)
        ax.set_ylabel("relMSE − ref. noise", fontsize=8)
        ax.tick_params(labelsize=7)
    for ax in list(axes.flat)[len(names):]:
        ax.axis("off")
    axes.flat[0].legend(fontsize=7)
    fig.suptitle("Time to error (dotted: the reference's own noise)", fontsize=11)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90)
    log(f"wrote {path}")


def write_docs(md: str, results: dict) -> None:
    date = results.get("date") or time.strftime("%Y-%m-%d")
    doc = LAB / f"{date}-time-to-error.md"
    text = doc.read_text() if doc.exists() else f"# {date}: time to error on the reference scenes\n\n"
    block = f"{BEGIN}\n{results['about']}\n\n{md}{END}"
    if BEGIN in text and END in text:
        text = re.sub(re.escape(BEGIN) + ".*?" + re.escape(END), lambda _: block, text, flags=re.S)
    else:
        text += "\n" + block + "\n"
    doc.write_text(text)
    log(f"updated {doc}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", nargs="+", default=COLLECTION + CLASSIC)
    ap.add_argument("--methods", nargs="*", default=DEFAULT_METHODS, help="methods to run (none: only the --variant ones)")
    ap.add_argument("--budget", type=float, default=60.0, help="CPU seconds per method and scene (default 60)")
    ap.add_argument("--plot", action="store_true", help=f"write {IMG.relative_to(ROOT)}")
    ap.add_argument("--write-docs", action="store_true", help="write the tables into docs/lab/<date>-time-to-error.md")
    ap.add_argument("--plot-only", type=Path, help="re-plot and re-tabulate a results.json")
    ap.add_argument("--variant", action="append", default=[],
                    help="NAME=KEY=VALUE[,KEY=VALUE...]: an extra octree method with these --set keys")
    ap.add_argument("--path-variant", action="append", default=[],
                    help="NAME=KEY=VALUE[,KEY=VALUE...]: an extra path-tracer method with these --set keys")
    ap.add_argument("--reuse", action="store_true", help="keep the scenes already in target/tte/results.json")
    args = ap.parse_args()
    extra = [add_variant(v) for v in args.variant] + [add_path_variant(v) for v in args.path_variant]
    args.methods = list(dict.fromkeys(args.methods + extra))
    if args.plot_only:
        results = json.loads(args.plot_only.read_text())
    else:
        if not BIN.exists():
            subprocess.run(["cargo", "build", "--release", "-p", "octolux-cli"], cwd=ROOT, check=True)
        if "mitsuba" in args.methods and not MI_PYTHON.exists():
            raise SystemExit(f"no Mitsuba python at {MI_PYTHON} (tools/mitsuba/setup.sh, or set OCTOLUX_MI_PYTHON)")
        all_scenes = scenes()
        t0 = time.time()
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True).stdout.strip()
        results = {"date": time.strftime("%Y-%m-%d"),
                   "about": f"`bench/time_to_error.py --budget {args.budget:g}` at {head}, "
                            f"{time.strftime('%Y-%m-%d')}, {os.cpu_count()} CPUs; {cpu_line()}",
                   "scenes": {}}
        log(cpu_line())
        if args.reuse and (OUT / "results.json").exists():
            results["scenes"] = json.loads((OUT / "results.json").read_text())["scenes"]
        for name in args.scenes:
            sc = all_scenes.get(name)
            if sc is None:
                log(f"{name}: unknown scene, skipped")
                continue
            if name in results["scenes"]:
                log(f"{name}: reused from {OUT / 'results.json'}")
                continue
            if sc["mi_scene"] and not Path(sc["mi_scene"]).exists():
                print(f"skip: {name} ({sc['mi_scene']} missing)")
                continue
            setup = setup_cpu(name, sc)
            log(f"{name}: setup (load + prepare) {setup:.2f} CPU s, reference noise {sc['ref_noise']:.2e}")
            curves = {m: ladder(name, sc, m, args.budget, setup) for m in args.methods}
            results["scenes"][name] = {"scene": sc, "setup_cpu_s": setup, "curves": curves}
            OUT.mkdir(parents=True, exist_ok=True)
            (OUT / "results.json").write_text(json.dumps(results, indent=1))
        results["total_wall_s"] = time.time() - t0
        (OUT / "results.json").write_text(json.dumps(results, indent=1))
        log(f"total {results['total_wall_s'] / 60:.1f} min; {OUT / 'results.json'}")
    md = summarise(results)
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "results.md").write_text(md)
    print(md)
    if args.plot:
        plot(results, IMG)
    if args.write_docs:
        write_docs(md, results)
    return 0


if __name__ == "__main__":
    sys.exit(main())
