#!/usr/bin/env bash
# Set up the Mitsuba 3 reference toolchain in <repo>/.venv-mitsuba.
#
#   tools/mitsuba/setup.sh            # idempotent: skips whatever is already in place
#
# - creates the virtual environment <repo>/.venv-mitsuba (git-ignored via /.venv*/)
# - pip installs mitsuba==$MITSUBA_VERSION (pinned) and numpy
# - makes sure libLLVM 19 is present for the `llvm_ad_rgb` variant (apt-get install libllvm19 when
#   missing and apt is usable); otherwise the tools fall back to `scalar_rgb`
# - writes .venv-mitsuba/mitsuba-env.sh, which the other scripts source: it exports
#   DRJIT_LIBLLVM_PATH (when libLLVM 19 was found) and OCTOLUX_MI_VARIANT (the best working variant)
#
# Environment knobs: PYTHON (interpreter used to create the venv, default python3),
# MITSUBA_VERSION (default below), MITSUBA_VENV (default <repo>/.venv-mitsuba).
set -euo pipefail

MITSUBA_VERSION="${MITSUBA_VERSION:-3.9.1}"
NUMPY_SPEC="${NUMPY_SPEC:-numpy}"
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
REPO="$(cd "$HERE/../.." && pwd)"
VENV="${MITSUBA_VENV:-$REPO/.venv-mitsuba}"
PY="${PYTHON:-python3}"

say() { echo "[mitsuba-setup] $*"; }

# --- 1. virtual environment ---------------------------------------------------------------------
if [[ -x "$VENV/bin/python" ]]; then
    say "venv exists: $VENV"
else
    say "creating venv: $VENV"
    "$PY" -m venv "$VENV"
fi
VPY="$VENV/bin/python"

# --- 2. mitsuba + numpy -------------------------------------------------------------------------
have_version() { "$VPY" - "$1" "$2" <<'EOF' 2>/dev/null
import sys
from importlib.metadata import version
sys.exit(0 if (sys.argv[2] == "" or version(sys.argv[1]) == sys.argv[2]) else 1)
EOF
}
if have_version mitsuba "$MITSUBA_VERSION" && have_version numpy ""; then
    say "mitsuba $MITSUBA_VERSION and numpy already installed"
else
    say "pip install mitsuba==$MITSUBA_VERSION $NUMPY_SPEC"
    "$VPY" -m pip install --disable-pip-version-check -q --upgrade pip
    "$VPY" -m pip install --disable-pip-version-check -q "mitsuba==$MITSUBA_VERSION" "$NUMPY_SPEC"
fi
say "installed: $("$VPY" -c 'import mitsuba, drjit, numpy; print("mitsuba", mitsuba.__version__, "drjit", drjit.__version__, "numpy", numpy.__version__)')"

# --- 3. libLLVM 19 for llvm_ad_rgb --------------------------------------------------------------
find_llvm19() {
    local c
    for c in /usr/lib/x86_64-linux-gnu/libLLVM-19.so \
             /usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 \
             /usr/lib/x86_64-linux-gnu/libLLVM-19.so.1 \
             /usr/lib/llvm-19/lib/libLLVM-19.so \
             /usr/lib/llvm-19/lib/libLLVM.so.19.1 \
             /usr/lib/llvm-19/lib/libLLVM.so \
             /usr/lib/*/libLLVM-19.so* /usr/lib/*/libLLVM.so.19*; do
        [[ -e "$c" ]] && { readlink -f "$c"; return 0; }
    done
    return 1
}
LLVM_SO=""
if LLVM_SO="$(find_llvm19)"; then
    say "libLLVM 19 found: $LLVM_SO"
else
    SUDO=""
    if [[ "$(id -u)" != 0 ]] && command -v sudo >/dev/null 2>&1 && sudo -n true 2>/dev/null; then SUDO="sudo -n"; fi
    if command -v apt-get >/dev/null 2>&1 && { [[ "$(id -u)" == 0 ]] || [[ -n "$SUDO" ]]; }; then
        say "libLLVM 19 missing: apt-get install libllvm19"
        export DEBIAN_FRONTEND=noninteractive
        if ($SUDO apt-get install -y -q --no-install-recommends libllvm19 \
            || { $SUDO apt-get update -q && $SUDO apt-get install -y -q --no-install-recommends libllvm19; }) >/dev/null 2>&1; then
            LLVM_SO="$(find_llvm19 || true)"
            say "libLLVM 19 installed: ${LLVM_SO:-<not found after install>}"
        else
            say "apt-get install libllvm19 failed; llvm_ad_rgb unavailable, using scalar_rgb"
        fi
    else
        say "libLLVM 19 missing and apt-get unusable (not root, no sudo); llvm_ad_rgb unavailable, using scalar_rgb"
    fi
fi

# --- 4. pick a variant that actually renders ----------------------------------------------------
# A render smoke test, in a subprocess: with the wrong LLVM loaded Dr.Jit can abort the process.
smoke() {  # $1 = variant
    DRJIT_LIBLLVM_PATH="$LLVM_SO" timeout 300 "$VPY" - "$1" <<'EOF' >/dev/null 2>&1
import sys, mitsuba as mi
mi.set_variant(sys.argv[1])
scene = mi.load_dict(mi.cornell_box())
scene.sensors()[0].film()  # touch
img = mi.render(scene, spp=4)
import numpy as np
a = np.array(img)
assert a.shape[-1] >= 3 and np.isfinite(a).all() and a.mean() > 0.01, a.mean()
EOF
}
VARIANT="scalar_rgb"
if [[ -n "$LLVM_SO" ]]; then
    if smoke llvm_ad_rgb; then
        VARIANT="llvm_ad_rgb"
        say "llvm_ad_rgb: render smoke test OK"
    else
        say "llvm_ad_rgb: render smoke test FAILED (falling back to scalar_rgb)"
    fi
fi
if ! smoke scalar_rgb; then
    say "scalar_rgb: render smoke test FAILED"; exit 1
fi
say "scalar_rgb: render smoke test OK"

ENVFILE="$VENV/mitsuba-env.sh"
{
    echo "# written by tools/mitsuba/setup.sh"
    if [[ -n "$LLVM_SO" ]]; then echo "export DRJIT_LIBLLVM_PATH='$LLVM_SO'"; fi
    echo "export OCTOLUX_MI_VARIANT='$VARIANT'"
} > "$ENVFILE"
say "wrote $ENVFILE (default variant: $VARIANT)"
say "use:  source $ENVFILE && $VPY tools/mitsuba/render.py --help"
