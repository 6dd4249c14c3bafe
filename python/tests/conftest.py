"""Shared fixtures of the drive_sim tests: small runs (few steps, the ideal-ish asphalt) so
that the whole suite takes seconds; the command-line binary for the figures to agree with."""

import os
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def cli() -> Path:
    """The `drive-sim` binary of the test build (`cargo test` builds it), or the one on PATH."""
    for candidate in (
        os.environ.get("DRIVE_SIM_BIN"),
        ROOT / "target" / "debug" / "drive-sim",
        shutil.which("drive-sim"),
    ):
        if candidate and Path(candidate).is_file():
            return Path(candidate)
    pytest.skip("no drive-sim binary: run `cargo build` (or set DRIVE_SIM_BIN)")


def run_cli(cli: Path, *args: str) -> subprocess.CompletedProcess:
    """Runs the binary; fails the test with its stderr if it fails."""
    p = subprocess.run([str(cli), *args], capture_output=True, text=True, cwd=ROOT)
    assert p.returncode == 0, p.stderr
    return p
