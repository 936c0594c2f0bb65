"""Study results with units, as xarray, through Parquet and Zarr (issue 35, acceptance 1 and 4).

- Every unit geardyn writes is one pint reads: the scene parameters' (`geardyn.unit(path)`),
  the output columns' and the study results'.
- A 2-D grid study on `spur_pair` (speed × damping ratio) becomes a Dataset whose dimensions
  are the two parameters, with the numbers of the same points run one by one through the
  plain API, and with units on every variable and coordinate.
- The units round-trip: read back from the Parquet store's field metadata (a new reader,
  pyarrow alone) and from a Zarr store (xarray.open_zarr), and the study plot's axes carry
  them.
- A Latin hypercube study lies along `point`, and a user output declares its unit.
"""

import numpy as np
import pytest

import geardyn
from geardyn import study as gs
from conftest import REPO

pint = pytest.importorskip("pint")
UREG = pint.UnitRegistry()

SPUR = REPO / "fmu" / "spur_pair"
GRID = f"""
scene = "{SPUR}"
results = ["dte_rms", "peak_force", "dynamic_factor"]
[[parameter]]
path = "operating.pinion_speed"
values = [350.0, 400.0, 450.0]
[[parameter]]
path = "mesh.damping_ratio"
values = [0.03, 0.08]
[analysis]
kind = "simulate"
"""


def test_every_unit_is_one_pint_reads():
    for kind, results in gs.RESULTS.items():
        for name in results:
            UREG.Unit(gs.result_unit(kind, name))  # raises on a unit pint does not know
    for path, unit in [("operating.pinion_speed", "rad/s"), ("operating.input_torque", "N.m"),
                       ("gear[0].teeth", "1"), ("gear[1].inertia", "kg.m^2"),
                       ("shaft[0].stiffness", "N.m/rad"), ("mesh.pressure_angle", "degree"),
                       ("mesh.stiffness.mean", "N/m"), ("mesh.damping", "N.s/m")]:
        assert geardyn.unit(path) == unit, path
        UREG.Unit(unit)
    assert UREG.Quantity(1, geardyn.unit("gear[1].inertia")).to("kg*m**2").magnitude == 1
    assert UREG.Quantity(1, geardyn.unit("operating.input_torque")).to("N*m").magnitude == 1
    scene = geardyn.Scene.from_file(SPUR)
    scene.update({"solver.stop_time": 2e-3})
    run = geardyn.simulate(scene)
    for name, unit in run.units.items():
        assert unit is not None, name
        UREG.Unit(unit)
    UREG.Unit(geardyn.unit("pinion.acceleration"))


def serial(point):
    scene = geardyn.Scene.from_file(SPUR)
    scene.update(point)
    return geardyn.simulate(scene).statistics[0]


def test_a_2d_grid_is_a_dataset_with_units_through_parquet_and_zarr(client, tmp_path):
    import pyarrow.parquet as pq
    import xarray as xr

    path = tmp_path / "grid.toml"
    path.write_text(GRID)
    study = gs.load(path)
    gs.run(study, client=client, progress=False)

    ds = gs.to_xarray(study)
    assert ds["dte_rms"].dims == ("operating.pinion_speed", "mesh.damping_ratio")
    assert ds["dte_rms"].shape == (3, 2)
    for i, speed in enumerate([350.0, 400.0, 450.0]):
        for j, zeta in enumerate([0.03, 0.08]):
            mesh = serial({"operating.pinion_speed": speed, "mesh.damping_ratio": zeta})
            assert ds["dte_rms"].values[i, j] == mesh["dte_rms"]
            assert ds["peak_force"].values[i, j] == mesh["peak_force"]
            assert ds["error"].values[i, j] == ""
    assert ds["dte_rms"].attrs["units"] == "m"
    assert ds["peak_force"].attrs["units"] == "N"
    assert ds["dynamic_factor"].attrs["units"] == "1"
    assert ds["operating.pinion_speed"].attrs["units"] == "rad/s"
    assert ds["mesh.damping_ratio"].attrs["units"] == "1"
    assert "mesh force" in ds["peak_force"].attrs["long_name"]

    # Parquet: a reader that knows nothing of geardyn finds the units in the field metadata.
    [part] = sorted(study.store.glob("part-*.parquet"))[:1]
    schema = pq.read_schema(part)
    assert schema.field("dte_rms").metadata[b"unit"] == b"m"
    assert schema.field("operating.pinion_speed").metadata[b"unit"] == b"rad/s"
    assert gs.results(study).attrs["units"]["peak_force"] == "N"

    # Zarr: written and read back, values and units unchanged.
    pytest.importorskip("zarr")
    back = xr.open_zarr(gs.to_zarr(study, tmp_path / "grid.zarr")).load()
    for name in ["dte_rms", "peak_force", "dynamic_factor", "operating.pinion_speed",
                 "mesh.damping_ratio"]:
        assert back[name].attrs.get("units") == ds[name].attrs.get("units"), name
        np.testing.assert_array_equal(back[name].values, ds[name].values)
    quantity = UREG.Quantity(back["peak_force"].values, back["peak_force"].attrs["units"])
    assert quantity.to("kN").magnitude[0, 0] == pytest.approx(ds["peak_force"].values[0, 0] / 1e3)

    # The plot's axes name the units.
    import matplotlib

    matplotlib.use("Agg")
    out = gs.plot(study, tmp_path / "grid.png")
    assert out.is_file()
    ax_labels = _plot_labels(study)
    assert "operating.pinion_speed [rad/s]" in ax_labels
    assert "dte_rms [m]" in ax_labels


def _plot_labels(study):
    """The axis and colour-bar labels of the study plot (drawn again, figure kept)."""
    import matplotlib.pyplot as plt

    before = set(plt.get_fignums())
    original = plt.close
    plt.close = lambda *a, **k: None
    try:
        gs.plot(study, study.path.parent / "again.png")
    finally:
        plt.close = original
    [num] = set(plt.get_fignums()) - before
    fig = plt.figure(num)
    labels = set()
    for ax in fig.axes:
        labels.update({ax.get_xlabel(), ax.get_ylabel()})
    plt.close(fig)
    return labels


def dte_p2p_um(run):
    return float(np.ptp(run["mesh.dte"]) * 1e6)


def test_a_latin_hypercube_lies_along_point_and_outputs_declare_units(client, tmp_path):
    path = tmp_path / "lhs.toml"
    path.write_text(f"""
scene = "{SPUR}"
seed = 7
results = ["dte_rms"]
[sampling]
method = "lhs"
samples = 4
[[parameter]]
path = "operating.pinion_speed"
distribution = "uniform"
low = 350.0
high = 450.0
[analysis]
kind = "simulate"
""")
    study = gs.load(path, outputs={"dte_p2p": (dte_p2p_um, "um")})
    gs.run(study, client=client, progress=False)
    ds = gs.to_xarray(study)
    assert ds["dte_rms"].dims == ("point",)
    assert ds["dte_p2p"].attrs["units"] == "um"
    assert ds["operating.pinion_speed"].attrs["units"] == "rad/s"
    for k, point in enumerate(study.points()):
        assert ds["operating.pinion_speed"].values[k] == point["operating.pinion_speed"]
        scene = geardyn.Scene.from_file(SPUR)
        scene.update(point)
        run = geardyn.simulate(scene)
        assert ds["dte_rms"].values[k] == run.statistics[0]["dte_rms"]
        assert ds["dte_p2p"].values[k] == dte_p2p_um(run)
    with pytest.raises(gs.StudyError, match="unit"):
        gs.load(path, outputs={"bad": (dte_p2p_um, "")})
