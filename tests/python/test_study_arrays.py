"""Per-point arrays of a study in Zarr (issue 35, "Any output"): a run's traces, a spectrum's
lines and arrays returned by a user output are stored per point and come back in the study's
Dataset over its dimensions, equal to the same points run through the plain API, with units;
arrays of different lengths are padded with NaN to the longest, whatever the order the
points finish in; a rerun computes nothing and keeps them."""

import numpy as np
import pytest

import geardyn
from geardyn import study as gs
from conftest import REPO

pytest.importorskip("zarr")
xr = pytest.importorskip("xarray")


def write(tmp_path, name, body):
    path = tmp_path / f"{name}.toml"
    path.write_text(body)
    return path


def first_forces(run):
    return run["mesh.force"][:10]


def test_traces_and_array_outputs(client, tmp_path):
    path = write(tmp_path, "traces", f"""
scene = "{REPO / 'fmu' / 'spur_pair'}"
results = ["dte_rms"]
[[parameter]]
path = "operating.pinion_speed"
values = [350.0, 450.0]
[[parameter]]
path = "solver.stop_time"
values = [0.01]
[analysis]
kind = "simulate"
arrays = ["time", "mesh.dte"]
""")
    study = gs.load(path, outputs={"first_forces": (first_forces, "N")})
    gs.run(study, client=client, progress=False)
    assert gs.arrays_store(study).is_dir()
    ds = gs.to_xarray(study)
    assert ds["mesh.dte"].dims == ("operating.pinion_speed", "solver.stop_time", "mesh.dte_sample")
    assert ds["mesh.dte"].attrs["units"] == "m" and ds["time"].attrs["units"] == "s"
    assert ds["first_forces"].attrs["units"] == "N"
    for i, speed in enumerate([350.0, 450.0]):
        scene = geardyn.Scene.from_file(REPO / "fmu" / "spur_pair")
        scene.update({"operating.pinion_speed": speed, "solver.stop_time": 0.01})
        run = geardyn.simulate(scene)
        np.testing.assert_array_equal(ds["mesh.dte"].values[i, 0], run["mesh.dte"])
        np.testing.assert_array_equal(ds["time"].values[i, 0], run.time)
        np.testing.assert_array_equal(ds["first_forces"].values[i, 0], first_forces(run))
        assert ds["dte_rms"].values[i, 0] == run.statistics[0]["dte_rms"]
    back = xr.open_zarr(gs.to_zarr(study, tmp_path / "all.zarr")).load()
    np.testing.assert_array_equal(back["mesh.dte"].values, ds["mesh.dte"].values)
    assert back["mesh.dte"].attrs["units"] == "m"
    again = gs.run(study, client=client, progress=False)
    assert again.computed == 0
    np.testing.assert_array_equal(gs.to_xarray(study)["mesh.dte"].values, ds["mesh.dte"].values)


def test_spectrum_lines_per_point_and_ragged_arrays(client, tmp_path):
    path = write(tmp_path, "lines", f"""
scene = "{REPO / 'fmu' / 'idler_gearset'}"
results = ["mesh_order_1"]
[[parameter]]
path = "operating.input_torque"
values = [80.0, 120.0]
[analysis]
kind = "spectrum"
arrays = ["frequency_Hz", "mesh2.dte_amplitude_m"]
""")
    study = gs.load(path)
    gs.run(study, client=client, progress=False)
    ds = gs.to_xarray(study)
    for i, torque in enumerate([80.0, 120.0]):
        scene = geardyn.Scene.from_file(REPO / "fmu" / "idler_gearset")
        scene["operating.input_torque"] = torque
        spectrum = geardyn.spectrum(scene)
        np.testing.assert_array_equal(ds["mesh2.dte_amplitude_m"].values[i], spectrum["mesh2.dte_amplitude_m"])
        np.testing.assert_array_equal(ds["frequency_Hz"].values[i], spectrum["frequency_Hz"])
    assert ds["mesh2.dte_amplitude_m"].attrs["units"] == "m"
    assert ds["frequency_Hz"].attrs["units"] == "Hz"

    ragged = write(tmp_path, "ragged", f"""
scene = "{REPO / 'fmu' / 'spur_pair'}"
results = ["dte_rms"]
[[parameter]]
path = "solver.stop_time"
values = [0.002, 0.004]
[analysis]
kind = "simulate"
arrays = ["mesh.dte"]
""")
    study = gs.load(ragged)
    gs.run(study, client=client, progress=False)
    assert gs.results(study)["error"].isna().all()
    ds = gs.to_xarray(study)
    for i, stop in enumerate([0.002, 0.004]):
        scene = geardyn.Scene.from_file(REPO / "fmu" / "spur_pair")
        scene["solver.stop_time"] = stop
        dte = geardyn.simulate(scene)["mesh.dte"]
        row = ds["mesh.dte"].values[i]
        np.testing.assert_array_equal(row[:dte.size], dte)
        assert np.isnan(row[dte.size:]).all() and row.size == ds.sizes["mesh.dte_sample"]
    bad = write(tmp_path, "bad", ragged.read_text().replace('"mesh.dte"', '"mesh.nope"'))
    study = gs.load(bad)
    gs.run(study, client=client, progress=False)
    assert "'mesh.nope' is not a column of the simulate result" in gs.results(study)["error"][0]
