"""tools/fetch_scenes.py (standard library only) against a local HTTP server and a made-up
manifest: single files, a .tar.gz with a member map and a .zip with a stripped, renamed top
folder are fetched and verified; `--verify` says ok, differs and missing; an archive member
that would land outside the scene's folder is not written."""
import functools
import hashlib
import http.server
import io
import json
import subprocess
import sys
import tarfile
import threading
import zipfile
from pathlib import Path

import pytest

TOOL = Path(__file__).resolve().parents[3] / "tools" / "fetch_scenes.py"


def sha(b: bytes) -> str:
    return hashlib.sha256(b).hexdigest()


@pytest.fixture
def served(tmp_path):
    site = tmp_path / "site"
    (site / "raw").mkdir(parents=True)
    (site / "raw" / "a.xml").write_bytes(b"<scene/>\n")
    (site / "raw" / "m").mkdir()
    (site / "raw" / "m" / "b.obj").write_bytes(b"v 0 0 0\n")
    buf = io.BytesIO()
    with tarfile.open(fileobj=buf, mode="w:gz") as t:
        for name, data in [("pack/deep/mesh.ply", b"ply\n"), ("pack/readme", b"not wanted\n")]:
            info = tarfile.TarInfo(name)
            info.size = len(data)
            t.addfile(info, io.BytesIO(data))
    (site / "pack.tar.gz").write_bytes(buf.getvalue())
    with zipfile.ZipFile(site / "scene.zip", "w") as z:
        z.writestr("top/scene_v0.6.xml", b"<scene version='0.6.0'/>\n")
        z.writestr("top/tex/t.png", b"png")
        z.writestr("top/../../evil.txt", b"outside")
    handler = functools.partial(http.server.SimpleHTTPRequestHandler, directory=str(site))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    url = f"http://127.0.0.1:{server.server_address[1]}"
    manifest = {"scenes": [
        {"name": "files", "fetch": {"files": url + "/raw/{path}"},
         "files": {"a.xml": sha(b"<scene/>\n"), "m/b.obj": sha(b"v 0 0 0\n")}},
        {"name": "group/tar", "fetch": {"archive": url + "/pack.tar.gz", "members": {"mesh.ply": "pack/deep/mesh.ply"}},
         "files": {"mesh.ply": sha(b"ply\n")}},
        {"name": "zip", "fetch": {"archive": url + "/scene.zip", "strip": 1, "rename": {"scene_v0.6.xml": "scene.xml"}},
         "files": {"scene.xml": sha(b"<scene version='0.6.0'/>\n"), "tex/t.png": sha(b"png")}},
        {"name": "lost", "why_not_fetched": "made up", "files": {"x": sha(b"x")}},
    ]}
    (tmp_path / "manifest.json").write_text(json.dumps(manifest))
    yield tmp_path / "manifest.json"
    server.shutdown()


def run(*args):
    return subprocess.run([sys.executable, str(TOOL), *map(str, args)], capture_output=True, text=True)


def test_fetch_then_verify(served, tmp_path):
    dest = tmp_path / "scenes"
    p = run("--manifest", served, "--dest", dest, "files", "group/tar", "zip")
    assert p.returncode == 0, p.stdout + p.stderr
    assert "3 of 3 scenes ok" in p.stdout
    assert (dest / "zip" / "scene.xml").is_file() and not (dest / "zip" / "scene_v0.6.xml").exists()
    assert not (tmp_path / "evil.txt").exists() and not list(tmp_path.rglob("evil.txt"))
    assert not (dest / "group" / "tar" / "readme").exists()

    (dest / "files" / "m" / "b.obj").write_bytes(b"v 1 0 0\n")
    (dest / "zip" / "tex" / "t.png").unlink()
    p = run("--manifest", served, "--verify", dest)
    assert p.returncode == 1
    lines = p.stdout.splitlines()
    assert "differs  files (1/2 files ok)" in lines and "    differs: m/b.obj" in lines, p.stdout
    assert "ok       group/tar (1/1 files ok)" in lines, p.stdout
    assert "missing  zip (1/2 files ok)" in lines and "    missing: tex/t.png" in lines, p.stdout
    assert "missing  lost (0/1 files ok)" in lines, p.stdout
    assert "1 of 4 scenes ok" in p.stdout

    # a scene that cannot be fetched says why, and the run fails
    p = run("--manifest", served, "--dest", dest, "lost")
    assert p.returncode == 1 and "not fetched: made up" in p.stdout, p.stdout


def test_the_committed_manifest_lists_every_scene_with_a_source():
    p = run("--list")
    assert p.returncode == 0, p.stderr
    manifest = json.loads((TOOL.parent / "scenes.json").read_text())
    for s in manifest["scenes"]:
        assert f"{s['name']}: {len(s['files'])} files" in p.stdout
        assert s["source"] and s["licence"] and (s.get("fetch") or s.get("why_not_fetched")), s["name"]
        assert all(len(h) == 64 for h in s["files"].values())
