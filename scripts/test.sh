#!/usr/bin/env bash
# Installs what is needed and runs every test: the Rust workspace (unit, integration, analytic renders,
# blob fuzzing by proptest), the farm on a one-node Slurm cluster, the kernel tests again on emulated
# CPUs without AVX2 (test-fallback.sh), and the Python cross-checks against Pixar's usd-core.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cargo build --release --locked -p ingest -p render
cargo test --release --locked --workspace
# The farm on a real one-node Slurm cluster (scripts/farm.sh: job arrays, merge, retry); its daemons
# run as root, so only there.
if [ "$(id -u)" = 0 ]; then
    bash scripts/slurm-local.sh start
    trap 'bash scripts/slurm-local.sh stop' EXIT
    FARM_SLURM=1 cargo test --release --locked -p render --test farm slurm
    bash scripts/slurm-local.sh stop
    trap - EXIT
else
    echo "test: not root: the Slurm farm tests are skipped (scripts/slurm-local.sh needs root)" >&2
fi
bash scripts/test-fallback.sh
.venv/bin/python -m pytest -q tests/python
