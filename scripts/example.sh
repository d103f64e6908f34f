#!/usr/bin/env bash
# Installs what is needed, builds, and renders the bundled example to out/tractor.exr and out/tractor.png.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cargo build --release --locked -p ingest -p render
mkdir -p out
./target/release/ingest examples/tractor.usda -o out/tractor.blob
./target/release/render out/tractor.blob -o out/tractor.exr --png out/tractor.png --spp "${SPP:-64}" --stats out/tractor.stats.json
echo "wrote out/tractor.exr and out/tractor.png"
