#!/usr/bin/env python3
"""scipy column of the spur_pair benchmark (run by scripts/bench.sh after `cargo bench`).

Times the independent Python reference (tests/python/gear_reference.py: solve_ivp DOP853 with
segment stops and terminal contact events, restarted at every stop/event) on the very scene
files the Rust benchmark wrote, at the same tolerances as the RK rows (rtol 1e-9, atol 1e-15),
and prints ns per mesh period next to geardyn's numbers from the benchmark's CSV.

Usage: bench_scipy.py BENCH_DIR   (BENCH_DIR holds spur_pair.csv and scenes/*.toml)
"""
from __future__ import annotations

import csv
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "python"))
import gear_reference as ref  # noqa: E402

RTOL = 1e-9
ATOL = 1e-15
SIM_TIME = 0.02  # s per run (57 mesh periods at 4500 rpm): scipy is slow
REPS = 2


def main() -> int:
    bench_dir = Path(sys.argv[1] if len(sys.argv) > 1 else "target/bench")
    rows = list(csv.DictReader(open(bench_dir / "spur_pair.csv")))
    rust = {(r["case"], r["method"], float(r["grid_s"])): float(r["ns_per_period"]) for r in rows}
    cases = list(dict.fromkeys(r["case"] for r in rows))
    grids = sorted({float(r["grid_s"]) for r in rows})

    print(f"scipy reference: solve_ivp DOP853 rtol {RTOL:g}, atol {ATOL:g}, restarted at every "
          f"stiffness stop and contact event; {SIM_TIME} s per run, best of {REPS}")
    print(f"{'scene':10} {'grid':>7} {'scipy ns/period':>16} {'/ geardyn dop853':>17} "
          f"{'/ geardyn exact':>16} {'events/period':>14}")
    for case in cases:
        scene = ref.load_scene(bench_dir / "scenes" / f"{case}.toml")
        periods = SIM_TIME * scene.mesh_frequency
        for grid in grids:
            n = int(round(SIM_TIME / grid))
            times = np.arange(n + 1) * grid
            times[-1] = SIM_TIME
            best = float("inf")
            for _ in range(REPS):
                t0 = time.perf_counter()
                result = ref.simulate(scene, SIM_TIME, output_times=times, rtol=RTOL,
                                      atol=np.array([ATOL, ATOL]))
                best = min(best, time.perf_counter() - t0)
            ns = best * 1e9 / periods
            print(f"{case:10} {grid * 1e6:5.0f}µs {ns:16.0f} "
                  f"{ns / rust[(case, 'dop853 1e-9', grid)]:16.0f}x "
                  f"{ns / rust[(case, 'exact', grid)]:15.0f}x "
                  f"{len(result.events) / periods:14.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
