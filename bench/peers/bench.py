#!/usr/bin/env python3
"""Side by side with the peers: time-to-error of octolux against Mitsuba 3 and LuxCore (issue 5).

    bench/peers/run.sh [--quick] [options]            # installs the peers, then runs this file
    .venv-peers/bin/python bench/peers/bench.py [--quick] [--scenes ...] [--renderers ...] [--out DIR]

For every scene (cornell-box, cornell-spheres, Mitsuba's cbox, Bitterli's box) and every renderer
(octolux path, octolux octree, Mitsuba 3 path, LuxCore PATHCPU, LuxCore PATHCPU + PhotonGI) it renders
a ladder of sample counts (for the two caches: sample count and photon count together), each run in
its own process with the same number of threads, and measures

* time: the renderer's own clock around "produce the image from the loaded scene":
    octolux   timings.render_s + build.t_c_s (photon tracing + octree build, also reported alone)
    Mitsuba   render.py's render_s after an untimed 1-spp warm-up (JIT kernels compiled)
    LuxCore   RenderSession.Start() .. HasDone() (PhotonGI cache build, rendering) minus its
              Embree BVH build (like the others' scene loading; reported apart); the cache build
              is also reported alone (from LuxCore's log)
  plus the process's whole wall time and CPU time (user + system, from wait4);
* error against one converged Mitsuba 3 reference per scene (cached): relMSE (as
  tools/mitsuba/compare.py: mean of (a-b)^2/(b^2+1e-2)), RMSE and the ratio of channel means,
  on the image without a 1-pixel border; LuxCore's image is compared one row up (it renders a
  Mitsuba-equivalent camera one pixel row lower; the best integer shift is measured and reported);
* memory: peak RSS of the process (GNU time's %M, else VmHWM polled every 10 ms) and the size of the cache (octolux
  build.bytes; LuxCore's "PhotonGI total memory usage").

Outputs under --out (default target/peers-results/<full|quick>/): results.json (everything),
results.md (tables), <scene>.png (relMSE against time, log-log) and the images. The headline is the
equal-error speed-up of octolux `octree` over each peer: time each renderer needs to reach the
same relMSE, interpolated log-log along its curve (see time_to_error()).

Nothing is written into the repository except with --write-docs (the results block of
docs/guide/benchmarks.md). Caches (references, exported scenes, LuxCore scene dumps) live in
target/peers-cache/ (git-ignored).
"""
from __future__ import annotations

import argparse
import datetime as dt
import hashlib
import json
import math
import os
import platform
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
BIN = ROOT / "target" / "release" / "octolux"
VPY = Path(os.environ.get("PEERS_PYTHON", ROOT / ".venv-peers" / "bin" / "python"))
RENDER_PY = ROOT / "tools" / "mitsuba" / "render.py"
CACHE = ROOT / "target" / "peers-cache"
DOCS = ROOT / "docs" / "guide" / "benchmarks.md"

sys.path.insert(0, str(ROOT / "tools" / "mitsuba"))
import locations  # noqa: E402  (tools/mitsuba/locations.py: $OCTOLUX_SHARED or <repo>/../shared)


# name -> where the scene comes from and the max_depth every renderer uses (Mitsuba's meaning),
# the same choices as tests/refs/manifest.json.
sys.path.insert(0, str(ROOT / "bench"))
import scenes as aliases  # noqa: E402  (bench/scenes.json: the one table of scene aliases)


def _scene(name: str) -> dict:
    e = aliases.get(name)
    where = {"builtin": e["scene"]} if e["builtin"] else {"xml": Path(e["scene"])}
    return {**where, "max_depth": e["max_depth"]}


SCENES = {name: _scene(name) for name in ["cornell-box", "cornell-spheres", "cbox", "bitterli"]}
RENDERERS = ["octolux-path", "octolux-octree", "mitsuba-path", "luxcore-path", "luxcore-pgi"]
LABELS = {
    "octolux-path": "octolux path",
    "octolux-octree": "octolux octree",
    "mitsuba-path": "Mitsuba 3 path",
    "luxcore-path": "LuxCore PATHCPU",
    "luxcore-pgi": "LuxCore PATHCPU+PhotonGI",
}
UNBIASED = {"octolux-path", "mitsuba-path", "luxcore-path"}
# Ladders: spp, or spp:photons for the two photon caches. octolux octree: at 128x128 a
# sample costs about as much as 16k photons (2 threads: ~8 ms per spp, ~0.45 s per 1M
# photons), so the photon count grows with spp to keep the build near half of the time.
LADDERS = {
    "full": {
        "octolux-path": "4,16,64,256,1024",
        "octolux-octree": "1:50000,4:100000,16:250000,64:1000000,256:4000000",
        "mitsuba-path": "4,16,64,256,1024",
        "luxcore-path": "4,16,64,256,1024",
        "luxcore-pgi": "4:250000,16:500000,64:1000000,256:2000000",
    },
    "quick": {
        "octolux-path": "4,16,64",
        "octolux-octree": "1:25000,4:50000,16:100000",
        "mitsuba-path": "4,16,64",
        "luxcore-path": "4,16,64",
        "luxcore-pgi": "4:50000,16:100000",
    },
}
MODE_DEFAULTS = {
    "full": {"resolution": (128, 128), "ref_spp": 8192, "max_run_s": 300.0, "check_spp": 1024},
    "quick": {"resolution": (32, 32), "ref_spp": 4096, "max_run_s": 60.0, "check_spp": 512},
}
LUX_SHIFT = (1, 0)  # (dy, dx): LuxCore pixel (y + dy, x + dx) is Mitsuba's (y, x)
MARGIN = 1
REL_EPS = 1e-2


