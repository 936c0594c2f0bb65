#!/usr/bin/env bash
# Benchmark (not a test): ns per mesh period of the exact propagator and the RK path (DP5 and
# DOP853 at rtol 1e-9) on spur_pair, with and without contact loss, all measured side by side
# in one run (benches/spur_pair.rs), then the same scenes through the scipy reference for the
# ratio to scipy (scripts/bench_scipy.py; skipped with --no-scipy).
# Usage: scripts/bench.sh [--quick] [--no-scipy]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
bench_args=()
scipy=1
for a in "$@"; do
  case "$a" in
    --quick) bench_args+=(--quick) ;;
    --no-scipy) scipy=0 ;;
    *) echo "usage: scripts/bench.sh [--quick] [--no-scipy]" >&2; exit 2 ;;
  esac
done
out=target/bench
mkdir -p "$out"
cargo bench --locked --bench spur_pair -- --csv "$out/spur_pair.csv" --write-scenes "$out/scenes" "${bench_args[@]}"
echo
# Steady-state tools: 400-point sweep vs brute force, HB continuation with stability.
cargo bench --locked --bench analysis
if [ "$scipy" = 1 ]; then
  echo
  bash scripts/setup-python.sh >/dev/null
  .venv/bin/python scripts/bench_scipy.py "$out"
fi
