"""A per-point timeout (issue 35, "Any output": a point whose solve exceeds a per-point timeout
is recorded as failed with its reason).

`timeout=` (seconds of wall-clock time) on `simulate`, `periodic`, `sweep` and `hb`, and
`[analysis] timeout` in a study file. The solver looks at the clock every 1e7 work units (about
25 ms) and goes on exactly where it stopped, so a run that ends in time is bit-identical to one
without a timeout; the checks below use runs long enough (idler 0.5 s: about 1e8 work units)
that the clock is looked at several times.
"""

import math
import time

import numpy as np
import pytest

import geardyn
from geardyn import study as gs
from conftest import REPO

IDLER = REPO / "fmu" / "idler_gearset"


def long_idler(**solver):
    scene = geardyn.Scene.from_file(IDLER)
    scene.update({"solver.stop_time": 0.5, "solver.output_interval": 1e-4,
                  "solver.work_budget": 1e12, **solver})
    return scene


def same_statistics(a, b):
    """Per-mesh statistics equal bit for bit (NaN where a statistic has none equals NaN)."""
    assert len(a) == len(b)
    for x, y in zip(a, b):
        assert x.keys() == y.keys()
        for k in x:
            u, v = np.asarray(x[k]), np.asarray(y[k])
            if u.dtype.kind == "f":
                assert np.array_equal(u, v, equal_nan=True), k
            else:
                assert x[k] == y[k], k


@pytest.mark.parametrize("method", ["exact", "rk"])
def test_a_run_within_its_timeout_is_bit_identical(method):
    scene = long_idler(**{"solver.method": method})
    plain = geardyn.simulate(scene)
    timed = geardyn.simulate(scene, timeout=3600.0)
    assert np.array_equal(plain.data, timed.data)
    assert plain.stats == timed.stats
    same_statistics(plain.statistics, timed.statistics)


@pytest.mark.parametrize("method", ["exact", "rk"])
def test_a_run_past_its_timeout_stops_with_the_reason(method):
    scene = long_idler(**{"solver.stop_time": 50.0, "solver.method": method})
    start = time.perf_counter()
    with pytest.raises(geardyn.GeardynError, match=r"time limit of 0\.05 s was reached at t = "):
        geardyn.simulate(scene, timeout=0.05)
    # The whole run would take tens of seconds; it stops within a few checks of the clock
    # (a generous bound: the machine may be loaded).
    assert time.perf_counter() - start < 10.0


def test_analyses_take_a_timeout():
    scene = geardyn.Scene.from_file(IDLER)
    speed = geardyn.parse_speed(scene["operating.input_speed"]) if isinstance(
        scene["operating.input_speed"], str) else scene["operating.input_speed"]
    # Within the limit: the same numbers.
    a = geardyn.sweep(scene, f"{0.9 * speed}:{1.1 * speed}:5", "up")
    b = geardyn.sweep(scene, f"{0.9 * speed}:{1.1 * speed}:5", "up", timeout=3600.0)
    assert np.array_equal(a.data, b.data, equal_nan=True)
    o1, o2 = geardyn.periodic(scene), geardyn.periodic(scene, timeout=3600.0)
    assert np.array_equal(o1.y0, o2.y0) and o1.spectral_radius == o2.spectral_radius
    # Past it: the analysis fails with the limit's message (a sweep does not go on with rows
    # of NaN).
    with pytest.raises(geardyn.GeardynError, match="time limit of 0.001 s"):
        geardyn.sweep(scene, f"{0.5 * speed}:{1.5 * speed}:400", "both", timeout=1e-3)
    with pytest.raises(geardyn.GeardynError, match=r"time limit of 0\.000001 s"):
        geardyn.hb(scene, f"{0.5 * speed}:{1.5 * speed}", harmonics=10, timeout=1e-6)


@pytest.mark.parametrize("bad", [0.0, -1.0, math.inf, math.nan])
def test_a_bad_timeout_names_the_argument(bad):
    with pytest.raises(ValueError, match="timeout"):
        geardyn.simulate(geardyn.Scene.from_file(IDLER), timeout=bad)


def idler_study(tmp_path, stop_times, timeout):
    """A study of the idler over `solver.stop_time` (work budget raised: only the timeout
    stops a run) with `[analysis] timeout`."""
    path = tmp_path / "study.toml"
    path.write_text(f"""
scene = "{IDLER}"
results = ["dte_rms"]
[[parameter]]
path = "solver.stop_time"
values = {stop_times!r}
[[parameter]]
path = "solver.work_budget"
values = [1e12]
[analysis]
kind = "simulate"
timeout = {timeout!r}
""")
    return path


def test_a_study_point_over_its_timeout_is_recorded_as_failed(client, tmp_path):
    study = gs.load(idler_study(tmp_path, [0.005, 40.0], 0.5))
    summary = gs.run(study, client=client, progress=False)
    assert (summary.computed, summary.failed) == (2, 1)
    df = gs.results(study)
    short, long = df.iloc[0], df.iloc[1]
    # A drivetrain's results are per mesh: `<mesh>.dte_rms`.
    scene = geardyn.Scene.from_file(IDLER)
    scene.update({"solver.stop_time": 0.005, "solver.work_budget": 1e12})
    first = geardyn.simulate(scene).statistics[0]
    column = f"{first['name']}.dte_rms"
    assert not isinstance(short["error"], str) and math.isfinite(short[column])
    assert "time limit of 0.5 s was reached" in long["error"] and math.isnan(long[column])
    # The point that ended in time has the number of a run without a timeout.
    assert short[column] == first["dte_rms"]


def test_a_bad_study_timeout_names_the_field(tmp_path):
    with pytest.raises(gs.StudyError, match=r"analysis.timeout = -2"):
        gs.load(idler_study(tmp_path, [0.005], -2))
