#!/usr/bin/env bash
# Installs what is needed and runs every test: the Rust workspace (unit, integration, analytic renders,
# blob fuzzing by proptest) and the Python cross-checks against Pixar's usd-core.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cargo build --release --locked -p ingest -p render
cargo test --release --locked --workspace
.venv/bin/python -m pytest -q tests/python
