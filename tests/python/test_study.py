"""Studies on a Dask LocalCluster with 2 worker processes (geardyn.study, docs/python.md).

The reference for every study result is the same point run serially through the plain API
(`Scene.update` + `geardyn.simulate`) with the result computed here from the time series.
"""

import os
import pathlib
import signal

import numpy as np
import pandas as pd
import pytest

import geardyn
from geardyn import study as gs
from conftest import REPO

SPUR = REPO / "fmu" / "spur_pair"


def write_study(tmp_path, body, name="study.toml"):
    path = tmp_path / name
    path.write_text(f'scene = "{SPUR}"\n' + body)
    return path


def serial(point, solver):
    """One point through the plain API: DTE RMS (mean removed) and peak |mesh force| of the
    run's statistics (from the continuous solution, as `geardyn simulate` prints them)."""
    scene = geardyn.Scene.from_file(SPUR)
    scene.update({**solver, **point})
    mesh = geardyn.simulate(scene).statistics[0]
    return mesh["dte_rms"], mesh["peak_force"]


def assert_exactly_once(study):
    df = gs.stored(study.store)
    assert df["key"].is_unique, "a point is stored twice"
    assert sorted(df["index"]) == list(range(len(study.points()))), "a point is missing"
    return df


GRID = """
results = ["dte_rms", "peak_force"]
[[parameter]]
path = "operating.pinion_speed"
from = 350.0
to = 500.0
points = 4
[[parameter]]
path = "mesh.damping_ratio"
values = [0.03, 0.08]
[analysis]
kind = "simulate"
"""


def test_grid_matches_the_points_run_serially(client, tmp_path):
    # 3 points per task: the last task holds the 2 left over.
    study = gs.load(write_study(tmp_path, "chunk = 3\n" + GRID))
    summary = gs.run(study, client=client, progress=False)
    assert (summary.total, summary.computed, summary.failed) == (8, 8, 0)
    df = gs.results(study)
    assert_exactly_once(study)
    for row, point in zip(df.itertuples(), study.points()):
        assert {p: getattr(row, "_" + str(3 + i)) for i, p in enumerate(point)} == point
        rms, peak = serial(point, {})
        assert row.dte_rms == rms and row.peak_force == peak
    # A 2-parameter grid is the product of the values, speed outermost.
    assert sorted(set(df["operating.pinion_speed"])) == [350.0, 400.0, 450.0, 500.0]


def test_seeded_lhs_is_bit_identical_to_serial_and_failures_are_recorded(client, tmp_path):
    body = """
seed = 11
results = ["dte_rms", "peak_force"]
[sampling]
method = "lhs"
samples = 6
[[parameter]]
path = "mesh.stiffness.mean"
distribution = "uniform"
low = -1.0e8
high = 4.0e8
[analysis]
kind = "simulate"
"""
    study = gs.load(write_study(tmp_path, body))
    points = study.points()
    assert points == gs.load(study.path).points(), "the seed alone fixes the points"
    gs.run(study, client=client, progress=False)
    df = gs.results(study)
    assert_exactly_once(study)
    failed = df[df["error"].notna()]
    for row, point in zip(df.itertuples(), points):
        if point["mesh.stiffness.mean"] > 0:
            assert pd.isna(row.error)
            assert (row.dte_rms, row.peak_force) == serial(point, {})
    # The lowest of the 6 strata of U(-1e8, 4e8) is negative: that point fails, recorded.
    assert len(failed) == 1
    for row in failed.itertuples():
        assert "mesh.stiffness.mean" in row.error and "must be" in row.error
        assert np.isnan(row.dte_rms)


SLOW = """
chunk = 1
results = ["dte_rms"]
[[parameter]]
path = "operating.pinion_speed"
from = 300.0
to = 520.0
points = 24
[analysis]
kind = "simulate"
"""


def slow_study(tmp_path, name):
    """24 points of ~0.1 s: the RK path over 0.2 s, set in a copy of the scene the study
    names (the study varies numbers; the base scene carries the fixed settings)."""
    scene = geardyn.Scene.from_file(SPUR)
    scene.update({"solver.method": "rk", "solver.stop_time": 0.2})
    (tmp_path / "scene.toml").write_text(scene.to_toml())
    path = tmp_path / name
    path.write_text('scene = "scene.toml"\n' + SLOW)
    return gs.load(path)


def test_a_worker_killed_midway_loses_no_point(client, tmp_path):
    study = slow_study(tmp_path, "kill.toml")
    pids = sorted(client.run(os.getpid).values())
    assert len(pids) == 2
    killed = []

    def kill_one(record):
        if not killed:
            killed.append(pids[0])
            os.kill(pids[0], signal.SIGKILL)

    summary = gs.run(study, client=client, progress=False, on_result=kill_one)
    assert killed and summary.failed == 0
    df = assert_exactly_once(study)
    assert df["error"].isna().all()
    client.wait_for_workers(2, timeout=60)
    assert pids[0] not in client.run(os.getpid).values(), "the worker was not killed"


