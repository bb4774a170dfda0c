#!/usr/bin/env python3
"""Fetch the public research scenes that octolux's tests and examples use (`../shared/scenes`)
from where they are published, and check them against the SHA-256 checksums of
`tools/scenes.json`.

    python3 tools/fetch_scenes.py --list                 # the scenes, their sources and licences
    python3 tools/fetch_scenes.py                        # fetch every fetchable scene into ../shared/scenes
    python3 tools/fetch_scenes.py --dest DIR stanford-bunny mitsuba-tutorials-cbox
    python3 tools/fetch_scenes.py --verify ../shared/scenes    # ok / missing / differs, per scene

The manifest holds, per scene, its files' SHA-256 as the copies this project was measured on
have them, where the scene comes from and how to fetch it (single files, or an archive and which
of its members go where). Not every scene can be fetched: where the exact source is unknown the
manifest says so, and where a publisher has changed a file since, or the project's copy was
edited after download, the fetched file is reported as `differs` (docs/guide/scene-sources.md).

Standard library only, Python 3.8 or newer. A scene already complete and matching is not
fetched again.
"""
import argparse
import hashlib
import json
import os
import shutil
import sys
import tarfile
import tempfile
import urllib.request
import zipfile
from pathlib import Path, PurePosixPath
from typing import Dict, List, Optional

HERE = Path(__file__).resolve().parent
MANIFEST = HERE / "scenes.json"
DEFAULT_DEST = HERE.parent.parent / "shared" / "scenes"
CHUNK = 1 << 20


def sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(CHUNK), b""):
            h.update(block)
    return h.hexdigest()


def load_manifest(path: Path) -> List[dict]:
    data = json.loads(path.read_text(encoding="utf-8"))
    scenes = data["scenes"]
    for s in scenes:
        for key in ("name", "files"):
            if key not in s:
                raise SystemExit(f"{path}: a scene lacks `{key}`")
    return scenes


def verify_scene(scene: dict, root: Path) -> Dict[str, List[str]]:
    """Each file of the scene in `root`, sorted by state: ok, missing, differs."""
    out: Dict[str, List[str]] = {"ok": [], "missing": [], "differs": []}
    base = root / scene["name"]
    for rel, digest in sorted(scene["files"].items()):
        p = base / rel
        if not p.is_file():
            out["missing"].append(rel)
        elif sha256(p) != digest:
            out["differs"].append(rel)
        else:
            out["ok"].append(rel)
    return out


def scene_state(result: Dict[str, List[str]]) -> str:
    if not result["ok"] and not result["differs"]:
        return "missing"
    if result["differs"]:
        return "differs"
    if result["missing"]:
        return "missing"
    return "ok"


def report(scene: dict, result: Dict[str, List[str]]) -> str:
    state = scene_state(result)
    n = len(scene["files"])
    line = f"{state:8} {scene['name']} ({len(result['ok'])}/{n} files ok)"
    details = [f"    differs: {r}" for r in result["differs"]]
    if state != "missing" or result["ok"]:
        details += [f"    missing: {r}" for r in result["missing"]]
    return "\n".join([line] + details[:20] + ([f"    ... {len(details) - 20} more"] if len(details) > 20 else []))


def verify(scenes: List[dict], root: Path) -> int:
    bad = 0
    for s in scenes:
        r = verify_scene(s, root)
        print(report(s, r))
        bad += scene_state(r) != "ok"
    print(f"{len(scenes) - bad} of {len(scenes)} scenes ok in {root}")
    return 0 if bad == 0 else 1


def download(url: str, to: Path) -> None:
    print(f"  downloading {url}", flush=True)
    req = urllib.request.Request(url, headers={"User-Agent": "octolux-fetch-scenes"})
    with urllib.request.urlopen(req, timeout=60) as r, open(to, "wb") as f:
        shutil.copyfileobj(r, f, CHUNK)


def safe_member(name: str) -> Optional[PurePosixPath]:
    """An archive member's path, or None where it would land outside the scene's folder."""
    p = PurePosixPath(name)
    if p.is_absolute() or ".." in p.parts or not p.parts:
        return None
    return p


def archive_members(archive: Path) -> Dict[str, bytes]:
    """Regular files of a .zip or .tar(.gz) archive: member path -> bytes."""
    out: Dict[str, bytes] = {}
    if zipfile.is_zipfile(archive):
        with zipfile.ZipFile(archive) as z:
            for info in z.infolist():
                if not info.is_dir():
                    out[info.filename] = z.read(info)
    else:
        with tarfile.open(archive) as t:
            for m in t.getmembers():
                if m.isfile():
                    f = t.extractfile(m)
                    if f is not None:
                        out[m.name] = f.read()
    return out


