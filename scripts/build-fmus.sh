#!/usr/bin/env bash
# Builds out/fmus/<name>.fmu for every shipped scene fmu/<name>/scene.toml, with the release
# cdylib. Usage: bash scripts/build-fmus.sh [out-dir]   (default out/fmus)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
out=${1:-out/fmus}
cargo build --release --locked
shopt -s nullglob
scenes=(fmu/*/scene.toml)
if [ ${#scenes[@]} -eq 0 ]; then
  echo "no fmu/*/scene.toml found" >&2
  exit 1
fi
for scene in "${scenes[@]}"; do
  target/release/geardyn fmu build "$(dirname "$scene")" --out "$out"
done
