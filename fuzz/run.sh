#!/usr/bin/env bash
# Fuzz octolux's loaders with cargo-fuzz (libFuzzer, nightly Rust), one target after the other.
#
#   fuzz/run.sh [SECONDS_PER_TARGET] [TARGET...]     (default: 60 s, every target)
#
# Installs cargo-fuzz when it is missing. Each target starts from fuzz/corpus/<target>/ and adds
# the new inputs it finds there; crashes are written to fuzz/artifacts/<target>/ (reproduce one
# with `cargo +nightly fuzz run <target> <file>`, then add the file to the corpus so that the
# stable replay test, crates/octolux-io/tests/fuzz_corpus.rs, keeps checking it). Before
# committing a grown corpus, minimise it: `cargo +nightly fuzz cmin <target>` (keep it < 1 MB).
# Runs niced, on one job: the machine is shared.
set -euo pipefail
cd "$(dirname "$0")/.."
secs="${1:-60}"
shift || true
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
    targets=(xml obj ply serialized image cache gltf settings paths)
fi
if ! cargo +nightly fuzz --version >/dev/null 2>&1; then
    cargo install cargo-fuzz --locked
fi
for t in "${targets[@]}"; do
    echo "== fuzzing $t for ${secs}s"
    nice -n 10 cargo +nightly fuzz run --fuzz-dir fuzz "$t" "fuzz/corpus/$t" -- \
        -max_total_time="$secs" -rss_limit_mb=2048 -max_len=65536 -timeout=10 -print_final_stats=1
done
