#!/usr/bin/env python3
"""Where the co-simulated drivetrain's DTE error comes from (issue 18 acceptance 2; the tables
of docs/cosimulation.md "Where the DTE error comes from").

Every measurement is against the monolithic native run of the same drivetrain at the same
operating point (`geardyn simulate examples/drivetrain_monolithic.toml` moved to the point,
rtol 1e-12: the oracle, itself checked against the scipy model drivetrain_reference.py). A
point is RPM:T_0, the pinion speed and the load's constant torque (the vehicle_load `torque`
key: rolling resistance plus any grade); its steady start is
drivetrain_reference.SteadyPoint, given to the system as `--start` overrides of the SSD's
bindings. The shipped system is 3000:10 (cruise), the rattling case 4500:10.

* ``sweep``: the five-FMU system (`geardyn run examples/systems/drivetrain`), every coupling,
  h = T_mesh/n: the max DTE error relative to the DTE's RMS about its mean and to its plain
  RMS, the RMS error relative to the RMS, the contact-loss fraction, the shaft torque errors.
* ``stage``: the spur_stage FMU alone under fmpy, fed the monolithic run's own shaft torques,
  each either "coarse" (over every step h the straight line through its exact values at t and
  t + h: the best any first-order coupling can do) or "fine" (the same on h/16 sub-steps), or
  both extrapolated from t with exact first (and second) derivatives: which coupled torque
  drives the DTE error, and what first- and second-order input derivatives could reach.
* ``order``: Gauss-Seidel/linear with the shipped element order against the reversed one.

Usage (build the FMUs first: bash scripts/build-fmus.sh):
  .venv/bin/python scripts/cosim_dte_error.py sweep --points 3000:10,4500:10 --divisors 10,20,40,80
  .venv/bin/python scripts/cosim_dte_error.py stage --points 3000:10,4500:10 --divisors 10,20,40
  .venv/bin/python scripts/cosim_dte_error.py order --points 3000:10,4500:10 --divisors 10,20,40
Not a test: the assertions are in tests/python/test_drivetrain_cosim.py.
"""
from __future__ import annotations

import argparse
import math
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "tests" / "python"))
import drivetrain_reference as dr  # noqa: E402  (the steady start of a point, from the scenes)

GEARDYN = REPO / "target" / "release" / "geardyn"
SYSTEM = REPO / "examples" / "systems" / "drivetrain"
MONOLITHIC = REPO / "examples" / "drivetrain_monolithic.toml"
COUPLINGS = [("gauss-seidel", "none", "GS hold"), ("gauss-seidel", "linear", "GS linear"),
             ("jacobi", "none", "Jacobi hold"), ("jacobi", "linear", "Jacobi linear")]


class Point(dr.SteadyPoint):
    """A steady operating point: pinion speed (rpm) and the load's constant torque T_0."""

    def label(self):
        return f"{self.rpm:g} rpm, T_0 {self.t0:g} N.m (pinion {self.t_pinion:.1f} N.m)"

    def starts(self):
        """`--start` overrides: the SSD's bindings recomputed for this point."""
        return [a for k, x in self.bindings().items() for a in ("--start", f"{k}={x!r}")]

    def scene(self, path: Path):
        """The monolithic scene at this point."""
        path.write_text(self.monolithic_scene(MONOLITHIC.read_text()))


def run(*args):
    r = subprocess.run([str(GEARDYN), *map(str, args)], capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"geardyn {' '.join(map(str, args[:2]))} failed:\n{r.stderr}")


def native(point: Point, tmp: Path, h: float, stop: float):
    point.scene(tmp / "mono.toml")
    run("simulate", tmp / "mono.toml", "--out", tmp / "n.csv", "--stop-time", repr(stop),
        "--output-interval", repr(h), "--rtol", "1e-12", "--atol", "1e-18", "--quiet")
    return np.genfromtxt(tmp / "n.csv", delimiter=",", names=True, deletechars="")


def cosim(point: Point, tmp: Path, h: float, stop: float, alg: str, ex: str, system: Path = SYSTEM):
    run("run", system, "--out", tmp / "c.csv", "--stop-time", repr(stop), "--output-interval", repr(h),
        "--algorithm", alg, "--extrapolation", ex, "--outputs", "gear.mesh1.dte,shaft1.shaft.torque,shaft2.shaft.torque",
        *point.starts())
    return np.genfromtxt(tmp / "c.csv", delimiter=",", names=True, deletechars="")


