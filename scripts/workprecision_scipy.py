#!/usr/bin/env python3
"""scipy column of the work-precision benchmark (run by scripts/bench-workprecision.sh).

For every single-mesh problem of DIR/problems.csv (written by
`cargo bench --bench workprecision -- --write-problems DIR`) this runs the independent scipy
model of tests/python/gear_reference.py (written from docs/model.md: segment stops at every
stiffness breakpoint, terminal contact events, the state snapped onto the switching surface,
restart) with solve_ivp's DOP853, RK45 and Radau along the tolerance ladder, and the tight
reference runs (DOP853 at rtol 1e-13, and Radau at 1e-13 for the problems the exact
propagator does not cover). Tolerance mapping as in every harness:
rtol = tol, atol = tol · x_scale for both states.

Work: wall time = the median of the timed runs after the warm-up run (whose output is the one
compared), RHS evaluations (nfev, including Radau's finite-difference Jacobians), accepted
steps; solve_ivp does not report rejected steps (left empty). A rung whose run fails, or that
follows a rung slower than the time limit, is written as a failed row, never dropped.

Usage: workprecision_scipy.py DIR [--quick]   (writes DIR/scipy.csv)
"""
from __future__ import annotations

import csv
import sys
import statistics
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "python"))
import gear_reference as ref  # noqa: E402

METHODS = ["DOP853", "RK45", "Radau"]
REFERENCE_TOL = 1e-13
# A rung slower than this (s per run) ends the method's ladder on that problem.
SLOW = 30.0


def join(values) -> str:
    return ";".join(f"{v:.17e}" for v in values)


def run(scene, problem, method, tol, timed_runs, min_wall):
    rtol, atol = tol, tol * problem["x_scale"]
    grid = np.array([k * problem["stop_time"] / problem["samples"]
                     for k in range(problem["samples"])] + [problem["stop_time"]])
    kwargs = dict(output_times=grid, rtol=rtol, atol=np.array([atol, atol]), method=method,
                  check_grazing=False)
    t0 = time.perf_counter()
    result = ref.simulate(scene, problem["stop_time"], **kwargs)
    warmup = time.perf_counter() - t0
    times = []
    started = time.perf_counter()
    while warmup < 2.0 and (len(times) < timed_runs or time.perf_counter() - started < min_wall):
        t0 = time.perf_counter()
        ref.simulate(scene, problem["stop_time"], **kwargs)
        times.append(time.perf_counter() - t0)
    # A run over 2 s is timed once: the warm-up run is its time.
    best = statistics.median(times) if times else warmup
    runs = len(times)
    events = [t for t, _ in result.events]
    return [f"{tol:e}", f"{rtol:e}", f"{atol:e}", "ok", f"{best:e}", str(max(runs, 1)),
            str(result.nfev), str(result.steps), "", str(len(events)),
            f"{result.dte[-1]:.17e}", f"{result.dte_rate[-1]:.17e}", join(result.dte), join(events)]


def main() -> int:
    bench_dir = Path(sys.argv[1] if len(sys.argv) > 1 else "target/workprecision")
    quick = "--quick" in sys.argv[2:]
    timed_runs, min_wall = (0, 0.0) if quick else (2, 1.0)
    problems = [dict(r) for r in csv.DictReader(open(bench_dir / "problems.csv"))]
    header = ["problem", "method", "tol", "rtol", "atol", "status", "wall_s", "timed_runs", "rhs",
              "steps", "rejected", "events", "final_x", "final_v", "dte", "event_times"]
    rows = []
    for p in problems:
        if p["kind"] != "pair":
            continue
        p["stop_time"] = float(p["stop_time"])
        p["samples"] = int(p["samples"])
        p["x_scale"] = float(p["x_scale"])
        ladder = [float(v) for v in p["ladder"].split(";")]
        name = p["problem"]
        scene = ref.load_scene(bench_dir / "scenes" / f"{name}.toml")
        # The tight runs that make or check the reference: DOP853 always (it checks the exact
        # propagator where that applies), Radau only where no exact propagator exists.
        ref_methods = ["DOP853"] if p["exact_eligible"] == "true" else ["DOP853", "Radau"]
        jobs = [(f"scipy reference {m}", m, [REFERENCE_TOL]) for m in ref_methods]
        jobs += [(f"scipy {m}", m, ladder) for m in METHODS]
        for label, method, tols in jobs:
            too_slow = None
            for tol in tols:
                if too_slow is not None:
                    rows.append([name, label, f"{tol:e}", "", "", f"skipped: the rung tol "
                                 f"{too_slow:e} took more than {SLOW:g} s"] + [""] * 10)
                    continue
                t0 = time.perf_counter()
                try:
                    fields = run(scene, p, method, tol, 0 if "reference" in label else timed_runs,
                                 min_wall)
                except Exception as exc:  # recorded as a failed row, never dropped
                    message = str(exc).replace(",", ";").replace("\n", " ")
                    fields = [f"{tol:e}", "", "", f"failed: {message}"] + [""] * 10
                rows.append([name, label] + fields)
                spent = time.perf_counter() - t0
                print(f"scipy {name:16} {label:24} tol {tol:.0e}: {fields[3][:40]:8} "
                      f"{spent:7.2f} s", flush=True)
                if spent > SLOW:
                    too_slow = tol
    with open(bench_dir / "scipy.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        w.writerows(rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
