"""Fixtures for the usd-core cross-checks: build the Rust binaries once, run them on stages."""

from __future__ import annotations

import json
import os
import subprocess
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@dataclass(frozen=True)
class Binaries:
    ingest: Path
    render: Path


@dataclass
class IngestResult:
    returncode: int
    stderr: str
    blob: Path
    dump: dict | None

    def ok(self) -> "IngestResult":
        assert self.returncode == 0, f"ingest exited {self.returncode}:\n{self.stderr}"
        assert self.dump is not None
        return self


@dataclass
class RenderResult:
    returncode: int
    stdout: str
    stderr: str


def _target_dir() -> Path:
    target = Path(os.environ.get("CARGO_TARGET_DIR", "target"))
    return target if target.is_absolute() else ROOT / target


@pytest.fixture(scope="session")
def binaries() -> Binaries:
    """`cargo build --release -p ingest -p render` from the repository root, once per session."""
    cargo = os.environ.get("CARGO", "cargo")
    build = subprocess.run(
        [cargo, "build", "--release", "-p", "ingest", "-p", "render"],
        cwd=ROOT, capture_output=True, text=True,
    )
    if build.returncode != 0:
        pytest.fail(f"cargo build failed ({build.returncode}):\n{build.stderr[-6000:]}")
    release = _target_dir() / "release"
    found = Binaries(release / "ingest", release / "render")
    for exe in (found.ingest, found.render):
        assert exe.is_file(), f"{exe} was not built"
    return found


@pytest.fixture
def ingest(binaries, tmp_path):
    """`ingest(stage, *flags)`: runs `ingest STAGE -o BLOB --dump-json JSON FLAGS` into tmp_path."""
    counter = iter(range(1_000_000))

    def run(stage, *flags) -> IngestResult:
        n = next(counter)
        blob = tmp_path / f"scene{n}.blob"
        dump = tmp_path / f"scene{n}.json"
        proc = subprocess.run(
            [str(binaries.ingest), str(stage), "-o", str(blob), "--dump-json", str(dump), "--quiet", *flags],
            capture_output=True, text=True, timeout=120,
        )
        data = json.loads(dump.read_text()) if proc.returncode == 0 and dump.exists() else None
        return IngestResult(proc.returncode, proc.stderr, blob, data)

    return run


@pytest.fixture
def render(binaries):
    """`render(*args)`: runs the render binary."""

    def run(*args) -> RenderResult:
        proc = subprocess.run([str(binaries.render), *map(str, args)], capture_output=True, text=True, timeout=120)
        return RenderResult(proc.returncode, proc.stdout, proc.stderr)

    return run


@pytest.fixture
def render_info(render):
    """`render_info(blob)`: the JSON object printed by `render BLOB --info`."""

    def run(blob) -> dict:
        result = render(blob, "--info")
        assert result.returncode == 0, f"render --info exited {result.returncode}:\n{result.stderr}"
        return json.loads(result.stdout)

    return run
