#!/usr/bin/env bash
# Benchmark of the FMI host runner (issue 4, acceptance 5): `geardyn run` on the shipped
# spur_pair FMU against `geardyn simulate` on the same scene, 1e5 communication steps
# (stop 1 s, interval 1e-5 s), both writing all outputs to CSV. Also: `geardyn run` recording
# one output (the FMU's own cost plus minimal host work) and `fmpy simulate` for scale.
# Reports the best of N runs (wall clock) and the ratios, then one `--timing` breakdown (time
# inside the FMU's calls vs the runner's own loop). Not a test: timings depend on load.
# Usage: bash scripts/bench-host.sh [N]   (default 5)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
n=${1:-5}
bin=target/release/geardyn
fmu=out/fmus/spur_pair.fmu
[ -x "$bin" ] || cargo build --release --locked
[ -f "$fmu" ] || bash scripts/build-fmus.sh
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
args=(--stop-time 1 --output-interval 1e-5)

best() { # best wall time of n runs of "$@", in seconds
  local b=""
  for _ in $(seq "$n"); do
    local s e
    s=$(date +%s.%N)
    "$@" >/dev/null 2>&1
    e=$(date +%s.%N)
    b=$(python3 -c "import sys; t=$e-$s; b='$b'; print(t if not b else min(t, float(b)))")
  done
  echo "$b"
}

sim=$(best "$bin" simulate fmu/spur_pair --out "$tmp/s.csv" "${args[@]}" --quiet)
run=$(best "$bin" run "$fmu" --out "$tmp/r.csv" "${args[@]}")
one=$(best "$bin" run "$fmu" --out "$tmp/o.csv" "${args[@]}" --outputs dte)
rows=$(($(wc -l <"$tmp/r.csv") - 1))
fmpy=""
if [ -x .venv/bin/python ]; then
  fmpy=$(n=1 best .venv/bin/python -m fmpy simulate "$fmu" --output-file "$tmp/f.csv" "${args[@]}")
fi
python3 - "$sim" "$run" "$one" "$rows" "$fmpy" <<'EOF'
import sys
sim, run, one, rows = map(float, sys.argv[1:5])
fmpy = sys.argv[5]
print(f"spur_pair, {int(rows)} communication steps (stop 1 s, interval 1e-5 s), best of runs:")
print(f"  geardyn simulate (native, CSV)          {sim:8.3f} s")
print(f"  geardyn run      (FMU, all outputs)     {run:8.3f} s   ratio run/simulate = {run / sim:.3f}")
print(f"  geardyn run      (FMU, --outputs dte)   {one:8.3f} s   ratio = {one / sim:.3f}")
if fmpy:
    print(f"  fmpy simulate    (FMU, all outputs)     {float(fmpy):8.3f} s   ratio = {float(fmpy) / sim:.3f}")
EOF
# Where the time of one `geardyn run` goes: inside the FMU's calls vs the runner itself.
"$bin" run "$fmu" --out "$tmp/t.csv" "${args[@]}" --timing 2>&1 >/dev/null | sed 's/^/  /'
