#!/usr/bin/env bash
# One command for the whole peer benchmark: install the peers (idempotent), then run the harness.
#
#   bench/peers/run.sh --quick                 # smoke test: 32x32, short ladders (a few minutes)
#   bench/peers/run.sh                         # full: 128x128, 4 scenes x 5 renderers (hours on 2 cores)
#   bench/peers/run.sh --scenes cbox --write-docs ...   # any bench.py option (see --help)
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
REPO="$(cd "$HERE/../.." && pwd)"
"$HERE/setup.sh" >&2
exec "$REPO/.venv-peers/bin/python" "$HERE/bench.py" "$@"