def test_rerun_after_an_interrupt_computes_only_the_missing_points(client, tmp_path):
    study = slow_study(tmp_path, "interrupt.toml")
    arrived = []

    def interrupt(record):
        arrived.append(record["key"])
        if len(arrived) == 5:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        gs.run(study, client=client, progress=False, on_result=interrupt)
    before = gs.stored_keys(study.store)
    assert set(arrived) == before, "everything that arrived is stored"
    total = len(study.points())
    assert 5 <= len(before) < total
    computed = []
    summary = gs.run(study, client=client, progress=False, on_result=lambda r: computed.append(r["key"]))
    assert summary.already == len(before)
    assert summary.computed == len(computed) == total - len(before)
    assert not set(computed) & before
    assert_exactly_once(study)


def test_study_errors_name_the_field(tmp_path):
    bad = GRID.replace('kind = "simulate"', 'kind = "simulate"\nspeed = 3.0')
    with pytest.raises(gs.StudyError, match=r"analysis.speed: not an option of simulate"):
        gs.load(write_study(tmp_path, bad))
    with pytest.raises(gs.StudyError, match=r"results: 'floquet_max' is not a result of simulate"):
        gs.load(write_study(tmp_path, GRID.replace('"peak_force"', '"floquet_max"')))
    mc = 'results = ["dte_rms"]\n[sampling]\nmethod = "monte_carlo"\nsamples = 4\n'
    with pytest.raises(gs.StudyError, match=r"seed = None: monte_carlo needs a seed"):
        gs.load(write_study(tmp_path, mc + '[[parameter]]\npath = "mesh.damping_ratio"\n'
                            'distribution = "uniform"\nlow = 0.01\nhigh = 0.1\n[analysis]\nkind = "simulate"\n'))
    with pytest.raises(gs.StudyError, match=r"mesh.stiffnes"):
        gs.load(write_study(tmp_path, GRID.replace("mesh.damping_ratio", "mesh.stiffnes")))


def test_the_documented_example_is_a_valid_study():
    study = gs.load(REPO / "examples" / "study_spur.toml")
    assert len(study.points()) == 69 and study.kind == "simulate"


def test_periodic_and_sweep_studies_match_serial(client, tmp_path):
    def over_damping(results, analysis):
        return (f"results = {results}\n[[parameter]]\npath = \"mesh.damping_ratio\"\n"
                f"values = [0.03, 0.06]\n[analysis]\n{analysis}\n")

    periodic = over_damping('["floquet_max", "stable", "period"]', 'kind = "periodic"\nspeed = 430.0')
    study = gs.load(write_study(tmp_path, periodic, "periodic.toml"))
    gs.run(study, client=client, progress=False)
    for row, point in zip(gs.results(study).itertuples(), study.points()):
        scene = geardyn.Scene.from_file(SPUR)
        scene.update({**point, "operating.pinion_speed": 430.0})
        orbit = geardyn.periodic(scene)
        assert (row.floquet_max, row.stable, row.period) == (
            orbit.spectral_radius, float(orbit.stability == "Stable"), orbit.period)
    sweep = over_damping('["peak_dte_rms", "peak_mesh_frequency", "hysteresis"]',
                         'kind = "sweep"\nspeed = "400:480:5"')
    study = gs.load(write_study(tmp_path, sweep, "sweep.toml"))
    gs.run(study, client=client, progress=False)
    for row, point in zip(gs.results(study).itertuples(), study.points()):
        scene = geardyn.Scene.from_file(SPUR)
        scene.update(point)
        table = geardyn.sweep(scene, "400:480:5")
        rms = table["dte_rms"]
        up, down = rms[table["direction"] > 0], rms[table["direction"] < 0]
        # Both branches list the same speeds (down in reverse order).
        assert row.peak_dte_rms == rms.max()
        assert row.peak_mesh_frequency == table["mesh_frequency"][np.argmax(rms)]
        assert row.hysteresis == np.abs(up - down[::-1]).max()


def test_console_script_on_an_existing_scheduler_with_plots(client, tmp_path):
    """`geardyn-study run --scheduler ADDRESS` uses the running cluster (and leaves it up);
    `--plot` draws the response surface of the 2-parameter grid, `plot` a Monte Carlo
    histogram."""
    import subprocess
    import sys

    script = pathlib.Path(sys.executable).parent / "geardyn-study"
    path = write_study(tmp_path, GRID)
    p = subprocess.run([script, "run", path, "--scheduler", client.scheduler.address,
                        "--no-progress", "--plot", tmp_path / "surface.png"],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    assert "8 points, 0 already stored, 8 computed" in p.stdout
    assert "dte_rms" in p.stdout and (tmp_path / "surface.png").stat().st_size > 10_000
    assert len(client.nthreads()) == 2, "the cluster is still up"
    mc = write_study(tmp_path, 'seed = 3\nresults = ["dte_rms"]\n'
                     'sampling = { method = "monte_carlo", samples = 6 }\n'
                     'parameter = [{ path = "mesh.damping_ratio", distribution = "lognormal", '
                     'median = 0.05, sigma = 0.3 }]\nanalysis = { kind = "simulate" }\n', "mc.toml")
    gs.run(mc, client=client, progress=False)
    p = subprocess.run([script, "plot", mc, "--out", tmp_path / "hist.png"],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    assert (tmp_path / "hist.png").stat().st_size > 5_000
    bad = subprocess.run([script, "run", write_study(tmp_path, GRID.replace("simulate", "nope"), "bad.toml")],
                         capture_output=True, text=True, timeout=120)
    assert bad.returncode == 1
    assert bad.stderr == "error: analysis.kind = 'nope': must be one of simulate, periodic, sweep, hb, modes, spectrum\n"