def dte_measures(r):
    dte = r["mesh1.dte"]
    return (float(np.sqrt(np.mean((dte - dte.mean()) ** 2))), float(np.sqrt(np.mean(dte ** 2))),
            float(np.mean(r["mesh1.contact_state"] != 1.0)))


def orders(e):
    return ", ".join(f"{math.log2(a / b):.2f}" for a, b in zip(e, e[1:]))


def sweep(points, divisors, stop):
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        for p in points:
            r0 = native(p, tmp, p.t_mesh / 200, stop)
            ac, rms, loss = dte_measures(r0)
            print(f"\n{p.label()}: DTE mean {r0['mesh1.dte'].mean():.3e} m, RMS about the mean {ac:.3e} m, "
                  f"RMS {rms:.3e} m, contact lost {100 * loss:.1f} % of {stop * 1e3:g} ms")
            for alg, ex, label in COUPLINGS:
                rows = []
                for n in divisors:
                    h = p.t_mesh / n
                    r, c = native(p, tmp, h, stop), cosim(p, tmp, h, stop, alg, ex)
                    assert abs(r["time"][-1] - c["time"][-1]) < 1e-12
                    err = c["gear.mesh1.dte"] - r["mesh1.dte"]
                    rows.append((float(np.abs(err).max()),
                                 float(np.abs(c["shaft1.shaft.torque"] - r["shaft1.torque"]).max()),
                                 float(np.abs(c["shaft2.shaft.torque"] - r["shaft2.torque"]).max()),
                                 float(np.sqrt(np.mean(err ** 2)))))
                e = [x[0] for x in rows]
                print(f"  {label:13} n = {divisors}: DTE err / RMS about mean "
                      + ", ".join(f"{x / ac:.3g}" for x in e) + " | / RMS " + ", ".join(f"{x / rms:.3g}" for x in e)
                      + " | RMS err / RMS " + ", ".join(f"{x[3] / rms:.3g}" for x in rows)
                      + f" | orders {orders(e)} | tau1 err " + ", ".join(f"{x[1]:.2g}" for x in rows)
                      + " | tau2 err " + ", ".join(f"{x[2]:.2g}" for x in rows))


def stage(points, divisors, stop, m=16):
    import fmpy
    from fmpy.fmi2 import FMU2Slave

    fmu = REPO / "out" / "fmus" / "spur_stage.fmu"
    md = fmpy.read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unzipdir = fmpy.extract(str(fmu))
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        for p in points:
            print(f"\n{p.label()}: stage FMU alone, fed the monolithic shaft torques")
            for n in divisors:
                h = p.t_mesh / n
                r = native(p, tmp, h / m, stop)
                ac, rms, _ = dte_measures(r)
                tau = {"input.torque": r["shaft1.torque"], "output.torque": -r["shaft2.torque"]}
                res = {}
                # the exact torques' right derivatives at t (one-sided differences on the h/m
                # grid: the acceleration jumps at the stiffness knots, central ones smear them)
                der = {}
                for name, x in tau.items():
                    dt = h / m
                    d1 = np.empty_like(x); d2 = np.zeros_like(x)
                    d1[:-2] = (-3 * x[:-2] + 4 * x[1:-1] - x[2:]) / (2 * dt)
                    d1[-2:] = (x[-1] - x[-2]) / dt
                    d2[:-2] = (x[:-2] - 2 * x[1:-1] + x[2:]) / dt ** 2
                    der[name] = (d1, d2)
                for coarse in ((), ("input.torque",), ("output.torque",), ("input.torque", "output.torque"), "taylor1", "taylor2"):
                    s = FMU2Slave(guid=md.guid, unzipDirectory=unzipdir, modelIdentifier=md.coSimulation.modelIdentifier,
                                  instanceName="stage")
                    s.instantiate()
                    s.setReal([vr["operating.input_speed"]], [p.omega])
                    s.setReal([vr["input.torque"], vr["output.torque"]], [tau["input.torque"][0], tau["output.torque"][0]])
                    s.setupExperiment(startTime=0.0)
                    s.enterInitializationMode()
                    s.exitInitializationMode()
                    dte = [s.getReal([vr["mesh1.dte"]])[0]]
                    steps = (len(r["time"]) - 1) // m
                    for k in range(steps):
                        for j in range(m):
                            i = k * m + j
                            vals, rates = [], []
                            for name, x in tau.items():
                                if isinstance(coarse, str):  # extrapolation from t with exact derivatives
                                    d1, d2 = der[name][0][k * m], der[name][1][k * m]
                                    if coarse == "taylor1":
                                        d2 = 0.0
                                    sj = j * h / m
                                    vals.append(x[k * m] + d1 * sj + 0.5 * d2 * sj * sj)
                                    slope = d1 + d2 * (sj + 0.5 * h / m)
                                elif name in coarse:
                                    slope = (x[(k + 1) * m] - x[k * m]) / h
                                    vals.append(x[k * m] + slope * j * h / m)
                                else:
                                    slope = (x[i + 1] - x[i]) / (h / m)
                                    vals.append(x[i])
                                rates.append(slope)
                            s.setReal([vr["input.torque"], vr["output.torque"]], vals)
                            s.setRealInputDerivatives([vr["input.torque"], vr["output.torque"]], [1, 1], rates)
                            s.doStep(currentCommunicationPoint=r["time"][i], communicationStepSize=h / m)
                        dte.append(s.getReal([vr["mesh1.dte"]])[0])
                    s.terminate()
                    s.freeInstance()
                    ref = r["mesh1.dte"][: steps * m + 1: m]
                    res[coarse] = float(np.abs(np.array(dte) - ref).max()) / ac
                print(f"  n = {n} (RMS / RMS about mean = {rms / ac:.3g}): max DTE err / RMS about mean: both fine {res[()]:.3g}, tau1 coarse {res[('input.torque',)]:.3g}, "
                      f"tau2 coarse {res[('output.torque',)]:.3g}, both coarse {res[('input.torque', 'output.torque')]:.3g}; "
                      f"both extrapolated from t with exact derivatives: order 1 {res['taylor1']:.3g}, order 2 {res['taylor2']:.3g}")


