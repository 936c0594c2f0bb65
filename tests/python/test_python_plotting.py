"""Plotting helpers return matplotlib figures with units on the axes (issue 35, "The whole CLI
in Python"), for spur_pair, idler_gearset and countershaft_gearset: a run's DTE over time, a
sweep, an hb branch and a spectrum. The drawn data are the results' own numbers."""

import numpy as np
import pytest

import geardyn
from conftest import REPO

matplotlib = pytest.importorskip("matplotlib")
from matplotlib.figure import Figure  # noqa: E402

SCENES = {"spur_pair": "400:420", "idler_gearset": "300:310", "countershaft_gearset": "240:242"}


@pytest.mark.parametrize("name", SCENES)
def test_figures_with_units(name, tmp_path):
    scene = geardyn.Scene.from_file(REPO / "fmu" / name)
    scene.update({"solver.stop_time": 5e-3})
    run = geardyn.simulate(scene)
    fig = run.plot()
    assert isinstance(fig, Figure)
    ax = fig.axes[0]
    assert ax.get_xlabel() == "time [s]" and ax.get_ylabel().endswith("[m]")
    dte = [n for n in run.names if n.endswith("dte")]
    assert [line.get_label() for line in ax.get_lines()] == dte
    np.testing.assert_array_equal(ax.get_lines()[0].get_ydata(), run[dte[0]])
    force = [n for n in run.names if n.endswith(".force")][:1]
    fig = run.plot(dte[:1] + force)
    assert [a.get_ylabel() for a in fig.axes] == [f"{dte[0]} [m]", f"{force[0]} [N]"]
    fig.savefig(tmp_path / "run.png")

    speeds = SCENES[name]
    sweep = geardyn.sweep(scene, f"{speeds}:3")
    y = "dte_rms" if "dte_rms" in sweep.columns else next(c for c in sweep.columns if c.endswith("dte_rms"))
    fig = sweep.plot(y)
    ax = fig.axes[0]
    assert ax.get_xlabel() == "speed [rad/s]" and ax.get_ylabel() == f"{y} [m]"
    up = ax.get_lines()[0]
    np.testing.assert_array_equal(up.get_ydata(), sweep[y][sweep["direction"] > 0])

    spectrum = geardyn.spectrum(scene)
    fig = spectrum.plot()
    ax = fig.axes[0]
    assert ax.get_xlabel() == "frequency [Hz]" and ax.get_ylabel().endswith("amplitude [m]")
    texts = {t.get_text() for t in ax.texts}
    assert texts and texts <= set(spectrum.labels)

    if name != "countershaft_gearset":  # its HB branch costs minutes (issue 38)
        hb = geardyn.hb(scene, speeds, 10)
        fig = hb.plot(y)
        assert fig.axes[0].get_ylabel() == f"{y} [m]"
    with pytest.raises(KeyError, match="no column 'nope'"):
        sweep.plot("nope")
