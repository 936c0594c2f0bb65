#!/usr/bin/env bash
# Benchmark of the co-simulated drivetrain (issue 18, acceptance 6): the three-FMU system
# examples/systems/drivetrain3 (emotor → spur_stage_speed → vehicle_load, the stage's speed
# ports carrying the shafts) and the five-FMU system examples/systems/drivetrain in geardyn's
# master (`geardyn run`: Jacobi and Gauss–Seidel with zero-order hold, with
# interpolation/extrapolation), each against the monolithic native run of the same drivetrain
# at the same operating point (`geardyn simulate examples/drivetrain_monolithic.toml`: the
# five-FMU system's cruise point, 3000 rpm; for the three-FMU system the scene moved to its
# 4500 rpm point by tests/python/drivetrain_reference.py SteadyPoint), on the same output grid
# (communication step = output interval = T_mesh/20 at the SSD's pinion speed, stop 1 s), each
# writing the CSV of its own columns. Jacobi runs on one thread (--threads 1), and the five-FMU
# system's Jacobi/hold also on two (parallel Jacobi, issue 32: bit-identical results; its
# speedup is the ratio of the two rows). The error-controlled master (--tolerance, issue 32)
# runs Gauss–Seidel/linear at 1e-3 and 1e-4 on the same output grid (the grid bounds its step),
# at 1e-4 also with --no-shared-binaries (a copy of the one geardyn binary per FMU, as FMI 2.0
# masters load them; docs/fmu.md "One binary for several FMUs").
# The commands run in alternating rounds so that a change of machine load hits all of them
# alike; reported: median wall and CPU time (user + system, children included: `geardyn run`
# runs the FMUs in a child process), their ratios to the native run of the same point, and the
# median over the rounds of each round's CPU ratio (the run and its native run seconds apart).
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
py=.venv/bin/python
[ -x "$py" ] || py=python3
"$py" - "$rounds" "$bin" "$tmp" <<'EOF_PY'
import math, os, re, statistics, subprocess, sys, time
rounds, exe, tmp = int(sys.argv[1]), sys.argv[2], sys.argv[3]
sys.path.insert(0, "tests/python")
import drivetrain_reference as dr

native = "examples/drivetrain_monolithic.toml"


def pinion_speed(system):
    ssd = open(f"{system}/SystemStructure.ssd").read()
    m = re.search(r'name="(?:operating\.)?input_speed"><ssv:Real value="([^"]+)"', ssd)
    return float(m.group(1))


def grid(system):
    h = 2 * math.pi / (38 * pinion_speed(system)) / 20
    return h, ["--stop-time", "1", "--output-interval", repr(h)]


def run(system, out, grid, algorithm, extrapolation, threads, tol, copies=False):
    cmd = [exe, "run", system, "--out", out, *grid, "--algorithm", algorithm, "--extrapolation", extrapolation]
    cmd += ["--tolerance", tol] if tol else []
    cmd += ["--no-shared-binaries"] if copies else []
    return cmd + (["--threads", str(threads)] if algorithm == "jacobi" else [])


groups = []
for system, n_fmus, couplings in (
        ("examples/systems/drivetrain3", 3, [("jacobi", "none", 1, None), ("jacobi", "linear", 1, None),
                                             ("gauss-seidel", "linear", 1, None), ("gauss-seidel", "linear", 1, "1e-3"),
                                             ("gauss-seidel", "linear", 1, "1e-4"),
                                             ("gauss-seidel", "linear", 1, "1e-4 copies")]),
        ("examples/systems/drivetrain", 5, [("jacobi", "none", 1, None), ("jacobi", "none", 2, None),
                                            ("gauss-seidel", "none", 1, None), ("gauss-seidel", "linear", 1, None),
                                            ("gauss-seidel", "linear", 1, "1e-3"), ("gauss-seidel", "linear", 1, "1e-4"),
                                            ("gauss-seidel", "linear", 1, "1e-4 copies")])):
    h, g = grid(system)
    rpm = pinion_speed(system) * 30 / math.pi
    point = dr.SteadyPoint(rpm, 10.0)
    scene = f"{tmp}/monolithic_{n_fmus}.toml"
    with open(scene, "w") as fh:
        fh.write(point.monolithic_scene(open(native).read()))
    commands = {f"monolithic drivetrain (native), {rpm:.0f} rpm": [exe, "simulate", scene, "--out", f"{tmp}/n{n_fmus}.csv", *g, "--quiet"]}
    for alg, ex, threads, spec in couplings:
        tol, _, copies = (spec or "").partition(" ")
        label = f"{n_fmus} FMUs, geardyn run {'GS' if alg == 'gauss-seidel' else 'Jacobi'}/{'hold' if ex == 'none' else 'linear'}"
        label += ", 2 threads" if threads == 2 else ""
        label += f", --tolerance {tol}" if tol else ""
        label += ", a binary per FMU" if copies else ""
        out = f"{tmp}/{n_fmus}{alg}{ex}{threads}{tol}{copies}.csv"
        commands[label] = run(system, out, g, alg, ex, threads, tol, bool(copies))
    groups.append((system, h, commands))


def timed(cmd):
    start = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - start
    if os.waitstatus_to_exitcode(status) != 0:
        sys.exit(f"failed: {' '.join(cmd)}")
    return wall, usage.ru_utime + usage.ru_stime


samples = {name: [] for _, _, commands in groups for name in commands}
load_before, loads = os.getloadavg()[0], []
for _ in range(rounds):
    for _, _, commands in groups:
        for name, cmd in commands.items():
            samples[name].append(timed(cmd))
            loads.append(os.getloadavg()[0])
med = statistics.median
print(f"median of {rounds} alternating rounds, output interval (fixed communication step) T_mesh/20, stop 1 s;"
      f" load average (1 min) before: {load_before:.2f}, after each run: median {med(loads):.2f},"
      f" {min(loads):.2f} to {max(loads):.2f}:")
print(f"  {'':60}  {'wall':>8}  {'ratio':>6}  {'CPU':>8}  {'ratio':>6}  {'per round':>9}")
for system, h, commands in groups:
    print(f"{system} (h = {h:.4e} s):")
    base = next(iter(commands))
    bw, bc = med([w for w, _ in samples[base]]), med([c for _, c in samples[base]])
    for name in commands:
        w, c = med([w for w, _ in samples[name]]), med([c for _, c in samples[name]])
        per_round = med([s[1] / b[1] for s, b in zip(samples[name], samples[base])])
        print(f"  {name:60}  {w:7.3f}s  {w / bw:6.3f}  {c:7.3f}s  {c / bc:6.3f}  {per_round:9.3f}")
print(f"load average after: {os.getloadavg()[0]:.2f}")
EOF_PY