def log(msg: str) -> None:
    print(f"[peers] {msg}", file=sys.stderr, flush=True)


def sha256_of(paths: list[Path]) -> str:
    h = hashlib.sha256()
    for p in paths:
        h.update(p.name.encode())
        h.update(p.read_bytes())
    return h.hexdigest()


def parse_ladder(s: str) -> list[tuple[int, int | None]]:
    out = []
    for part in s.split(","):
        if ":" in part:
            a, b = part.split(":")
            out.append((int(a), int(float(b))))
        else:
            out.append((int(part), None))
    return out


# --------------------------------------------------------------------------------------------------
# processes


class HwmPoller:
    """Peak RSS of a child process: polls VmHWM in /proc/PID/status (the high-water mark of the
    child's own address space). wait4's ru_maxrss is no good here: Linux carries the forking
    parent's (this Python process with numpy and Mitsuba loaded) high-water mark over the exec.
    Readings are taken only once the child has exec'd (its cmdline differs from ours)."""

    def __init__(self, pid: int, interval: float = 0.01):
        import threading
        self.pid, self.interval, self.peak = pid, interval, 0
        self.own = Path("/proc/self/cmdline").read_bytes()
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self.loop, daemon=True)
        self.thread.start()

    def loop(self) -> None:
        while not self.stop.is_set():
            self.sample()
            self.stop.wait(self.interval)

    def sample(self) -> None:
        try:
            if Path(f"/proc/{self.pid}/cmdline").read_bytes() == self.own:
                return
            for line in Path(f"/proc/{self.pid}/status").read_text().splitlines():
                if line.startswith("VmHWM:"):
                    self.peak = max(self.peak, int(line.split()[1]) * 1024)
        except (OSError, ValueError, IndexError):
            pass

    def finish(self) -> int:
        self.stop.set()
        self.thread.join()
        return self.peak


GNU_TIME = "/usr/bin/time" if Path("/usr/bin/time").exists() else None


def run_measured(cmd: list[str], log_path: Path) -> dict:
    """Run cmd; stdout captured, stderr to log_path. Wall time; CPU time (user + system) from wait4;
    peak RSS from GNU time's %M when /usr/bin/time exists (it forks the renderer from its own small
    image), else by polling VmHWM (HwmPoller)."""
    log_path.parent.mkdir(parents=True, exist_ok=True)
    load0 = os.getloadavg()[0]
    rss_file = log_path.with_suffix(".rss")
    full = ([GNU_TIME, "-f", "%M", "-o", rss_file] if GNU_TIME else []) + list(cmd)
    t0 = time.perf_counter()
    with open(log_path, "w") as lf:
        lf.write("$ " + " ".join(map(str, cmd)) + "\n")
        lf.flush()
        p = subprocess.Popen([str(c) for c in full], stdout=subprocess.PIPE, stderr=lf, cwd=ROOT)
        hwm = None if GNU_TIME else HwmPoller(p.pid)
        try:
            out = p.stdout.read().decode(errors="replace")
        finally:
            p.stdout.close()
        if hwm:
            hwm.sample()
        _, status, ru = os.wait4(p.pid, 0)
    p.returncode = os.waitstatus_to_exitcode(status)
    wall = time.perf_counter() - t0
    peak, how = None, None
    if hwm:
        peak, how = hwm.finish(), "VmHWM polling"
    else:
        try:
            peak, how = int(rss_file.read_text().strip().splitlines()[-1]) * 1024, "GNU time %M"
        except (OSError, ValueError, IndexError):
            pass
    res = {
        "rc": p.returncode,
        "stdout": out,
        "process_wall_s": wall,
        "cpu_s": ru.ru_utime + ru.ru_stime,
        "peak_rss_bytes": peak,
        "peak_rss_how": how,
        "load_avg_1m_before": load0,
        "load_avg_1m_after": os.getloadavg()[0],
    }
    if p.returncode != 0:
        tail = log_path.read_text(errors="replace")[-3000:]
        raise RuntimeError(f"command failed (rc {p.returncode}): {' '.join(map(str, cmd))}\n{tail}")
    return res


def last_json(stdout: str) -> dict:
    for line in reversed(stdout.strip().splitlines()):
        line = line.strip()
        if line.startswith("{"):
            return json.loads(line)
    raise RuntimeError(f"no JSON in output:\n{stdout[-2000:]}")


# --------------------------------------------------------------------------------------------------
# images and errors


def read_image(path: Path) -> np.ndarray:
    if path.suffix == ".npy":
        return np.load(path).astype(np.float64)[..., :3]
    from compare import read_exr  # tools/mitsuba/compare.py (Mitsuba's Bitmap; never pyluxcore here)
    return read_exr(str(path))


def crop(img: np.ndarray, shift=(0, 0)) -> np.ndarray:
    h, w = img.shape[:2]
    dy, dx = shift
    return img[MARGIN + dy:h - MARGIN + dy, MARGIN + dx:w - MARGIN + dx]


def errors(img: np.ndarray, ref: np.ndarray, shift=(0, 0)) -> dict:
    a, b = crop(img, shift), crop(ref)
    d2 = (a - b) ** 2
    ma, mb = a.reshape(-1, 3).mean(0), b.reshape(-1, 3).mean(0)
    ratio = ma / mb
    return {
        "rel_mse": float(np.mean(d2 / (b * b + REL_EPS))),
        "rmse": float(np.sqrt(np.mean(d2))),
        "mean_ratio": [float(x) for x in ratio],
        "mean_err": float(np.max(np.abs(ratio - 1))),
        "finite": bool(np.isfinite(img).all()),
    }


