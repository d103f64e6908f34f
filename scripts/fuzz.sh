#!/usr/bin/env bash
# Coverage-guided fuzzing (cargo-fuzz, libFuzzer): scripts/fuzz.sh TARGET SECONDS [LIBFUZZER ARGS...]
#
# Targets (render/fuzz/fuzz_targets): blob_render — blob parse + a one-sample render, checksums
# recomputed by the harness so mutations reach structural validation.
# Needs `cargo install cargo-fuzz`. cargo-fuzz passes nightly-only flags (-Zsanitizer); on a stable
# toolchain RUSTC_BOOTSTRAP=1 enables them, which this script sets.
# The first run seeds render/fuzz/corpus/TARGET by ingesting tests/assets/fuzz/corpus (subdivision level 0,
# so the seeds stay ~100-200 KB). Crashes land in
# render/fuzz/artifacts/TARGET; copy each into render/fuzz/regressions/TARGET so the blob tests replay it.
set -euo pipefail
target=${1:?usage: scripts/fuzz.sh TARGET SECONDS [LIBFUZZER ARGS...]}
seconds=${2:?usage: scripts/fuzz.sh TARGET SECONDS [LIBFUZZER ARGS...]}
shift 2
root=$(cd "$(dirname "$0")/.." && pwd)
fuzz=$root/render/fuzz
corpus=$fuzz/corpus/$target
mkdir -p "$corpus"
if [ -z "$(ls -A "$corpus")" ]; then
    (cd "$root" && cargo build --release -p ingest --bin ingest)
    for asset in "$root"/tests/assets/fuzz/corpus/*; do
        "$root/target/release/ingest" "$asset" --subdiv-level 0 -o "$corpus/$(basename "$asset").blob" >/dev/null 2>&1 || true
    done
    # Regressions seed the corpus too.
    cp "$fuzz"/regressions/"$target"/* "$corpus"/ 2>/dev/null || true
fi
cd "$fuzz"
export RUSTC_BOOTSTRAP=1
exec cargo fuzz run "$target" "$corpus" -- -max_total_time="$seconds" -rss_limit_mb=2048 -timeout=20 "$@"
