#!/usr/bin/env bash
# Work-precision benchmark (issue 9): regenerates docs/benchmarks.md and docs/benchmarks/*.svg.
# geardyn's DP5, DOP853 and exact propagator, scipy's solve_ivp (DOP853, RK45, Radau) and the
# Rust crate differential-equations (DOPRI5, DOP853; benches/peer, a separate cargo project)
# on the problems of benches/workprecision/problems.rs along one tolerance ladder, all in this
# one run, with the extended-precision reference scripts/workprecision_mpmath.py (about 10 min
# on 2 cores, mostly scipy's Radau). --quick: fewer timed runs (for
# iteration; every rung still runs).
# Usage: scripts/bench-workprecision.sh [--quick]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
quick=()
for a in "$@"; do
  case "$a" in
    --quick) quick=(--quick) ;;
    *) echo "usage: scripts/bench-workprecision.sh [--quick]" >&2; exit 2 ;;
  esac
done
out=target/workprecision
mkdir -p "$out"
start=$(date +%s)
# 1. Problem files for the other harnesses.
cargo bench --locked --bench workprecision -- --write-problems "$out"
# 2. The Rust peer (its own lock file and target directory: never part of geardyn's build).
cargo build --release --locked --manifest-path benches/peer/Cargo.toml --target-dir target/peer
target/peer/release/geardyn-peer-bench "$out" "${quick[@]}" 2>/dev/null
echo "peer done ($(( $(date +%s) - start )) s)"
# 3. scipy.
bash scripts/setup-python.sh >/dev/null
.venv/bin/python scripts/workprecision_scipy.py "$out" "${quick[@]}"
echo "scipy done ($(( $(date +%s) - start )) s)"
# 4. The extended-precision reference (mpmath closed form) of the piecewise-constant problems.
.venv/bin/python scripts/workprecision_mpmath.py "$out"
echo "mpmath done ($(( $(date +%s) - start )) s)"
# 5. geardyn, references, errors, report.
cargo bench --locked --bench workprecision -- --report "$out" --doc docs/benchmarks.md "${quick[@]}"
echo "total $(( $(date +%s) - start )) s"
