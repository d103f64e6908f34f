#!/usr/bin/env bash
# Benchmarks, measured side by side in one run (never asserted in tests):
#   1. ray throughput of our BVH against Embree (embreex) on the same rays, 1 and 2 threads;
#   2. error against time: RMSE to a high-spp reference versus render seconds, charted as SVG.
# Figures land in out/bench/ (rays.json, convergence.json, convergence.svg).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
.venv/bin/python -c "import embreex" 2>/dev/null || .venv/bin/pip install -q embreex
cargo build --release --locked -p ingest -p render -p bench
mkdir -p out/bench
./target/release/ingest -q examples/tractor.usda -o out/bench/tractor.blob
./target/release/bench rays out/bench/tractor.blob --rays "${RAYS:-1000000}" --out out/bench
./target/release/bench convergence out/bench/tractor.blob --out out/bench
