#!/usr/bin/env bash
# Runs every test of the project on a fresh machine: installs the Python test environment
# (./.venv), builds the release binary and cdylib, runs the Rust tests, then pytest.
# The long variants of the stress suite are not run here: bash scripts/stress.sh (docs/testing.md).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
bash scripts/setup-python.sh
cargo build --release --locked
# The branch time-series helper of the Liu report's fast check (tests/python/test_liu_report_fresh.py).
cargo build --release --locked --example liu2007_orbit
cargo test --release --locked
# The shipped FMUs (out/fmus/*.fmu) that the Python tests load.
bash scripts/build-fmus.sh
# pytest exits 5 when it collects no test; that is a failure of the harness, not a pass.
.venv/bin/python -m pytest -q tests/python "$@"
