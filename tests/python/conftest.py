"""Shared pytest fixtures: repository paths and the release `geardyn` binary.

`scripts/test.sh` builds the binary before pytest runs; the fixture fails with a clear message
if it is missing rather than building behind the user's back.
"""

import pathlib
import subprocess

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]
GEARDYN = REPO / "target" / "release" / "geardyn"


@pytest.fixture(scope="session")
def repo_root() -> pathlib.Path:
    return REPO


@pytest.fixture(scope="session")
def geardyn_bin() -> pathlib.Path:
    if not GEARDYN.exists():
        pytest.fail(f"{GEARDYN} missing: run `cargo build --release` (scripts/test.sh does)")
    return GEARDYN


def run_geardyn(*args, check=True):
    """Runs the binary, returning the CompletedProcess (text mode)."""
    return subprocess.run([str(GEARDYN), *map(str, args)], capture_output=True, text=True, check=check)
