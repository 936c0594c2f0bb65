#!/usr/bin/env bash
# Benchmark of the co-simulated drivetrain (issue 18, acceptance 6): the three-FMU system
# examples/systems/drivetrain3 (emotor → spur_stage_speed → vehicle_load, the stage's speed
# ports carrying the shafts) and the five-FMU system examples/systems/drivetrain in geardyn's
# master (`geardyn run`: Jacobi and Gauss–Seidel with zero-order hold, with
# interpolation/extrapolation) against the monolithic native run of the same drivetrain
# (`geardyn simulate examples/drivetrain_monolithic.toml`), on the same output grid
# (communication step = output interval = T_mesh/20 at the SSD's pinion speed, stop 1 s: 38 000
# steps at 3000 rpm), each writing
# the CSV of its own columns.
# The commands run in alternating rounds so that a change of machine load hits all of them
# alike; reported: median wall and CPU time (user + system, children included: `geardyn run`
# runs the FMUs in a child process) and the ratios to the native run.
# Not a test: timings depend on the machine and its load.
# Usage: bash scripts/bench-cosim.sh [ROUNDS]   (default 7)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
rounds=${1:-7}
bin=target/release/geardyn
[ -x "$bin" ] || cargo build --release --locked
for f in emotor shaft_in spur_stage spur_stage_speed shaft_out vehicle_load; do
  [ -f "out/fmus/$f.fmu" ] || { bash scripts/build-fmus.sh; break; }
done
native=examples/drivetrain_monolithic.toml
label="monolithic drivetrain (native)"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
python3 - "$rounds" "$bin" "$native" "$label" "$tmp" <<'EOF_PY'
import math, os, statistics, subprocess, sys, time
rounds, exe, native, label, tmp = int(sys.argv[1]), *sys.argv[2:6]
import re
ssd = open("examples/systems/drivetrain/SystemStructure.ssd").read()
omega = float(re.search(r'name="input_speed"><ssv:Real value="([^"]+)"', ssd).group(1))  # the SSD's pinion speed
h = 2 * math.pi / (38 * omega) / 20
grid = ["--stop-time", "1", "--output-interval", repr(h)]
system = "examples/systems/drivetrain"
system3 = "examples/systems/drivetrain3"
commands = {
    label: [exe, "simulate", native, "--out", f"{tmp}/n.csv", *grid, "--quiet"],
    "3 FMUs, geardyn run Jacobi/hold": [exe, "run", system3, "--out", f"{tmp}/j3.csv", *grid,
                                        "--algorithm", "jacobi", "--extrapolation", "none"],
    "3 FMUs, geardyn run Jacobi/linear": [exe, "run", system3, "--out", f"{tmp}/jl3.csv", *grid,
                                          "--algorithm", "jacobi", "--extrapolation", "linear"],
    "3 FMUs, geardyn run GS/linear": [exe, "run", system3, "--out", f"{tmp}/l3.csv", *grid,
                                      "--algorithm", "gauss-seidel", "--extrapolation", "linear"],
    "5 FMUs, geardyn run Jacobi/hold": [exe, "run", system, "--out", f"{tmp}/j.csv", *grid,
                                        "--algorithm", "jacobi", "--extrapolation", "none"],
    "5 FMUs, geardyn run GS/hold": [exe, "run", system, "--out", f"{tmp}/g.csv", *grid,
                                    "--algorithm", "gauss-seidel", "--extrapolation", "none"],
    "5 FMUs, geardyn run GS/linear": [exe, "run", system, "--out", f"{tmp}/l.csv", *grid,
                                      "--algorithm", "gauss-seidel", "--extrapolation", "linear"],
}

def timed(cmd):
    start = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - start
    if os.waitstatus_to_exitcode(status) != 0:
        sys.exit(f"failed: {' '.join(cmd)}")
    return wall, usage.ru_utime + usage.ru_stime

samples = {name: [] for name in commands}
for _ in range(rounds):
    for name, cmd in commands.items():
        samples[name].append(timed(cmd))
rows = sum(1 for _ in open(f"{tmp}/j.csv")) - 1
base = next(iter(commands))
med = statistics.median
bw, bc = med([w for w, _ in samples[base]]), med([c for _, c in samples[base]])
print(f"drivetrain, {rows} communication steps of T_mesh/20 = {h:.4e} s (stop 1 s), median of {rounds} alternating rounds:")
print(f"  {'':40}  {'wall':>8}  {'ratio':>6}  {'CPU':>8}  {'ratio':>6}")
for name, xs in samples.items():
    w, c = med([w for w, _ in xs]), med([c for _, c in xs])
    print(f"  {name:40}  {w:7.3f}s  {w / bw:6.3f}  {c:7.3f}s  {c / bc:6.3f}")
EOF_PY
