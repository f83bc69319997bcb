"""Shared fixtures: the repository, ../shared beside it, and the `agvsim` CLI the Python
results are compared with (byte for byte)."""

import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SHARED = ROOT.parent / "shared"


def cli_path() -> Path:
    """The CLI built from this checkout: AGVSIM_BIN, else target/release or target/debug."""
    given = os.environ.get("AGVSIM_BIN")
    if given:
        return Path(given)
    for profile in ("release", "debug"):
        p = ROOT / "target" / profile / "agvsim"
        if p.exists():
            return p
    raise RuntimeError("no agvsim CLI to compare with: run `cargo build` first or set AGVSIM_BIN")


@pytest.fixture(scope="session")
def root() -> Path:
    return ROOT


@pytest.fixture(scope="session")
def shared() -> Path:
    if not SHARED.is_dir():
        raise RuntimeError(f"{SHARED}: the shared data folder is not beside the repository")
    return SHARED


@pytest.fixture(scope="session")
def cli():
    """Runs the CLI in the repository's folder; returns its standard output, failing the
    test with its standard error when it fails."""
    exe = cli_path()

    def run(*args, ok=True):
        p = subprocess.run([str(exe), *map(str, args)], cwd=ROOT, capture_output=True, text=True)
        if ok and p.returncode != 0:
            raise AssertionError(f"agvsim {' '.join(map(str, args))} failed ({p.returncode}):\n{p.stderr}")
        return p

    return run
