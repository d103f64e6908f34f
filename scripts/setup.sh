#!/usr/bin/env bash
# Installs everything the project needs on a fresh Debian machine (run as root): Debian packages, and a
# Python venv in .venv with Pixar's usd-core for the conversion tests. Idempotent: a second run only checks.
set -euo pipefail
cd "$(dirname "$0")/.."

if ! command -v cargo >/dev/null 2>&1; then
    echo "error: cargo not found. Install Rust 1.95 or newer (rustup) and re-run." >&2
    exit 1
fi

# Debian packages: a C/C++ toolchain for crates that build C, OpenSubdiv (subdiv/ links it),
# Python's venv module, qemu-user (scripts/test-fallback.sh runs the kernel tests on emulated CPUs
# without AVX2), and Slurm with munge (the farm tests run on a one-node cluster, scripts/slurm-local.sh).
apt_packages=(build-essential pkg-config python3-venv libosd-dev qemu-user slurm-wlm munge)
missing=()
for p in "${apt_packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
    if command -v apt-get >/dev/null 2>&1; then
        echo "setup: installing Debian packages: ${missing[*]}"
        export DEBIAN_FRONTEND=noninteractive
        apt-get update -qq
        apt-get install -y -qq "${missing[@]}" >/dev/null
    else
        echo "warning: not a Debian machine; make sure these are installed: ${missing[*]}" >&2
    fi
fi

# Python venv with usd-core (tests only; rendering never needs Python).
if [ ! -x .venv/bin/python ] || ! .venv/bin/python -c "import pxr, pytest, numpy" >/dev/null 2>&1; then
    echo "setup: creating .venv with usd-core"
    python3 -m venv .venv
    .venv/bin/pip install -q --upgrade pip
    .venv/bin/pip install -q -r tests/python/requirements.txt
fi
