#!/usr/bin/env bash
# Builds the geardyn Python wheel into DIR (default: out/wheels): one abi3 wheel for every
# CPython >= 3.11 that installs without a Rust toolchain. It carries the FMU binary
# (libgeardyn.so) beside the module, so `geardyn.build_fmu` works from the installed wheel.
# Usage: bash scripts/build-wheel.sh [DIR]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
out=$(mkdir -p "${1:-$root/out/wheels}" && cd "${1:-$root/out/wheels}" && pwd)
venv="$root/.venv"
[ -x "$venv/bin/maturin" ] || bash "$root/scripts/setup-python.sh"
cd "$root"
cargo build --release --locked --lib
# maturin packs every file of the package folder (python/geardyn); the copy is removed after,
# so the source tree's editable install keeps using target/release (geardyn._default_cdylib).
staged="$root/python/geardyn/libgeardyn.so"
trap 'rm -f "$staged"' EXIT
cp "$root/target/release/libgeardyn.so" "$staged"
VIRTUAL_ENV="$venv" PATH="$venv/bin:$PATH" \
  "$venv/bin/maturin" build --release --locked --quiet -m "$root/python/Cargo.toml" --out "$out"
ls "$out"/geardyn-*-abi3-*.whl
