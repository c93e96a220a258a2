"""Shared paths: the repository root (bundled recordings and models) and the CLI binary."""

import os
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def root() -> Path:
    return ROOT


@pytest.fixture(scope="session")
def cli() -> str:
    """The `softsense` binary: SOFTSENSE_BIN, else target/release/softsense, else one on PATH;
    a missing binary fails (these tests compare against it), it is never skipped."""
    given = os.environ.get("SOFTSENSE_BIN")
    candidates = [given] if given else [str(ROOT / "target" / "release" / "softsense"), shutil.which("softsense")]
    for c in candidates:
        if c and Path(c).is_file():
            return c
    pytest.fail("no softsense binary: build it (cargo build --release) or set SOFTSENSE_BIN")


def run_cli(cli: str, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([cli, *args], cwd=ROOT, capture_output=True, text=True, check=True)
