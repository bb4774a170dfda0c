#!/usr/bin/env bash
# Install the peer renderers for the side-by-side benchmark into <repo>/.venv-peers (git-ignored).
#
#   bench/peers/setup.sh        # idempotent
#
# - Mitsuba 3 (+ numpy, libLLVM 19 detection, variant smoke test): delegated to tools/mitsuba/setup.sh
#   with MITSUBA_VENV=<repo>/.venv-peers, which also writes .venv-peers/mitsuba-env.sh
#   (DRJIT_LIBLLVM_PATH, OCTOLUX_MI_VARIANT) that tools/mitsuba/render.py picks up from sys.prefix.
# - LuxCore (pip package pyluxcore), numpy and matplotlib at the versions pinned in requirements.txt.
# - builds target/release/octolux when missing.
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
REPO="$(cd "$HERE/../.." && pwd)"
VENV="${PEERS_VENV:-$REPO/.venv-peers}"
say() { echo "[peers-setup] $*"; }

# Pins: read from requirements.txt (single source of truth).
pin() { sed -n "s/^$1==\([^ #]*\).*/\1/p" "$HERE/requirements.txt"; }
MITSUBA_VERSION="$(pin mitsuba)" NUMPY_SPEC="numpy==$(pin numpy)" MITSUBA_VENV="$VENV" \
    "$REPO/tools/mitsuba/setup.sh"

VPY="$VENV/bin/python"
if "$VPY" - "$HERE/requirements.txt" <<'PY' 2>/dev/null
import sys, re
from importlib.metadata import version
for line in open(sys.argv[1]):
    m = re.match(r"^([A-Za-z0-9_.-]+)==([^\s#]+)", line)
    if m and version(m.group(1)) != m.group(2):
        sys.exit(1)
PY
then
    say "pinned packages already installed"
else
    say "pip install -r bench/peers/requirements.txt"
    "$VPY" -m pip install --disable-pip-version-check -q -r "$HERE/requirements.txt"
fi
# pyluxcore in its own process (importing mitsuba after pyluxcore in one process aborts).
# (pyluxcore prints a library check on import and can abort at interpreter exit: print last, _exit.)
say "installed: $("$VPY" -c 'import os, sys, pyluxcore; pyluxcore.Init(lambda s: None); print("pyluxcore", pyluxcore.Version()); sys.stdout.flush(); os._exit(0)' | tail -n 1)"
say "installed: $("$VPY" -c 'import matplotlib, numpy; print("matplotlib", matplotlib.__version__, "numpy", numpy.__version__)')"

if [[ ! -x "$REPO/target/release/octolux" ]]; then
    say "building octolux (cargo build --release -p octolux-cli)"
    (cd "$REPO" && cargo build --release -p octolux-cli)
fi
say "ready: $VPY bench/peers/bench.py --help"
