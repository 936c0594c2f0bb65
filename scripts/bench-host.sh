#!/usr/bin/env bash
# Benchmark of the FMI host runner (issue 4, acceptance 5): `geardyn run` on the shipped
# spur_pair FMU against `geardyn simulate` on the same scene, 1e5 communication steps
# (stop 1 s, interval 1e-5 s), both writing all outputs to CSV (same grid, same columns, one
# file each). Also: `geardyn run` recording one output (the FMU's own cost plus minimal host
# work) and `fmpy simulate` for scale.
# The commands run in alternating rounds (simulate, run, run --outputs dte, ...) so that a
# change of machine load hits all of them alike; reported: the median wall time and the median
# CPU time (user + system, less sensitive to other processes) of each, and the ratios side by
# side. Then one `--timing` breakdown (time inside the FMU's calls vs CSV formatting vs the
# runner's own loop). Not a test: timings depend on the machine and its load.
# With --instructions (needs valgrind): also the instructions executed by one run of each
# (callgrind, ~1 min), a measure that does not depend on the load at all.
# With --against DIR (another worktree with a release build and out/fmus, e.g. the commit
# before a change): each command also runs with DIR's binary and FMU, alternated with this
# tree's, and the table gives this tree's median CPU over DIR's (the speed-unchanged check);
# with --instructions the callgrind totals of both, side by side.
# Usage: bash scripts/bench-host.sh [ROUNDS] [--instructions] [--against DIR]   (default 9 rounds)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
rounds=9
instructions=false
against=""
while [ $# -gt 0 ]; do
  case "$1" in
    --instructions) instructions=true ;;
    --against) against=$(cd "$2" && pwd); shift ;;
    *) rounds=$1 ;;
  esac
  shift
done
bin=target/release/geardyn
fmu=out/fmus/spur_pair.fmu
[ -x "$bin" ] || cargo build --release --locked
[ -f "$fmu" ] || bash scripts/build-fmus.sh
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fmpy=""
[ -x .venv/bin/python ] && fmpy=.venv/bin/python
python3 - "$rounds" "$bin" "$fmu" "$tmp" "$fmpy" "$against" <<'EOF_PY'
import os, statistics, subprocess, sys, time
rounds, exe, fmu, tmp, fmpy, against = int(sys.argv[1]), *sys.argv[2:7]
grid = ["--stop-time", "1", "--output-interval", "1e-5"]
commands = {
    "geardyn simulate (native, CSV)": [exe, "simulate", "fmu/spur_pair", "--out", f"{tmp}/s.csv", *grid, "--quiet"],
    "geardyn run      (FMU, all outputs)": [exe, "run", fmu, "--out", f"{tmp}/r.csv", *grid],
    "geardyn run      (FMU, --outputs mesh.dte)": [exe, "run", fmu, "--out", f"{tmp}/o.csv", *grid, "--outputs", "mesh.dte"],
}

def timed(cmd):
    """Wall and CPU (user + system) seconds of one run of `cmd`."""
    start = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - start
    if os.waitstatus_to_exitcode(status) != 0:
        sys.exit(f"failed: {' '.join(cmd)}")
    return wall, usage.ru_utime + usage.ru_stime

if against:
    base = {
        name: [f"{against}/{exe}" if a == exe else f"{against}/{fmu}" if a == fmu else a for a in cmd]
        for name, cmd in commands.items()
    }
    new_cpu, base_cpu = {n: [] for n in commands}, {n: [] for n in commands}
    for _ in range(rounds):
        for name in commands:
            base_cpu[name].append(timed(base[name])[1])
            new_cpu[name].append(timed(commands[name])[1])
    print(f"this tree against {against}: median CPU of {rounds} alternated rounds (load average {os.getloadavg()[0]:.1f})")
    print(f"  {'':44}  {'base':>8}  {'new':>8}  {'new/base':>8}")
    for name in commands:
        b, n = statistics.median(base_cpu[name]), statistics.median(new_cpu[name])
        print(f"  {name:44}  {b:7.3f}s  {n:7.3f}s  {n / b:8.3f}")
    sys.exit(0)
samples = {name: [] for name in commands}
for _ in range(rounds):
    for name, cmd in commands.items():
        samples[name].append(timed(cmd))
rows = sum(1 for _ in open(f"{tmp}/r.csv")) - 1
base_name = next(iter(commands))
median = lambda xs: statistics.median(xs)
base_wall = median([w for w, _ in samples[base_name]])
base_cpu = median([c for _, c in samples[base_name]])
print(f"spur_pair, {rows} communication steps (stop 1 s, interval 1e-5 s), median of {rounds} alternating rounds:")
print(f"  {'':38}  {'wall':>8}  {'ratio':>6}  {'CPU':>8}  {'ratio':>6}")
for name, xs in samples.items():
    wall, cpu = median([w for w, _ in xs]), median([c for _, c in xs])
    print(f"  {name:38}  {wall:7.3f}s  {wall / base_wall:6.3f}  {cpu:7.3f}s  {cpu / base_cpu:6.3f}")
if fmpy:
    wall, cpu = timed([fmpy, "-m", "fmpy", "simulate", fmu, "--output-file", f"{tmp}/f.csv", *grid])
    print(f"  {'fmpy simulate    (FMU, all outputs)':38}  {wall:7.3f}s  {wall / base_wall:6.3f}  {cpu:7.3f}s  {cpu / base_cpu:6.3f}   (one run)")
EOF_PY
# Where the time of one `geardyn run` goes: inside the FMU's calls vs the runner itself.
[ -n "$against" ] || "$bin" run "$fmu" --out "$tmp/t.csv" --stop-time 1 --output-interval 1e-5 --timing 2>&1 >/dev/null | sed 's/^/  /'
if $instructions; then
  # callgrind's "Collected" totals: every instruction, FMU library included, summed over the
  # processes (`geardyn run` forks the one that runs the FMU; each reports its own total).
  ir() {
    valgrind --tool=callgrind --callgrind-out-file="$tmp/cg.%p" "$@" 2>&1 >/dev/null |
      sed -n 's/.*Collected : //p' | awk '{ total += $1 } END { print total }'
  }
  grid="--stop-time 1 --output-interval 1e-5"
  trees=("$root")
  [ -n "$against" ] && trees=("$against" "$root")
  for tree in "${trees[@]}"; do
    # shellcheck disable=SC2086
    sim_ir=$(cd "$tree" && ir "$bin" simulate fmu/spur_pair --out "$tmp/s.csv" $grid --quiet)
    # shellcheck disable=SC2086
    run_ir=$(cd "$tree" && ir "$bin" run "$fmu" --out "$tmp/r.csv" $grid)
    # shellcheck disable=SC2086
    dte_ir=$(cd "$tree" && ir "$bin" run "$fmu" --out "$tmp/o.csv" $grid --outputs mesh.dte)
    python3 -c "s, r, o = $sim_ir, $run_ir, $dte_ir; print(f'  instructions (callgrind) in $tree: simulate {s / 1e6:.1f} M, run {r / 1e6:.1f} M, run --outputs mesh.dte {o / 1e6:.1f} M')"
  done
fi