def place(files: Dict[str, bytes], rules: dict) -> Dict[str, bytes]:
    """The scene's files from the archive's members by the manifest's rules: `members` maps a
    file of the scene to its member path; without it, every member is taken with the first
    `strip` path components removed (`rename` then renames some)."""
    if "members" in rules:
        missing = [m for m in rules["members"].values() if m not in files]
        if missing:
            raise RuntimeError(f"the archive lacks {', '.join(missing)}")
        return {rel: files[m] for rel, m in rules["members"].items()}
    strip = int(rules.get("strip", 0))
    rename = rules.get("rename", {})
    out = {}
    for name, data in files.items():
        p = safe_member(name)
        if p is None or len(p.parts) <= strip:
            continue
        rel = str(PurePosixPath(*p.parts[strip:]))
        out[rename.get(rel, rel)] = data
    return out


def write_scene(root: Path, scene: dict, files: Dict[str, bytes]) -> None:
    base = root / scene["name"]
    for rel, data in files.items():
        p = safe_member(rel)
        if p is None:
            continue
        target = base / Path(*p.parts)
        target.parent.mkdir(parents=True, exist_ok=True)
        staged = target.with_name(f".{target.name}.partial")
        staged.write_bytes(data)
        os.replace(staged, target)


def fetch_scene(scene: dict, root: Path, force: bool) -> str:
    how = scene.get("fetch")
    if not force and scene_state(verify_scene(scene, root)) == "ok":
        return "ok (already here)"
    if not how:
        return f"not fetched: {scene.get('why_not_fetched', 'no published source is known')}"
    with tempfile.TemporaryDirectory(prefix="octolux-scenes-") as tmp:
        if "files" in how:
            files = {}
            for rel in scene["files"]:
                url = how["files"].replace("{path}", rel)
                d = Path(tmp) / "file"
                download(url, d)
                files[rel] = d.read_bytes()
        else:
            archive = Path(tmp) / "archive"
            download(how["archive"], archive)
            files = place(archive_members(archive), how)
    write_scene(root, scene, files)
    return scene_state(verify_scene(scene, root))


def main(argv: Optional[List[str]] = None) -> int:
    ap = argparse.ArgumentParser(
        description="Fetch the research scenes from their published sources and check their SHA-256 checksums.",
        epilog="Sources, licences and what cannot be fetched: docs/guide/scene-sources.md.",
    )
    ap.add_argument("scenes", nargs="*", help="scene names (default: all); see --list")
    ap.add_argument("--dest", type=Path, default=DEFAULT_DEST, help="folder to fetch into (default: ../shared/scenes beside the repository)")
    ap.add_argument("--verify", type=Path, metavar="DIR", help="check the scenes in DIR against the manifest (ok / missing / differs); fetch nothing")
    ap.add_argument("--list", action="store_true", help="list the scenes with their sources and licences; fetch nothing")
    ap.add_argument("--force", action="store_true", help="fetch a scene again even when its files are all present and ok")
    ap.add_argument("--manifest", type=Path, default=MANIFEST, help="the checksum manifest (default: tools/scenes.json)")
    a = ap.parse_args(argv)

    scenes = load_manifest(a.manifest)
    if a.scenes:
        known = {s["name"] for s in scenes}
        unknown = [n for n in a.scenes if n not in known]
        if unknown:
            print(f"error: unknown scene {', '.join(unknown)}; known: {', '.join(sorted(known))}", file=sys.stderr)
            return 2
        scenes = [s for s in scenes if s["name"] in a.scenes]

    if a.list:
        for s in scenes:
            how = s.get("fetch")
            where = (how.get("archive") or how.get("files")) if how else "cannot be fetched: " + s.get("why_not_fetched", "source unknown")
            print(f"{s['name']}: {len(s['files'])} files\n    source:  {s.get('source', 'unknown')}\n    licence: {s.get('licence', 'unknown')}\n    fetch:   {where}")
        return 0
    if a.verify is not None:
        if not a.verify.is_dir():
            print(f"error: {a.verify} is not a folder", file=sys.stderr)
            return 2
        return verify(scenes, a.verify)

    bad = 0
    for s in scenes:
        print(f"{s['name']}:", flush=True)
        try:
            state = fetch_scene(s, a.dest, a.force)
        except (OSError, RuntimeError, tarfile.TarError, zipfile.BadZipFile) as e:
            state = f"failed: {e}"
        print(f"  {state}")
        bad += not state.startswith("ok")
    print(f"{len(scenes) - bad} of {len(scenes)} scenes ok in {a.dest}")
    return 0 if bad == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