def best_shift(img: np.ndarray, ref: np.ndarray) -> tuple[int, int]:
    res = []
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            a, b = crop(img, (dy, dx)), crop(ref)
            res.append((float(np.mean((a - b) ** 2 / (b * b + REL_EPS))), (dy, dx)))
    return min(res)[1]


# --------------------------------------------------------------------------------------------------
# scenes, references, dumps


class Scene:
    def __init__(self, name: str, spec: dict, res: tuple[int, int], max_depth: int):
        self.name, self.spec, self.res, self.max_depth = name, spec, res, max_depth
        self.xml: Path | None = None
        self.hash = ""
        self.dump: Path | None = None
        self.ref: Path | None = None
        self.ref_info: dict = {}
        self.has_specular = False

    @property
    def res_s(self) -> str:
        return f"{self.res[0]}x{self.res[1]}"

    def prepare_xml(self) -> None:
        if "builtin" in self.spec:
            d = CACHE / "scenes" / self.name
            if d.exists():
                shutil.rmtree(d)
            d.mkdir(parents=True)
            cmd = [BIN, "export", self.spec["builtin"], "-o", d / "scene.xml", "--max-depth", str(self.max_depth),
                   "--spp", "64"]
            subprocess.run([str(c) for c in cmd], check=True, capture_output=True, cwd=ROOT)
            self.xml = d / "scene.xml"
            files = [self.xml] + sorted((d / "meshes").glob("*"))
        else:
            self.xml = Path(self.spec["xml"])
            if not self.xml.exists():
                raise FileNotFoundError(self.xml)
            files = [self.xml]
        self.hash = sha256_of(files)

    def prepare_dump(self) -> None:
        tr = sha256_of([HERE / "mi_translate.py"])[:8]  # a new translator invalidates old dumps
        d = CACHE / "dumps" / f"{self.name}-{self.res_s}-d{self.max_depth}-{self.hash[:12]}-t{tr}"
        if not (d / "scene.json").exists():
            tmp = d.with_name(d.name + ".tmp")
            shutil.rmtree(tmp, ignore_errors=True)
            run_measured([VPY, HERE / "mi_translate.py", self.xml, tmp, "--resolution", self.res_s,
                          "--max-depth", str(self.max_depth)], CACHE / "logs" / f"translate-{self.name}.log")
            shutil.rmtree(d, ignore_errors=True)
            tmp.rename(d)
        self.dump = d
        self.has_specular = json.loads((d / "scene.json").read_text())["has_specular"]

    def prepare_reference(self, ref_spp: int, threads: int, seed: int = 1) -> None:
        key = f"{self.name}-{self.res_s}-d{self.max_depth}-{ref_spp}spp-s{seed}-{self.hash[:12]}"
        exr = CACHE / "refs" / f"{key}.exr"
        meta = exr.with_suffix(".json")
        if exr.exists() and meta.exists():
            self.ref, self.ref_info = exr, json.loads(meta.read_text())
            log(f"{self.name}: cached reference {exr.relative_to(ROOT)}")
            return
        reused = self.reuse_committed_reference(ref_spp)
        if reused:
            exr.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(reused[0], exr)
            meta.write_text(json.dumps(reused[1], indent=1))
            self.ref, self.ref_info = exr, reused[1]
            log(f"{self.name}: reference = {reused[0].relative_to(ROOT)} (same scene, settings and resolution)")
            return
        log(f"{self.name}: rendering the reference ({self.res_s}, {ref_spp} spp, Mitsuba 3) ...")
        cmd = [VPY, RENDER_PY, self.xml, "-o", exr, "--spp", str(ref_spp), "--resolution", self.res_s,
               "--max-depth", str(self.max_depth), "--seed", str(seed), "--sampler", "independent", "--quiet"]
        if threads:
            cmd += ["--threads", str(threads)]
        r = run_measured(cmd, CACHE / "logs" / f"ref-{key}.log")
        info = last_json(r["stdout"])
        info.update({"what": "converged Mitsuba 3 reference of bench/peers", "command": " ".join(map(str, cmd)),
                     "scene_sha256": self.hash, "process_wall_s": r["process_wall_s"],
                     "date": dt.datetime.now().isoformat(timespec="seconds")})
        meta.write_text(json.dumps(info, indent=1))
        self.ref, self.ref_info = exr, info

    def reuse_committed_reference(self, ref_spp: int):
        """tests/refs/<name>.exr when it was made from the same scene file with these settings."""
        man = ROOT / "tests" / "refs" / "manifest.json"
        if not man.exists():
            return None
        entry = json.loads(man.read_text()).get("references", {}).get(self.name)
        if not entry:
            return None
        ok = (list(entry.get("resolution", [])) == list(self.res) and int(entry.get("max_depth", -2)) == self.max_depth
              and int(entry.get("spp", 0)) >= ref_spp)
        if "builtin" in self.spec:
            ok = ok and entry.get("export_sha256") == hashlib.sha256(self.xml.read_bytes()).hexdigest()
        else:
            rel = str(self.xml).split("scenes/", 1)[-1]
            ok = ok and str(entry.get("source_scene", "")).endswith(rel)
        path = ROOT / "tests" / "refs" / entry.get("file", "")
        if not ok or not path.exists():
            return None
        info = dict(entry)
        info["what"] = "tests/refs reference reused by bench/peers"
        info["scene_sha256"] = self.hash
        return path, info


# --------------------------------------------------------------------------------------------------
# one run per renderer


