#!/usr/bin/env python3
"""The error-controlled master against the monolithic drivetrain (issue 32 acceptance 1; the
tables of docs/cosimulation.md "The error-controlled master").

For each case (system, rpm) and tolerance: `geardyn run SYSTEM --tolerance TOL` on the grid
h = T_mesh/20 over STOP seconds, against the monolithic native run of the same drivetrain at
the same point (`geardyn simulate examples/drivetrain_monolithic.toml` moved there by
drivetrain_reference.SteadyPoint, rtol 1e-12, same grid). Printed per run: the DTE's max error
over its RMS (the whole run), the largest relative error of the motor (pinion side) and load
speeds, the pinion angle's error at the end (the drift), the steps accepted and undone, and
the CPU time of the co-simulation and of the monolithic run at its default tolerances.

Usage (build the FMUs first: bash scripts/build-fmus.sh):
  .venv/bin/python scripts/cosim_tolerance.py --stop 1 --tolerances 1e-2,1e-3,1e-4,1e-5
  .venv/bin/python scripts/cosim_tolerance.py --cases 3:4500 --tolerances 1e-4 --no-correction
  .venv/bin/python scripts/cosim_tolerance.py --grid 5 --stop 0.02   (the tolerance, not the grid, decides)
Not a test: the bound is asserted in tests/python/test_cosim_tolerance.py.
"""
from __future__ import annotations

import argparse
import os
import re
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests" / "python"))
import drivetrain_reference as dr  # noqa: E402

GEARDYN = Path(os.environ.get("GEARDYN_BIN", REPO / "target" / "release" / "geardyn"))
MONOLITHIC = REPO / "examples" / "drivetrain_monolithic.toml"
SYSTEMS = {"3": REPO / "examples" / "systems" / "drivetrain3", "5": REPO / "examples" / "systems" / "drivetrain"}
# The speed each system ships at (its SSD's bindings); other speeds get --start overrides.
SHIPPED_RPM = {"3": 4500.0, "5": 3000.0}


def cpu_run(args):
    """Runs geardyn; (CompletedProcess, CPU seconds of the child)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    p = subprocess.run([str(GEARDYN), *map(str, args)], capture_output=True, text=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return p, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def monolithic(point, tmp: Path, h: float, stop: float):
    scene = tmp / f"monolithic_{point.rpm:g}.toml"
    scene.write_text(point.monolithic_scene(MONOLITHIC.read_text()))
    out = tmp / f"m_{point.rpm:g}.csv"
    p, _ = cpu_run(["simulate", scene, "--out", out, "--stop-time", repr(stop), "--output-interval", repr(h),
                    "--rtol", "1e-12", "--atol", "1e-18", "--work-budget", "1e12", "--quiet"])
    assert p.returncode == 0, p.stderr
    p, cpu = cpu_run(["simulate", scene, "--out", tmp / "m_default.csv", "--stop-time", repr(stop),
                      "--output-interval", repr(h), "--quiet"])
    assert p.returncode == 0, p.stderr
    return np.genfromtxt(out, delimiter=",", names=True, deletechars=""), cpu


def controlled(system: str, point, tmp: Path, h: float, stop: float, tol: float, extra=()):
    """The co-simulation at `tol`: (rows, stderr, CPU s)."""
    starts = [] if point.rpm == SHIPPED_RPM[system] else [
        a for k, v in point.bindings().items() for a in ("--start", f"{k}={v!r}")]
    out = tmp / f"c_{system}.csv"
    p, cpu = cpu_run(["run", SYSTEMS[system], "--out", out, "--stop-time", repr(stop), "--output-interval", repr(h),
                      "--outputs", "gear.mesh1.dte,gear.pinion.angle", "--tolerance", repr(tol), *starts, *extra])
    assert p.returncode == 0, p.stderr
    return np.genfromtxt(out, delimiter=",", names=True, deletechars=""), p.stderr, cpu


def errors(d, r):
    """DTE max error / DTE RMS, largest relative speed error (motor, load), end angle error."""
    assert len(d) == len(r) and np.abs(d["time"] - r["time"]).max() <= 1e-12 * r["time"][-1]
    dte = float(np.abs(d["gear.mesh1.dte"] - r["mesh1.dte"]).max() / np.sqrt(np.mean(r["mesh1.dte"] ** 2)))
    speed = max(float(np.abs(d[c] - r[k]).max() / np.abs(r[k]).max())
                for c, k in (("motor.flange.speed", "motor.speed"), ("load.flange.speed", "load.speed")))
    drift = float(d["gear.pinion.angle"][-1] - r["pinion.angle"][-1])
    return dte, speed, drift


def steps(stderr: str):
    m = re.search(r"(\d+) steps accepted, (\d+) undone", stderr)
    return (int(m.group(1)), int(m.group(2))) if m else (0, 0)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", default="3:4500,5:3000,5:4500", help="SYSTEM:RPM, SYSTEM 3 or 5 FMUs")
    ap.add_argument("--tolerances", default="1e-2,1e-3,1e-4,1e-5")
    ap.add_argument("--stop", type=float, default=1.0)
    ap.add_argument("--no-correction", action="store_true", help="pass --no-impulse-correction")
    ap.add_argument("--no-switch-steps", action="store_true", help="pass --no-switch-steps")
    ap.add_argument("--grid", type=int, default=20, help="output interval (largest step) T_mesh/GRID")
    a = ap.parse_args()
    extra = ["--no-impulse-correction"] if a.no_correction else []
    extra += ["--no-switch-steps"] if a.no_switch_steps else []
    print("| system | rpm | tolerance | DTE max error / RMS | speeds, max rel. error | pinion angle error at end (rad)"
          " | steps accepted / undone | CPU (s) | monolithic CPU (s) |")
    print("|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as t:
        tmp = Path(t)
        for case in a.cases.split(","):
            system, rpm = case.split(":")
            point = dr.SteadyPoint(float(rpm), 10.0)
            h = point.t_mesh / a.grid
            r, mono_cpu = monolithic(point, tmp, h, a.stop)
            for tol in map(float, a.tolerances.split(",")):
                d, err, cpu = controlled(system, point, tmp, h, a.stop, tol, extra)
                dte, speed, drift = errors(d, r)
                acc, und = steps(err)
                print(f"| {system} | {float(rpm):g} | {tol:g} | {dte:.3g} | {speed:.3g} | {drift:.3g} | {acc} / {und}"
                      f" | {cpu:.2f} | {mono_cpu:.2f} |", flush=True)


if __name__ == "__main__":
    main()
