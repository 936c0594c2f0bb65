#!/usr/bin/env python3
"""What an input polynomial of each order can do for the error-controlled master (issue 32
acceptance 2; the table of docs/cosimulation.md "The floor of a linear input").

The coupling torques the master exchanges are the drivetrain's shaft torques (the five-FMU
system's shaft FMUs; the three-FMU system's speed-port couplings have the same stiffness and
damping). This script takes them from the monolithic native run (`geardyn simulate
examples/drivetrain_monolithic.toml` moved to the point by drivetrain_reference.SteadyPoint,
rtol 1e-12, sampled 20 times per communication step), and measures, for every communication
step of h = T_mesh/n (a step starting at every sample), the largest distance over the step
between the torque and the polynomial a consumer would be given from exact data:

* ``tangent``: y(t) + s·y'(t), what `--extrapolation linear` gives over a cut connection;
* ``predicted chord``: y(t) + s·(y'(t) + h·c/2), c = (y'(t) − y'(t−h))/h, the error-controlled
  master's extrapolation (src/host/system/controlled.rs);
* ``chord``: the line from y(t) to y(t+h), the interpolation of a producer that stepped first;
  the best linear input there is with the end values known;
* ``quadratic``: through y(t), y'(t), y(t+h) (input derivatives of order 2);
* ``cubic``: the cubic Hermite interpolant through y, y' at both ends (order 3).

Printed per step size: that distance relative to `--tolerance` times the torque's largest
magnitude (what the master's estimate compares with 1): median, 90th and 99th percentile, and
the share of steps that estimate would accept (≤ 1). Not a test.

Usage (builds nothing; needs target/release/geardyn):
  .venv/bin/python scripts/cosim_input_defects.py --points 4500,3000 --divisors 20,40 --tolerance 1e-4
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests" / "python"))
import drivetrain_reference as dr  # noqa: E402

GEARDYN = Path(os.environ.get("GEARDYN_BIN", REPO / "target" / "release" / "geardyn"))
SUB = 20  # samples per communication step


def torques(rpm: float, n: int, stop: float, tmp: Path):
    """Time step dt and the shaft torques sampled at T_mesh/(n·SUB)."""
    point = dr.SteadyPoint(rpm, 10.0)
    scene = tmp / f"m{rpm:g}.toml"
    scene.write_text(point.monolithic_scene((REPO / "examples" / "drivetrain_monolithic.toml").read_text()))
    dt = point.t_mesh / (n * SUB)
    out = tmp / f"m{rpm:g}_{n}.csv"
    subprocess.run([str(GEARDYN), "simulate", str(scene), "--out", str(out), "--stop-time", repr(stop),
                    "--output-interval", repr(dt), "--rtol", "1e-12", "--atol", "1e-18", "--work-budget", "1e12",
                    "--quiet"], check=True)
    d = np.genfromtxt(out, delimiter=",", names=True, deletechars="")
    return dt, {k: d[k] for k in ("shaft1.torque", "shaft2.torque")}


def defects(y: np.ndarray, dt: float):
    """Per method: the largest distance over each step of SUB samples."""
    h = SUB * dt
    d = np.gradient(y, dt, edge_order=2)
    s = np.arange(SUB + 1) * dt
    u = s / h
    h00, h10, h01, h11 = 2 * u**3 - 3 * u**2 + 1, u**3 - 2 * u**2 + u, -2 * u**3 + 3 * u**2, u**3 - u**2
    out = {k: [] for k in ("tangent", "predicted chord", "chord", "quadratic", "cubic")}
    for i in range(SUB, len(y) - SUB):
        seg = y[i:i + SUB + 1]
        y0, d0, y1, d1 = y[i], d[i], y[i + SUB], d[i + SUB]
        c = (d0 - d[i - SUB]) / h
        a = (y1 - y0 - h * d0) / h**2
        lines = {
            "tangent": y0 + s * d0,
            "predicted chord": y0 + s * (d0 + 0.5 * h * c),
            "chord": y0 + s * (y1 - y0) / h,
            "quadratic": y0 + s * d0 + a * s * s,
            "cubic": h00 * y0 + h10 * h * d0 + h01 * y1 + h11 * h * d1,
        }
        for k, p in lines.items():
            out[k].append(np.abs(seg - p).max())
    return {k: np.array(v) for k, v in out.items()}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--points", default="4500,3000", help="pinion speeds, rpm")
    ap.add_argument("--divisors", default="20,40", help="h = T_mesh/n")
    ap.add_argument("--tolerance", type=float, default=1e-4)
    ap.add_argument("--stop", type=float, default=0.01)
    a = ap.parse_args()
    print("| rpm | torque | h | input | median | 90 % | 99 % | steps accepted |")
    print("|---|---|---|---|---:|---:|---:|---:|")
    with tempfile.TemporaryDirectory() as t:
        for rpm in map(float, a.points.split(",")):
            for n in map(int, a.divisors.split(",")):
                dt, ys = torques(rpm, n, a.stop, Path(t))
                for name, y in ys.items():
                    scale = a.tolerance * np.abs(y).max()
                    for k, v in defects(y, dt).items():
                        r = v / scale
                        print(f"| {rpm:g} | {name} | T_mesh/{n} | {k} | {np.median(r):.2f} | {np.percentile(r, 90):.2f}"
                              f" | {np.percentile(r, 99):.1f} | {np.mean(r <= 1):.0%} |", flush=True)


if __name__ == "__main__":
    main()