def run_one(scene: Scene, renderer: str, spp: int, photons: int | None, args, outdir: Path) -> dict:
    tag = f"{renderer}-{spp:05d}" + (f"-{photons}" if photons else "")
    base = outdir / "runs" / scene.name / tag
    base.parent.mkdir(parents=True, exist_ok=True)
    logp = outdir / "logs" / scene.name / f"{tag}.log"
    rec = {"scene": scene.name, "renderer": renderer, "spp": spp, "photons": photons, "threads": args.threads,
           "seed": args.seed, "resolution": list(scene.res)}
    shift = (0, 0)
    if renderer.startswith("octolux-"):
        integ = renderer.split("-", 1)[1]
        out = base.with_suffix(".exr")
        cmd = [BIN, "render", scene.xml, "--integrator", integ, "--spp", str(spp), "--resolution", scene.res_s,
               "--max-depth", str(scene.max_depth), "--seed", str(args.seed), "--threads", str(args.threads),
               "-q", "-o", out]
        if integ == "octree":
            cmd += ["--photons", str(photons)]
        r = run_measured(cmd, logp)
        st = json.loads(out.with_suffix(".json").read_text())
        build = st.get("build") or {}
        rec.update({
            "render_s": st["timings"]["render_s"],
            "build_s": build.get("t_c_s"),
            "time_s": st["timings"]["render_s"] + (build.get("t_c_s") or 0.0),
            "cache_bytes": build.get("bytes"),
            "samples_per_second": st.get("samples_per_second"),
            "backend": st.get("backend"),
            "version": st.get("octolux_version"),
        })
        img_path = out
    elif renderer == "mitsuba-path":
        out = base.with_suffix(".exr")
        cmd = [VPY, RENDER_PY, scene.xml, "-o", out, "--spp", str(spp), "--resolution", scene.res_s,
               "--max-depth", str(scene.max_depth), "--seed", str(args.seed), "--threads", str(args.threads),
               "--sampler", "independent", "--warmup", "--warmup-spp", "1", "--quiet"]
        if args.mi_variant:
            cmd += ["--variant", args.mi_variant]
        r = run_measured(cmd, logp)
        j = last_json(r["stdout"])
        rec.update({"render_s": j["render_s"], "build_s": None, "time_s": j["render_s"], "cache_bytes": None,
                    "samples_per_second": j["samples_per_second"], "variant": j["variant"],
                    "version": j["mitsuba_version"], "drjit_version": j["drjit_version"],
                    "warmup_s": j.get("warmup_s"), "load_s": j.get("load_s")})
        img_path = out
    elif renderer.startswith("luxcore-"):
        out = base.with_suffix(".npy")
        pgi = "auto" if renderer == "luxcore-pgi" else "none"
        cmd = [VPY, HERE / "lux_render.py", scene.dump, "-o", out, "--spp", str(spp), "--pgi", pgi,
               "--threads", str(args.threads), "--seed", str(args.seed), "--log", base.with_suffix(".luxlog")]
        if photons:
            cmd += ["--photons", str(photons)]
        r = run_measured(cmd, logp)
        j = last_json(r["stdout"])
        pg = j.get("photongi") or {}
        accel = j.get("accel_build_s") or 0.0
        rec.update({"render_s": j["render_s"], "build_s": pg.get("build_s"), "time_s": j["wall_s"] - accel,
                    "accel_build_s": j.get("accel_build_s"),
                    "cache_bytes": pg.get("memory_bytes"), "pgi": j["pgi"], "spp_done": j.get("spp_done"),
                    "photongi": pg, "version": j["luxcore_version"], "start_s": j["start_s"],
                    "samples_per_second": scene.res[0] * scene.res[1] * spp / j["render_s"] if j["render_s"] else None})
        img_path = out
        shift = LUX_SHIFT
    else:
        raise ValueError(renderer)
    rec.update({k: r[k] for k in ("process_wall_s", "cpu_s", "peak_rss_bytes", "peak_rss_how",
                                  "load_avg_1m_before", "load_avg_1m_after")})
    img = read_image(img_path)
    ref = read_image(scene.ref)
    if img.shape != ref.shape:
        raise RuntimeError(f"{img_path}: shape {img.shape} != reference {ref.shape}")
    rec.update(errors(img, ref, shift))
    rec["shift"] = list(shift)
    if renderer.startswith("luxcore-"):
        rec["best_shift"] = list(best_shift(img, ref))
    rec["image"] = str(img_path.relative_to(outdir))
    return rec


# --------------------------------------------------------------------------------------------------
# analysis


def curve(runs: list[dict], renderer: str) -> list[tuple[float, float]]:
    pts = sorted((r["time_s"], r["rel_mse"]) for r in runs if r["renderer"] == renderer and r["rel_mse"] > 0)
    return pts


def time_to_error(pts: list[tuple[float, float]], target: float, unbiased: bool):
    """Time at which relMSE falls to `target` along a curve sorted by time: log-log interpolation
    between the first pair of consecutive points that brackets it. Outside the curve: an unbiased
    method is extrapolated with relMSE ~ 1/time from its nearest end point (flag 'extrapolated');
    a biased one gets None above its lowest error, and its first time as an upper bound below."""
    if not pts:
        return None, "no data"
    for (t0, e0), (t1, e1) in zip(pts, pts[1:]):
        if e0 >= target >= e1 and e0 != e1:
            a = (math.log(target) - math.log(e0)) / (math.log(e1) - math.log(e0))
            return math.exp(math.log(t0) + a * (math.log(t1) - math.log(t0))), "interpolated"
    if pts[0][1] <= target:
        if unbiased:
            return pts[0][0] * pts[0][1] / target, "extrapolated"
        return pts[0][0], "upper bound"
    if unbiased:
        # lowest-error end (the last point of a converging curve)
        t, e = min(pts, key=lambda p: p[1])
        return t * e / target, "extrapolated"
    return None, "not reached"


