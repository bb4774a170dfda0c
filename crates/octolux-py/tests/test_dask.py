"""octolux.dask on a LocalCluster of 2 worker processes: the frames, rendered in the workers'
processes by the Python module, equal a single-machine `octolux render` bit for bit, with a
worker killed in the middle of the job; a missing output folder is created, as the CLI creates it.

Needs the `octolux` binary for the single-machine side (conftest.py finds it: `$OCTOLUX_BIN`,
which tests/pytest.rs sets to the one cargo built, else the checkout's build, else the PATH).
"""
import json
import os
import signal
import subprocess
from pathlib import Path

import pytest
from distributed import Client, LocalCluster

from octolux.dask import render_frames

from conftest import HOW_TO_GET_ONE, find_octolux_bin

BIN = find_octolux_bin() or ""
pytestmark = pytest.mark.skipif(not BIN, reason=HOW_TO_GET_ONE)

RENDER = ["--resolution", "64x48", "--spp", "32"]


def camera_path(tmp: Path) -> Path:
    keys = [
        {"time": 0.0, "position": [0.0, 1.0, 3.4], "target": [0.0, 1.0, 0.0], "fov": 40.0},
        {"time": 1.0, "position": [0.6, 1.2, 3.0], "target": [0.0, 0.9, 0.0], "fov": 45.0},
    ]
    p = tmp / "path.json"
    p.write_text(json.dumps({"fps": 7, "keyframes": keys}))
    return p


def test_farm_equals_one_machine_with_a_worker_killed(tmp_path):
    path = camera_path(tmp_path)
    # one machine: bake, then every frame from the cache
    subprocess.run([BIN, "bake", "cornell-box", "-o", str(tmp_path / "c.oxc"), "--photons", "20000", "--seed", "1", "-q"], check=True)
    # the CLI creates the missing folder `one` ...
    subprocess.run(
        [BIN, "render", "cornell-box", "--cache", str(tmp_path / "c.oxc"), "--camera-path", str(path), "--seed", "1", "-q",
         "-o", str(tmp_path / "one" / "f.exr"), *RENDER],
        check=True,
    )
    one = sorted((tmp_path / "one").glob("f_*.exr"))
    assert len(one) == 8

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, Client(cluster) as client:
        pids = client.run(os.getpid)
        killed = []

        def kill_one(_frame):
            if not killed:  # after the first frame: the others are queued or running
                victim = sorted(pids.values())[0]
                os.kill(victim, signal.SIGKILL)
                killed.append(victim)

        # ... and so does the farm (`farm/sub`, two levels), removing it again when the job
        # fails before any frame is written (here: frames out of range)
        with pytest.raises(ValueError, match="the animation has frames 1..8"):
            render_frames(client, "cornell-box", str(tmp_path / "farm" / "sub" / "f.exr"), camera_path=str(path), frames=(1, 99))
        assert not (tmp_path / "farm").exists()
        written = render_frames(
            client, "cornell-box", str(tmp_path / "farm" / "sub" / "f.exr"), camera_path=str(path), bake={"photons": 20000},
            seed=1, resolution=(64, 48), spp=32, on_frame=kill_one,
        )
    assert killed, "no worker was killed"
    assert [p.name for p in written] == [p.name for p in one]
    for a in one:
        b = tmp_path / "farm" / "sub" / a.name
        assert a.read_bytes() == b.read_bytes(), f"{a.name} differs from the single-machine frame"
        assert a.with_suffix(".png").read_bytes() == b.with_suffix(".png").read_bytes()
