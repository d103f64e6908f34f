#!/usr/bin/env bash
# Installs what is needed and runs every test: the Rust workspace (unit, integration, analytic renders,
# blob fuzzing by proptest), the kernel tests again on emulated CPUs without AVX2 (test-fallback.sh),
# and the Python cross-checks against Pixar's usd-core.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cargo build --release --locked -p ingest -p render
cargo test --release --locked --workspace
bash scripts/test-fallback.sh
.venv/bin/python -m pytest -q tests/python