def choose_target(runs: list[dict]) -> float | None:
    oc = curve(runs, "octolux-octree")
    if not oc:
        return None
    lo, hi = min(e for _, e in oc), max(e for _, e in oc)
    return min(2.0 * lo, hi)


def analyse(scene_runs: dict[str, list[dict]], targets: dict[str, float]) -> dict:
    out = {}
    for name, runs in scene_runs.items():
        target = targets.get(name) or choose_target(runs)
        per = {}
        for rd in RENDERERS:
            pts = curve(runs, rd)
            if not pts:
                continue
            t, how = time_to_error(pts, target, rd in UNBIASED) if target else (None, "no target")
            rr = [r for r in runs if r["renderer"] == rd]
            last = max(rr, key=lambda r: (r["spp"], r["photons"] or 0))
            per[rd] = {
                "time_to_target_s": t, "how": how,
                "points": len(pts), "best_rel_mse": min(e for _, e in pts),
                "cache_bytes_max": max((r.get("cache_bytes") or 0) for r in rr) or None,
                "build_s_max": max((r.get("build_s") or 0) for r in rr) or None,
                "peak_rss_bytes_max": max((r["peak_rss_bytes"] or 0) for r in rr) or None,
                "mean_ratio_last": last["mean_ratio"], "last_spp": last["spp"],
            }
        oct_t = per.get("octolux-octree", {}).get("time_to_target_s")
        for rd, v in per.items():
            v["octree_speedup"] = (v["time_to_target_s"] / oct_t) if (oct_t and v["time_to_target_s"]) else None
        # speed-up at every octree ladder point (the error it reached there)
        along = []
        for r in sorted((r for r in runs if r["renderer"] == "octolux-octree"), key=lambda r: r["time_s"]):
            row = {"spp": r["spp"], "photons": r["photons"], "time_s": r["time_s"], "rel_mse": r["rel_mse"]}
            for rd in RENDERERS:
                if rd == "octolux-octree" or not curve(runs, rd):
                    continue
                t, how = time_to_error(curve(runs, rd), r["rel_mse"], rd in UNBIASED)
                row[rd] = {"time_s": t, "how": how, "speedup": (t / r["time_s"]) if t else None}
            along.append(row)
        # PhotonGI is biased and may never reach the target: compare at each of its own points
        # instead (octree's time to the error PhotonGI reached there), and keep the least
        # favourable ratio for octree.
        along_pgi = []
        oc = curve(runs, "octolux-octree")
        for t_p, e_p in curve(runs, "luxcore-pgi"):
            t_o, how = time_to_error(oc, e_p, False) if oc else (None, "no data")
            along_pgi.append({"rel_mse": e_p, "pgi_time_s": t_p, "octree_time_s": t_o, "how": how,
                              "speedup": (t_p / t_o) if t_o else None})
        ratios = [a["speedup"] for a in along_pgi if a["speedup"]]
        lux = [r for r in runs if r["renderer"] == "luxcore-path"]
        check = max(lux, key=lambda r: r["spp"]) if lux else None
        out[name] = {"target_rel_mse": target, "renderers": per, "along_octree": along,
                     "along_pgi": along_pgi, "pgi_least_speedup": min(ratios) if ratios else None,
                     "luxcore_check": None if not check else {
                         k: check.get(k) for k in ("spp", "mean_ratio", "rel_mse", "best_shift", "shift", "time_s")}}
    return out


# --------------------------------------------------------------------------------------------------
# reporting


def fmt_t(v) -> str:
    if v is None:
        return "–"
    return f"{v:.3g}"


def fmt_x(v, how="") -> str:
    if v is None:
        return "–"
    s = f"{v:.2g}×" if v < 10 else f"{v:.0f}×"
    return s + ("*" if how == "extrapolated" else ("≤" if how == "upper bound" else ""))


def mb(v) -> str:
    return "–" if not v else f"{v / 2**20:.1f}"


def is_loaded(max_load: float, threads: int) -> bool:
    """Other work ran beside the benchmark: the 1-minute load average went above the benchmark's
    own threads by more than half a core."""
    return max_load > threads + 0.5


