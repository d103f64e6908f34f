#!/usr/bin/env bash
# Coverage-guided fuzzing (cargo-fuzz, libFuzzer): scripts/fuzz.sh TARGET SECONDS [LIBFUZZER ARGS...]
#
# Targets:
# - render/fuzz/fuzz_targets: blob_render — blob parse + a one-sample render, checksums
#   recomputed by the harness so mutations reach structural validation.
# - ingest/fuzz/fuzz_targets (each calls the function of the same name in ingest::fuzz_entry):
#   usda, usdc, usdz (a layer through the ingest reader), abc (an Alembic archive through its
#   translation), mtlx (MaterialX translation + a stage referencing it), texture_decode (first byte picks the decoder, rest decoded within a budget).
# Needs `cargo install cargo-fuzz`. cargo-fuzz passes nightly-only flags (-Zsanitizer); on a stable
# toolchain RUSTC_BOOTSTRAP=1 enables them, which this script sets.
#
# blob_render: the first run seeds render/fuzz/corpus/TARGET by ingesting tests/assets/fuzz/corpus
# (subdivision level 0, so the seeds stay ~100-200 KB). Crashes land in render/fuzz/artifacts/TARGET;
# copy each into render/fuzz/regressions/TARGET so the blob tests replay it.
#
# ingest targets: the committed seeds are ingest/fuzz/corpus/TARGET (read only); what libFuzzer adds
# goes to ingest/fuzz/work/TARGET (not committed). Crashes land in ingest/fuzz/artifacts/TARGET; after
# the fix, copy each into ingest/fuzz/regressions/TARGET named after the bug, so that
# `cargo test --release -p ingest --test integration fuzz_corpus` replays it.
set -euo pipefail
target=${1:?usage: scripts/fuzz.sh TARGET SECONDS [LIBFUZZER ARGS...]}
seconds=${2:?usage: scripts/fuzz.sh TARGET SECONDS [LIBFUZZER ARGS...]}
shift 2
root=$(cd "$(dirname "$0")/.." && pwd)
export RUSTC_BOOTSTRAP=1
limits=(-max_total_time="$seconds" -rss_limit_mb=2048 -timeout=20)
case "$target" in
usda | usdc | usdz | abc | mtlx | texture_decode)
    fuzz=$root/ingest/fuzz
    work=$fuzz/work/$target
    mkdir -p "$work"
    dirs=("$work" "$fuzz/corpus/$target")
    [ -d "$fuzz/regressions/$target" ] && dirs+=("$fuzz/regressions/$target")
    cd "$fuzz"
    exec cargo fuzz run -O "$target" "${dirs[@]}" -- "${limits[@]}" "$@"
    ;;
blob_render) ;;
*)
    echo "unknown target $target (blob_render, usda, usdc, usdz, abc, mtlx, texture_decode)" >&2
    exit 2
    ;;
esac
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
exec cargo fuzz run "$target" "$corpus" -- "${limits[@]}" "$@"
