"""Where things are, for every Python script of the repository (tools/, bench/).

No path of one machine: everything is found relative to the repository root.

* the shared folder (the one that holds `scenes/`): `$OCTOLUX_SHARED`, else `<repo>/../shared`;
* the Mitsuba 3 virtual environment: `$MITSUBA_VENV`, else `<repo>/.venv-mitsuba`
  (made by tools/mitsuba/setup.sh).
"""
from __future__ import annotations

import os

REPO = os.path.abspath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))


def shared_dir() -> str:
    """The shared folder: `$OCTOLUX_SHARED` or `<repo>/../shared` (it holds `scenes/`)."""
    env = os.environ.get("OCTOLUX_SHARED")
    return os.path.abspath(env) if env else os.path.normpath(os.path.join(REPO, "..", "shared"))


def scenes_dir() -> str:
    """`<shared>/scenes`: the read-only scene files."""
    return os.path.join(shared_dir(), "scenes")


def shown(path: str) -> str:
    """`path` as written in manifests and docs: relative to the repository root when it lies under
    the shared folder (`../shared/scenes/...`) or the repository, so no machine path is recorded."""
    p = os.path.abspath(path)
    for base, label in ((shared_dir(), "../shared"), (REPO, ".")):
        if p == base or p.startswith(base + os.sep):
            rel = os.path.relpath(p, base)
            return rel if label == "." else f"{label}/{rel}"
    return os.path.basename(p)


def mitsuba_venv() -> str:
    """The Mitsuba 3 virtual environment: `$MITSUBA_VENV` or `<repo>/.venv-mitsuba`."""
    return os.path.abspath(os.environ.get("MITSUBA_VENV", os.path.join(REPO, ".venv-mitsuba")))


def mitsuba_python() -> str:
    return os.path.join(mitsuba_venv(), "bin", "python")