def markdown(results: dict) -> str:
    meta, ana, runs = results["meta"], results["analysis"], results["runs"]
    meta["loaded"] = is_loaded(meta.get("max_load", 0.0), meta.get("threads", 2))
    L = []
    L.append(f"Mode `{meta['mode']}`, {meta['resolution'][0]}x{meta['resolution'][1]} pixels, {meta['threads']} threads "
             f"per renderer, reference: Mitsuba 3 at {meta['ref_spp']} spp; {meta['date']} on {meta['machine']['cpu']} "
             f"({meta['machine']['nproc']} CPUs, {meta['machine']['mem_gib']:.0f} GiB).")
    if meta.get("command"):
        L.append("")
        L.append(f"Command: `{meta['command']}` (total {meta.get('total_s', 0) / 60:.1f} min including the references).")
    if meta.get("loaded"):
        L.append("")
        L.append(f"**Taken on a loaded machine** (1-minute load average up to {meta['max_load']:.1f} on "
                 f"{meta['machine']['nproc']} CPUs while timing): the times are noisy and pessimistic; CPU time is "
                 "listed beside the wall time.")
    L.append("")
    L.append("Equal-error speed-up of octolux `octree` (time of the peer / time of octree to reach the target "
             "relMSE; `*` = the peer's curve extrapolated with relMSE ∝ 1/time, `≤` = bound):")
    L.append("")
    L.append("| scene | target relMSE | octree time (s) | vs Mitsuba path | vs LuxCore path | vs LuxCore PhotonGI | "
             "vs PhotonGI at its own errors (least) | vs octolux path | octree cache (MiB) | PhotonGI cache (MiB) | "
             "LuxCore/Mitsuba mean |")
    L.append("|---|---|---|---|---|---|---|---|---|---|---|")
    for name, a in ana.items():
        p = a["renderers"]
        g = lambda rd, k: p.get(rd, {}).get(k)  # noqa: E731
        lr = (a.get("luxcore_check") or {}).get("mean_ratio")
        L.append(f"| {name} | {a['target_rel_mse']:.2e} | {fmt_t(g('octolux-octree', 'time_to_target_s'))} | "
                 f"{fmt_x(g('mitsuba-path', 'octree_speedup'), g('mitsuba-path', 'how'))} | "
                 f"{fmt_x(g('luxcore-path', 'octree_speedup'), g('luxcore-path', 'how'))} | "
                 f"{fmt_x(g('luxcore-pgi', 'octree_speedup'), g('luxcore-pgi', 'how'))} | "
                 f"{fmt_x(a.get('pgi_least_speedup'))} | "
                 f"{fmt_x(g('octolux-path', 'octree_speedup'), g('octolux-path', 'how'))} | "
                 f"{mb(g('octolux-octree', 'cache_bytes_max'))} | {mb(g('luxcore-pgi', 'cache_bytes_max'))} | "
                 + ("–" if not lr else " / ".join(f"{x:.3f}" for x in lr)) + " |")
    L.append("")
    L.append("PhotonGI is biased: where it never reaches the target, the column \"at its own errors\" takes each "
             "PhotonGI run, finds the time octree needs for the same relMSE, and gives the smallest of the "
             "ratios (PhotonGI's time / octree's).")
    L.append("")
    L.append("LuxCore/Mitsuba mean = ratio of the channel means (R / G / B, without the 1-pixel border) of LuxCore "
             "PATHCPU at its highest spp and the Mitsuba reference: the check of the scene translation. Its "
             "relMSE and best integer alignment: " + "; ".join(
                 f"{n} {a['luxcore_check']['spp']} spp relMSE {a['luxcore_check']['rel_mse']:.1e}, shift "
                 f"{a['luxcore_check']['best_shift']}" for n, a in ana.items() if a.get("luxcore_check")) + ".")
    L.append("")
    L.append("Time to the target per renderer (s) and lowest relMSE reached:")
    L.append("")
    L.append("| scene | " + " | ".join(LABELS[r] for r in RENDERERS) + " |")
    L.append("|---|" + "---|" * len(RENDERERS))
    for name, a in ana.items():
        cells = []
        for rd in RENDERERS:
            v = a["renderers"].get(rd)
            if not v:
                cells.append("–")
                continue
            t = v["time_to_target_s"]
            mark = {"extrapolated": "*", "upper bound": "≤", "not reached": " (not reached)"}.get(v["how"], "")
            cells.append(f"{fmt_t(t)}{mark} (min {v['best_rel_mse']:.1e})")
        L.append(f"| {name} | " + " | ".join(cells) + " |")
    L.append("")
    L.append("<details><summary>All runs (time = the renderer's own clock incl. cache build; build = photon "
             "tracing + cache build alone; wall/CPU = the whole process; RSS = peak resident memory of the "
             "process)</summary>")
    L.append("")
    L.append("| scene | renderer | spp | photons | time (s) | build (s) | wall (s) | CPU (s) | relMSE | "
             "RMSE | mean ratio (R/G/B) | cache (MiB) | peak RSS (MiB) |")
    L.append("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in runs:
        L.append(f"| {r['scene']} | {r['renderer']} | {r['spp']} | {r['photons'] or '–'} | {r['time_s']:.3f} | "
                 f"{'–' if r.get('build_s') is None else format(r['build_s'], '.3f')} | {r['process_wall_s']:.2f} | "
                 f"{r['cpu_s']:.2f} | {r['rel_mse']:.3e} | {r['rmse']:.3e} | "
                 + "/".join(f"{x:.3f}" for x in r["mean_ratio"])
                 + f" | {mb(r.get('cache_bytes'))} | {mb(r['peak_rss_bytes'])} |")
    L.append("")
    L.append("</details>")
    L.append("")
    L.append("Versions: " + ", ".join(f"{k} {v}" for k, v in meta["versions"].items()) + ".")
    checks = [f"{r['scene']} {r['renderer']} {r['spp']} spp: best shift {r['best_shift']}"
              for r in runs if r.get("best_shift") and list(r["best_shift"]) != list(r["shift"])]
    if checks:
        L.append("")
        L.append("LuxCore runs whose best integer alignment differs from the fixed one-row shift (noisy runs "
                 "can): " + "; ".join(checks) + ".")
    return "\n".join(L) + "\n"


def plot(results: dict, outdir: Path) -> list[str]:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    files = []
    styles = {"octolux-path": ("tab:blue", "o", "--"), "octolux-octree": ("tab:blue", "s", "-"),
              "mitsuba-path": ("tab:green", "^", "--"), "luxcore-path": ("tab:red", "v", "--"),
              "luxcore-pgi": ("tab:red", "D", "-")}
    for name, a in results["analysis"].items():
        runs = [r for r in results["runs"] if r["scene"] == name]
        fig, ax = plt.subplots(figsize=(6.4, 4.6))
        for rd in RENDERERS:
            pts = curve(runs, rd)
            if not pts:
                continue
            c, m, ls = styles[rd]
            ax.plot([p[0] for p in pts], [p[1] for p in pts], color=c, marker=m, linestyle=ls, label=LABELS[rd])
        if a["target_rel_mse"]:
            ax.axhline(a["target_rel_mse"], color="gray", linewidth=0.8, linestyle=":", label="target")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("time (s): render + cache build, %d threads" % results["meta"]["threads"])
        ax.set_ylabel("relMSE vs Mitsuba 3 reference")
        ttl = f"{name}, {results['meta']['resolution'][0]}x{results['meta']['resolution'][1]}"
        if results["meta"].get("loaded"):
            ttl += " (loaded machine)"
        ax.set_title(ttl)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
        fig.tight_layout()
        f = outdir / f"{name}.png"
        fig.savefig(f, dpi=110)
        plt.close(fig)
        files.append(str(f))
    return files


def machine_info() -> dict:
    cpu = platform.processor() or "?"
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True).stdout
        m = re.search(r"Model name:\s*(.+)", out)
        if m:
            cpu = m.group(1).strip()
    except OSError:
        pass
    mem = 0.0
    try:
        for line in open("/proc/meminfo"):
            if line.startswith("MemTotal:"):
                mem = int(line.split()[1]) / 2**20
    except OSError:
        pass
    return {"cpu": cpu, "nproc": os.cpu_count(), "mem_gib": mem, "kernel": platform.release()}