def reversed_order_system(tmp: Path) -> Path:
    """The SSD with its elements in reverse document order: the master's Gauss-Seidel order
    (docs/systems.md: depth-first from the last element) becomes motor, shaft1, gear, shaft2,
    load instead of load, shaft2, gear, shaft1, motor; the gear stage then takes the input
    shaft's torque interpolated and the output shaft's extrapolated (the cut connection)."""
    text = (SYSTEM / "SystemStructure.ssd").read_text()
    blocks = re.findall(r"( *<ssd:Component name=.*?</ssd:Component>\n)", text, flags=re.S)
    start, end = text.index(blocks[0]), text.index(blocks[-1]) + len(blocks[-1])
    text = text[:start] + "".join(reversed(blocks)) + text[end:]
    fmus = os.path.relpath(REPO / "out" / "fmus", tmp / "reversed")
    text = text.replace("../../../out/fmus", fmus)
    (tmp / "reversed").mkdir()
    (tmp / "reversed" / "SystemStructure.ssd").write_text(text)
    return tmp / "reversed"


def order(points, divisors, stop):
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        system = reversed_order_system(tmp)
        for p in points:
            print(f"\n{p.label()}: Gauss-Seidel/linear, shipped order against the reversed one")
            for n in divisors:
                h = p.t_mesh / n
                r = native(p, tmp, h, stop)
                rms = float(np.sqrt(np.mean(r["mesh1.dte"] ** 2)))
                line = []
                for label, sysdir in (("shipped", SYSTEM), ("reversed", system)):
                    err = cosim(p, tmp, h, stop, "gauss-seidel", "linear", sysdir)["gear.mesh1.dte"] - r["mesh1.dte"]
                    line.append(f"{label}: max DTE err / RMS {np.abs(err).max() / rms:.3g}, "
                                f"RMS err / RMS {np.sqrt(np.mean(err ** 2)) / rms:.3g}")
                print(f"  n = {n}: " + "; ".join(line))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("what", choices=["sweep", "stage", "order"])
    ap.add_argument("--points", default="4500:10", help="RPM:T0 pairs, comma separated (shipped: 4500:10)")
    ap.add_argument("--divisors", default="10,20,40,80", help="h = T_mesh/n for these n")
    ap.add_argument("--stop", type=float, default=5e-3)
    a = ap.parse_args()
    points = [Point(*map(float, x.split(":"))) for x in a.points.split(",")]
    divisors = tuple(int(x) for x in a.divisors.split(","))
    {"sweep": sweep, "stage": stage, "order": order}[a.what](points, divisors, a.stop)


if __name__ == "__main__":
    main()
