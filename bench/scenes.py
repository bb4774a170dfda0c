"""The one table of scene aliases (bench/scenes.json), for every bench; the Rust examples read the
same file through `octolux_io::shared::scene_alias`.

    import scenes                       # with bench/ on sys.path
    s = scenes.get("cbox")              # {"scene": ".../cbox.xml", "max_depth": 6, "resolution": [128, 128],
                                        #  "reference": ".../tests/refs/cbox.exr", "builtin": False}
"""
from __future__ import annotations

import json
import os
import sys

REPO = os.path.abspath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
TABLE = os.path.join(REPO, "bench", "scenes.json")
sys.path.insert(0, os.path.join(REPO, "tools", "mitsuba"))
import locations  # noqa: E402  (tools/mitsuba/locations.py: $OCTOLUX_SHARED or <repo>/../shared)


def names() -> list[str]:
    """Every alias, in the table's order."""
    with open(TABLE) as f:
        return list(json.load(f)["scenes"])


def get(name: str) -> dict:
    """The alias `name` resolved: `scene` is a built-in name or an absolute path (`builtin` says
    which), `reference` an absolute path. A KeyError names the known aliases."""
    with open(TABLE) as f:
        table = json.load(f)["scenes"]
    if name not in table:
        raise KeyError(f"{name!r} is not a scene alias of {TABLE} (known: {', '.join(table)})")
    e = dict(table[name])
    scene = e["scene"]
    if scene.startswith("shared:"):
        e["scene"], e["builtin"] = os.path.join(locations.scenes_dir(), scene.removeprefix("shared:")), False
    elif "/" in scene:
        e["scene"], e["builtin"] = os.path.join(REPO, scene), False
    else:
        e["builtin"] = True
    e["reference"] = os.path.join(REPO, e["reference"])
    return e