def versions(runs: list[dict]) -> dict:
    v = {}
    try:
        v["octolux"] = subprocess.run([str(BIN), "--version"], capture_output=True, text=True).stdout.strip()
        v["octolux"] = v["octolux"].removeprefix("octolux").strip()
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, cwd=ROOT).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "crates"], capture_output=True, text=True, cwd=ROOT).stdout.strip()
        v["octolux"] += f" (git {head}{', crates/ modified' if dirty else ''})"
    except OSError:
        pass
    for r in runs:
        if r["renderer"] == "mitsuba-path":
            v["Mitsuba"] = f"{r['version']} ({r.get('variant')}, Dr.Jit {r.get('drjit_version')})"
        if r["renderer"].startswith("luxcore-"):
            v["LuxCore (pyluxcore)"] = r["version"]
    v["Python"] = platform.python_version()
    v["numpy"] = np.__version__
    return v


def write_docs(md: str, meta: dict) -> None:
    text = DOCS.read_text()
    begin, end = "<!-- peers-results:begin -->", "<!-- peers-results:end -->"
    if begin not in text or end not in text:
        raise SystemExit(f"{DOCS}: markers {begin} / {end} not found")
    block = f"{begin}\n\n{md}\n{end}"
    text = re.sub(re.escape(begin) + ".*?" + re.escape(end), lambda _: block, text, flags=re.S)
    DOCS.write_text(text)
    log(f"updated {DOCS.relative_to(ROOT)}")


