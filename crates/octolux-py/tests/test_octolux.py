"""pytest suite of the `octolux` Python module.

Run by `cargo test -p octolux-py` (tests/pytest.rs builds the module into a venv first), or by
hand: `pip install ./crates/octolux-py && pytest crates/octolux-py/tests`.
"""
import json
import os
import subprocess
import sys
import threading
import time
import _thread
from pathlib import Path

import numpy as np
import pytest

import octolux
import octolux.dask
from conftest import HOW_TO_GET_ONE, find_octolux_bin

ROOT = Path(__file__).resolve().parents[3]
REFS = ROOT / "tests" / "refs"
BIN = find_octolux_bin() or ""
needs_cli = pytest.mark.skipif(not BIN, reason=HOW_TO_GET_ONE)


def _exe(path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("#!/bin/sh\n")
    path.chmod(0o755)
    return path


def test_the_binary_is_found_by_the_variable_then_the_checkout_then_the_path(tmp_path):
    checkout, on_path = tmp_path / "repo", tmp_path / "bin"
    installed = _exe(on_path / "octolux")
    named = _exe(tmp_path / "elsewhere" / "my-octolux")
    env = {"PATH": str(on_path)}
    assert find_octolux_bin(env, checkout) == str(installed)
    built = _exe(checkout / "target" / "release" / "octolux")
    assert find_octolux_bin(env, checkout) == str(built)
    assert find_octolux_bin({**env, "OCTOLUX_BIN": str(named)}, checkout) == str(named)
    with pytest.raises(FileNotFoundError, match="OCTOLUX_BIN=.*nothing-here is not a file"):
        find_octolux_bin({**env, "OCTOLUX_BIN": str(tmp_path / "nothing-here")}, checkout)
    assert find_octolux_bin({"PATH": str(tmp_path / "empty")}, tmp_path / "no-checkout") is None
    assert "cargo install --path crates/octolux-cli" in HOW_TO_GET_ONE and "OCTOLUX_BIN" in HOW_TO_GET_ONE


def test_dir_shows_the_public_names_only():
    names = set(dir(octolux))
    assert names == set(octolux.__all__), names ^ set(octolux.__all__)
    assert not {"Any", "np", "os", "json", "warnings", "PathLike"} & names
    for n in names:
        assert getattr(octolux, n) is not None


def test_the_dask_runner_without_distributed_says_which_extra_to_install(tmp_path):
    # `distributed` made unimportable (None in sys.modules) in a fresh interpreter
    code = "import sys; sys.modules['distributed'] = None; from octolux.dask import main; sys.exit(main(sys.argv[1:]))"
    p = subprocess.run([sys.executable, "-c", code, "cornell-box", "-o", str(tmp_path / "f.exr"), "--sensors"],
                       capture_output=True, text=True)
    assert p.returncode == 2, p
    assert "Traceback" not in p.stderr, p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and "[dask]" in lines[0] and "distributed" in lines[0], p.stderr


def test_the_dask_help_describes_every_flag():
    ap = octolux.dask._parser()
    text = ap.format_help()
    assert "issue" not in text.lower(), text
    for action in ap._actions:
        assert action.help, f"{action.option_strings or action.dest} has no description"


def test_readme_one_liner_renders_the_default_scene():
    img = octolux.render("cornell-box", spp=4)
    assert img.dtype == np.float32 and img.ndim == 3 and img.shape[2] == 3
    assert np.isfinite(img).all() and (img >= 0).all()
    assert img.mean() > 0.01, "the lit box renders black"


def test_path_tracer_agrees_with_the_mitsuba_reference():
    """The built-in box at 128x128 against the committed Mitsuba 3 reference (8192 spp): the
    error is the render's own noise (two seeds) plus the reference's, with no bias on top."""
    manifest = json.loads((REFS / "manifest.json").read_text())["references"]["cornell-box"]
    ref = octolux.read_exr(REFS / manifest["file"])
    scene = octolux.load_scene("cornell-box", resolution=(128, 128))
    a = octolux.render(scene, "path", spp=64, seed=1, max_depth=-1)
    b = octolux.render(scene, "path", spp=64, seed=2, max_depth=-1)
    err = octolux.compare(a, ref)
    noise = octolux.compare(a, b)["rel_mse"] / 2
    ref_noise = manifest["self_noise"]["rel_mse"] / 2
    assert err["rel_mse"] <= 1.5 * (noise + ref_noise), (err, noise, ref_noise)
    for c in range(3):
        assert abs(a[..., c].mean() / ref[..., c].mean() - 1) < 0.02


def test_deterministic_for_any_thread_count():
    scene = octolux.load_scene("cornell-box", resolution=(48, 32))
    one = octolux.render(scene, "path", spp=4, seed=5, threads=1)
    two = octolux.render(scene, "path", spp=4, seed=5, threads=2)
    assert np.array_equal(one, two)
    other = octolux.render(scene, "path", spp=4, seed=6, threads=2)
    assert not np.array_equal(one, other), "the seed changes nothing"


def test_stats_and_settings_dict():
    img, stats = octolux.render(
        "cornell-box", "octree", spp=2, resolution=(32, 32), settings={"photons": {"photons": 20000}, "mode": "paper"}, stats=True
    )
    assert img.shape == (32, 32, 3)
    assert stats["integrator"] == "octree"
    settings = stats["integrator_settings"]
    assert settings["type"] == "octree" and settings["photons"]["photons"] == 20000 and settings["mode"] == "paper"
    assert stats["build"]["photons_emitted"] == 20000 and stats["timings"]["build_s"] > 0
    assert stats["render"]["spp"] == 2 and stats["render"]["samples"] == 32 * 32 * 2


def test_bad_settings_raise_the_cli_messages_in_python_words():
    # the dict key is named as the dict spells it, not as `--set photons.bogus=1`
    with pytest.raises(octolux.OctoluxError) as e:
        octolux.render("cornell-box", "octree", spp=1, resolution=(8, 8), settings={"photons": {"bogus": 1}})
    msg = str(e.value)
    assert msg.startswith('settings={"photons": {"bogus": 1}}: no integrator has the setting `photons.bogus`'), msg
    assert "--set" not in msg and "--integrator" not in msg and "integrator='octree'" in msg, msg
    with pytest.raises(octolux.OctoluxError, match=r'^settings=\{"photons": \{"photons": -3\}\}: '):
        octolux.render("cornell-box", "octree", spp=1, resolution=(8, 8), settings={"photons": {"photons": -3}})
    with pytest.raises(octolux.OctoluxError, match=r"^settings=\{\"type\": \"path\"\}: the integrator is chosen with integrator="):
        octolux.render("cornell-box", spp=1, resolution=(8, 8), settings={"type": "path"})
    with pytest.warns(octolux.OctoluxWarning, match=r"^photons= applies to integrator 'octree', .*; ignored by integrator='path'$"):
        octolux.render("cornell-box", "path", spp=1, resolution=(8, 8), photons=1000)
    with pytest.raises(octolux.OctoluxError, match="unknown integrator 'bdpt'"):
        octolux.render("cornell-box", "bdpt", spp=1, resolution=(8, 8))
    with pytest.raises(octolux.OctoluxError, match="spp must be at least 1"):
        octolux.render("cornell-box", spp=0, resolution=(8, 8))
    with pytest.raises(octolux.OctoluxError, match="cornell-box"):  # the error lists the known scenes
        octolux.load_scene("no-such-scene")
    with pytest.raises(octolux.OctoluxError, match="no such file"):
        octolux.load_scene("missing.xml")


def test_scene_warnings_become_python_warnings():
    with pytest.warns(octolux.OctoluxWarning, match="-D is ignored"):
        octolux.load_scene("cornell-box", defines={"spp": 4})


def test_bake_then_render_from_the_cache_equals_the_uncached_render(tmp_path):
    scene = octolux.load_scene("cornell-box", resolution=(40, 30))
    settings = {"photons": {"photons": 30000}}
    info = octolux.bake(scene, tmp_path / "light.oxc", seed=3, settings=settings)
    assert info["file_bytes"] == (tmp_path / "light.oxc").stat().st_size > 0
    direct = octolux.render(scene, "octree", spp=2, seed=3, settings=settings)
    cached = octolux.render(scene, spp=2, seed=3, cache=tmp_path / "light.oxc")
    assert np.array_equal(direct, cached)
    # the cache is refused for another scene, with the CLI's message
    with pytest.raises(octolux.OctoluxError, match="does not match scene 'cornell-spheres'"):
        octolux.render("cornell-spheres", spp=1, resolution=(8, 8), cache=tmp_path / "light.oxc")
    with pytest.warns(octolux.OctoluxWarning, match="rendering anyway"):
        octolux.render("cornell-spheres", spp=1, resolution=(8, 8), cache=tmp_path / "light.oxc", allow_stale_cache=True)
    # a missing output folder is created, as `octolux bake` creates it ...
    deep = tmp_path / "new" / "deeper" / "light.oxc"
    octolux.bake(scene, deep, seed=3, settings=settings)
    assert deep.read_bytes() == (tmp_path / "light.oxc").read_bytes() and deep.with_suffix(".json").is_file()
    deep.unlink()
    deep.with_suffix(".json").unlink()
    # ... and removed again when the bake fails; the folders of the bake that succeeded stay,
    # though they are empty now
    with pytest.raises(octolux.OctoluxError, match="bogus"):
        octolux.bake(scene, tmp_path / "failed" / "light.oxc", settings={"bogus": 1})
    assert not (tmp_path / "failed").exists()
    assert deep.parent.is_dir()
    # a truncated file is refused, naming it
    data = (tmp_path / "light.oxc").read_bytes()
    (tmp_path / "cut.oxc").write_bytes(data[: len(data) // 2])
    with pytest.raises(octolux.OctoluxError, match="cut.oxc"):
        octolux.render(scene, spp=1, cache=tmp_path / "cut.oxc")


@needs_cli
def test_the_cli_and_python_give_the_same_cache_and_the_same_images(tmp_path):
    """One layer (octolux_io::job) under both: a bake through the CLI and one through Python
    give identical bytes, volumetric values included, and so do their renders."""
    cli = lambda *a: subprocess.run([BIN, *a, "-q"], check=True, capture_output=True)  # noqa: E731
    cli("bake", "cornell-spheres", "-o", str(tmp_path / "cli.oxc"), "--photons", "20000", "--seed", "3", "--volume")
    report = octolux.bake(octolux.load_scene("cornell-spheres"), tmp_path / "py.oxc", seed=3, photons=20000, volume=True)
    a, b = (tmp_path / "cli.oxc").read_bytes(), (tmp_path / "py.oxc").read_bytes()
    assert a == b, "the CLI's bake and Python's differ"
    # the times are in the reports beside the caches, not in the files
    cli_report = json.loads((tmp_path / "cli.json").read_text())
    assert report["file_bytes"] == cli_report["file_bytes"] == len(a)
    assert report["atmosphere"]["filled_leaves"] == cli_report["atmosphere"]["filled_leaves"] > 0
    assert cli_report["timings"]["build_s"] > 0 and cli_report["build"]["t_c_s"] > 0
    # renders from the caches: the CLI's EXR, Python's array and Python's files
    common = ["--resolution", "40x30", "--spp", "2", "--seed", "3"]
    cli("render", "cornell-spheres", "--cache", str(tmp_path / "cli.oxc"), "-o", str(tmp_path / "cli.exr"), *common)
    img = octolux.render(octolux.load_scene("cornell-spheres", resolution=(40, 30)), spp=2, seed=3, cache=tmp_path / "py.oxc")
    assert np.array_equal(octolux.read_exr(tmp_path / "cli.exr"), img)
    octolux.render_to_files("cornell-spheres", tmp_path / "py.exr", spp=2, seed=3, resolution=(40, 30), cache=tmp_path / "py.oxc")
    for ext in ("exr", "png"):
        assert (tmp_path / f"cli.{ext}").read_bytes() == (tmp_path / f"py.{ext}").read_bytes(), ext
    # and the uncached octree render, whose photons are traced in the call
    cli("render", "cornell-spheres", "--integrator", "octree", "--photons", "20000", "-o", str(tmp_path / "cli-built.exr"), *common)
    built = octolux.render("cornell-spheres", "octree", spp=2, seed=3, photons=20000, resolution=(40, 30))
    assert np.array_equal(octolux.read_exr(tmp_path / "cli-built.exr"), built)
    assert np.array_equal(built, img), "the cached render differs from the uncached one"


def test_compare_and_exr_round_trip(tmp_path):
    img = octolux.render("cornell-box", spp=2, resolution=(16, 12))
    octolux.write_exr(tmp_path / "a.exr", img)
    back = octolux.read_exr(tmp_path / "a.exr")
    assert back.shape == (12, 16, 3)
    assert octolux.compare(back, img)["rel_mse"] < 1e-6  # EXR half/float storage
    noisy = img * 1.1
    assert octolux.compare(noisy, img)["rel_mse"] > 1e-4
    with pytest.raises(octolux.OctoluxError, match="is 16x12 but the reference is 8x8"):
        octolux.compare(img, np.zeros((8, 8, 3), np.float32))
    bad = img.copy()
    bad[0, 0, 0] = np.nan
    with pytest.raises(octolux.OctoluxError, match="non-finite"):
        octolux.compare(bad, img)


def test_render_releases_the_gil():
    scene = octolux.load_scene("cornell-box", resolution=(96, 96))
    ticks = 0
    done = threading.Event()

    def work():
        octolux.render(scene, "path", spp=32)
        done.set()

    t = threading.Thread(target=work)
    t.start()
    while not done.is_set():
        ticks += 1
        time.sleep(0.001)
    t.join()
    assert ticks > 20, f"the main thread ran {ticks} times while the render held the GIL"


def test_ctrl_c_stops_a_render():
    """A render of ~130M samples (minutes) stops at the next tile (16x16 px x 2000 spp, about
    a second) once Ctrl-C arrives."""
    scene = octolux.load_scene("cornell-box", resolution=(256, 256))
    timer = threading.Timer(0.5, _thread.interrupt_main)
    start = time.monotonic()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        octolux.render(scene, "path", spp=2000)
    assert time.monotonic() - start < 30
