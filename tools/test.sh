#!/usr/bin/env bash
# The whole test suite (the README's test command). Tests that need ../shared/scenes skip
# cleanly when it is absent.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo test --workspace --no-fail-fast "$@"