# --------------------------------------------------------------------------------------------------


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="32x32, short ladders, 4096-spp references: a smoke test")
    ap.add_argument("--scenes", nargs="+", default=list(SCENES), choices=list(SCENES))
    ap.add_argument("--renderers", nargs="+", default=RENDERERS, choices=RENDERERS)
    ap.add_argument("--resolution", default=None, help="WxH (default 128x128, quick 32x32)")
    ap.add_argument("--ref-spp", type=int, default=None, help="reference spp (default 8192, quick 4096)")
    ap.add_argument("--ref-threads", type=int, default=0, help="threads of the reference render (0 = all)")
    ap.add_argument("--threads", type=int, default=2, help="threads of every timed render")
    ap.add_argument("--seed", type=int, default=7)
    for rd in RENDERERS:
        ap.add_argument(f"--ladder-{rd}", default=None, metavar="LIST",
                        help=f"spp list{' (spp:photons)' if rd in ('octolux-octree', 'luxcore-pgi') else ''}")
    ap.add_argument("--check-spp", type=int, default=None,
                    help="spp of the LuxCore translation check (LuxCore PATHCPU against the reference: "
                         "mean ratio, best alignment; default 1024, quick 512; 0 = none)")
    ap.add_argument("--max-run-s", type=float, default=None,
                    help="stop a renderer's ladder after a run that took longer (default 300, quick 60)")
    ap.add_argument("--target", action="append", default=[], metavar="SCENE=RELMSE",
                    help="equal-error target per scene (default: 2x the lowest relMSE octree reaches)")
    ap.add_argument("--mi-variant", default=None, help="Mitsuba variant (default: what setup.sh found)")
    ap.add_argument("--out", default=None, help="output folder (default target/peers-results/<mode>)")
    ap.add_argument("--reuse", action="store_true", help="keep runs already in OUT/results.json (resume)")
    ap.add_argument("--report-only", action="store_true", help="only redo analysis, tables, plots from results.json")
    ap.add_argument("--write-docs", action="store_true", help="write the tables into docs/guide/benchmarks.md")
    args = ap.parse_args(argv)

    mode = "quick" if args.quick else "full"
    md = MODE_DEFAULTS[mode]
    res = tuple(int(x) for x in args.resolution.lower().split("x")) if args.resolution else md["resolution"]
    ref_spp = args.ref_spp or md["ref_spp"]
    max_run_s = args.max_run_s or md["max_run_s"]
    check_spp = md["check_spp"] if args.check_spp is None else args.check_spp
    outdir = Path(args.out) if args.out else ROOT / "target" / "peers-results" / mode
    outdir.mkdir(parents=True, exist_ok=True)
    res_json = outdir / "results.json"
    targets = {k: float(v) for k, v in (t.split("=", 1) for t in args.target)}

    old = json.loads(res_json.read_text()) if (args.reuse or args.report_only) and res_json.exists() else None
    runs: list[dict] = list(old["runs"]) if old else []
    if old and not args.report_only:
        kept = [r for r in runs if tuple(r["resolution"]) == tuple(res) and r["threads"] == args.threads]
        if len(kept) != len(runs):
            log(f"--reuse: {len(runs) - len(kept)} runs at another resolution or thread count dropped")
        runs = kept
    meta = old["meta"] if old and args.report_only else None

    if not args.report_only:
        if not VPY.exists():
            raise SystemExit(f"{VPY} missing: run bench/peers/setup.sh (or bench/peers/run.sh)")
        if not BIN.exists():
            log("building octolux ...")
            subprocess.run(["cargo", "build", "--release", "-p", "octolux-cli"], cwd=ROOT, check=True)
        if args.threads != 2:
            log(f"note: {args.threads} threads per renderer (the issue asks for 2)")
        done = {(r["scene"], r["renderer"], r["spp"], r["photons"]) for r in runs}
        max_load = 0.0
        t_all = time.perf_counter()
        for name in args.scenes:
            spec = SCENES[name]
            sc = Scene(name, spec, res, spec["max_depth"])
            try:
                sc.prepare_xml()
            except FileNotFoundError as e:
                log(f"{name}: scene file missing ({e}), skipped")
                continue
            if any(r.startswith("luxcore-") for r in args.renderers):
                sc.prepare_dump()
            sc.prepare_reference(ref_spp, args.ref_threads)
            for rd in args.renderers:
                ladder = parse_ladder(getattr(args, "ladder_" + rd.replace("-", "_")) or LADDERS[mode][rd])
                for spp, photons in ladder:
                    if (name, rd, spp, photons) in done:
                        continue
                    log(f"{name}: {rd} spp {spp}" + (f" photons {photons}" if photons else "") + " ...")
                    try:
                        rec = run_one(sc, rd, spp, photons, args, outdir)
                    except RuntimeError as e:
                        log(f"FAILED: {e}")
                        break
                    max_load = max(max_load, rec["load_avg_1m_before"], rec["load_avg_1m_after"])
                    runs.append(rec)
                    log(f"   time {rec['time_s']:.3f} s" + (f" (build {rec['build_s']:.3f} s)" if rec.get("build_s") else "")
                        + f"  relMSE {rec['rel_mse']:.3e}  mean ratio {'/'.join(f'{x:.3f}' for x in rec['mean_ratio'])}"
                        f"  RSS {mb(rec['peak_rss_bytes'])} MiB  load {rec['load_avg_1m_before']:.1f}")
                    res_json.write_text(json.dumps({"meta": {"partial": True}, "runs": runs}, indent=1))
                    if rec["time_s"] > max_run_s:
                        log(f"   {rd}: run took more than {max_run_s:.0f} s, rest of its ladder skipped")
                        break
            if check_spp and "luxcore-path" in args.renderers:
                # Translation check: a well-converged LuxCore PATHCPU render (also a point of its curve).
                rec = next((r for r in runs if (r["scene"], r["renderer"], r["spp"]) == (name, "luxcore-path", check_spp)), None)
                if rec is None:
                    log(f"{name}: LuxCore translation check, PATHCPU {check_spp} spp ...")
                    try:
                        rec = run_one(sc, "luxcore-path", check_spp, None, args, outdir)
                        rec["translation_check"] = True
                        runs.append(rec)
                    except RuntimeError as e:
                        log(f"FAILED: {e}")
                if rec is not None:
                    log(f"   LuxCore/Mitsuba mean ratio {'/'.join(f'{x:.4f}' for x in rec['mean_ratio'])}, relMSE "
                        f"{rec['rel_mse']:.2e}, best shift {rec.get('best_shift')} (applied {list(LUX_SHIFT)})")
            ref_meta = dict(sc.ref_info)
            ref_meta["file"] = str(sc.ref)
            if meta is None:
                meta = {"references": {}}
            meta.setdefault("references", {})[name] = {k: ref_meta.get(k) for k in (
                "file", "what", "command", "spp", "variant", "mitsuba_version", "max_depth", "resolution", "width",
                "height", "seed", "render_s", "wall_time_s", "process_wall_s", "scene_sha256", "date")}
        mach = machine_info()
        meta.update({
            "mode": mode, "resolution": list(res), "ref_spp": ref_spp, "threads": args.threads, "seed": args.seed,
            "date": dt.datetime.now().strftime("%Y-%m-%d %H:%M"), "machine": mach,
            "max_load": max_load, "loaded": is_loaded(max_load, args.threads),
            "total_s": time.perf_counter() - t_all,
            "command": " ".join(["bench/peers/bench.py"] + (argv if argv is not None else sys.argv[1:])),
            "ladders": {rd: getattr(args, "ladder_" + rd.replace("-", "_")) or LADDERS[mode][rd] for rd in RENDERERS},
            "lux_shift": list(LUX_SHIFT), "margin": MARGIN,
        })
    if meta is None:
        raise SystemExit("nothing to report")
    scene_runs: dict[str, list[dict]] = {}
    for r in runs:
        scene_runs.setdefault(r["scene"], []).append(r)
    meta["versions"] = versions(runs)
    results = {"meta": meta, "runs": runs, "analysis": analyse(scene_runs, targets)}
    res_json.write_text(json.dumps(results, indent=1))
    md_text = markdown(results)
    (outdir / "results.md").write_text(md_text)
    plots = plot(results, outdir)
    print(md_text)
    log(f"wrote {res_json}, {outdir / 'results.md'}, " + ", ".join(Path(p).name for p in plots))
    if args.write_docs:
        write_docs(md_text, meta)
    return 0


if __name__ == "__main__":
    sys.exit(main())
