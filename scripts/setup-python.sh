#!/usr/bin/env bash
# Creates ./.venv (if missing), installs the Python test dependencies into it, and builds the
# geardyn Python module (python/, PyO3 + maturin) from source into it.
# Idempotent: a second run only checks that the pinned requirements are satisfied and runs an
# incremental build of the module (seconds when nothing changed; it shares target/ with the
# main crate, see python/Cargo.toml).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
venv="$root/.venv"
req="$root/tests/python/requirements.txt"
python=${PYTHON:-python3}
if [ ! -x "$venv/bin/python" ]; then
  "$python" -m venv "$venv"
fi
stamp="$venv/.requirements.sha256"
want=$(sha256sum "$req" | cut -d' ' -f1)
if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$want" ]; then
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check --upgrade pip
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check -r "$req"
  echo "$want" > "$stamp"
fi
# The module is an abi3 extension (`_geardyn.abi3.so`, python/Cargo.toml); a version-tagged one
# left by an older build would be imported before it, so it goes.
rm -f "$root"/python/geardyn/_geardyn.cpython-*.so
# Editable install: python/geardyn is imported in place, the extension is built into it.
# `--skip-install` is not used: the first run must register the package (and the
# geardyn-study console script) in the venv; later runs reinstall only the small wheel stub.
VIRTUAL_ENV="$venv" PATH="$venv/bin:$PATH" \
  "$venv/bin/maturin" develop --release --locked --quiet -m "$root/python/Cargo.toml"
echo "python test environment ready: $venv"
