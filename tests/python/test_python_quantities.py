"""Scene values with units (issue 35, "Any parameter"): `"4500rpm"`, `("150", "N*m")` and pint
Quantities are converted to the scene format's unit for the path, on spur_pair,
idler_gearset and countershaft_gearset; a unit of the wrong dimension, or a unit on a
parameter that has none, is refused naming the path; a study's grid may be written with
units and stores SI values."""

import math

import numpy as np
import pytest

import geardyn
from geardyn import study as gs
from conftest import REPO

pint = pytest.importorskip("pint")
UREG = pint.UnitRegistry()

SCENES = ["spur_pair", "idler_gearset", "countershaft_gearset"]


def speed_path(scene):
    return "operating.input_speed" if "input_speed" in scene.to_dict()["operating"] else "operating.pinion_speed"


@pytest.mark.parametrize("name", SCENES)
def test_quantities_become_the_scene_units(name):
    scene = geardyn.Scene.from_file(REPO / "fmu" / name)
    scene.update({"solver.stop_time": 2e-3})
    speed = speed_path(scene)
    rpm = scene.copy()
    rpm[speed] = "4500rpm"
    assert rpm[speed] == 4500 * 2 * math.pi / 60 == geardyn.parse_speed("4500rpm")
    plain = scene.copy()
    plain[speed] = geardyn.parse_speed("4500rpm")
    a, b = geardyn.simulate(rpm), geardyn.simulate(plain)
    assert np.array_equal(a.data, b.data)  # the same double: the same run, bit for bit

    torque = scene.copy()
    torque["operating.input_torque"] = ("0.15", "kN*m")
    assert torque["operating.input_torque"] == pytest.approx(150.0, rel=1e-15)
    torque["operating.input_torque"] = UREG.Quantity(110.6, "ft*lbf")
    assert torque["operating.input_torque"] == pytest.approx(149.95, rel=1e-3)
    inertia = scene.copy()
    inertia.update({"gear[0].inertia": ("2", "g*m**2")})
    assert inertia["gear[0].inertia"] == pytest.approx(2e-3, rel=1e-15)

    for path, value, needle in [
        ("operating.input_torque", ("150", "m"), "Cannot convert"),
        ("operating.input_torque", "fast", "not defined"),
        ("gear[0].name", UREG.Quantity(1, "m"), "has no unit"),
    ]:
        before = scene.to_toml()
        with pytest.raises(geardyn.GeardynError, match=needle) as e:
            scene[path] = value
        assert f"'{path}'" in str(e.value)
        assert scene.to_toml() == before  # refused: the scene is unchanged


def test_a_grid_with_units_stores_si_values(client, tmp_path):
    path = tmp_path / "study.toml"
    path.write_text(f"""
scene = "{REPO / 'fmu' / 'spur_pair'}"
results = ["dte_rms"]
[[parameter]]
path = "operating.pinion_speed"
values = ["4000rpm", "4500rpm"]
[[parameter]]
path = "mesh.backlash"
values = ["100 um", "0.2 mm"]
[analysis]
kind = "simulate"
""")
    study = gs.load(path)
    speeds = [p.values for p in study.parameters][0]
    assert speeds == [geardyn.parse_speed("4000rpm"), geardyn.parse_speed("4500rpm")]
    assert [p.values for p in study.parameters][1] == pytest.approx([1e-4, 2e-4], rel=1e-15)
    gs.run(study, client=client, progress=False)
    ds = gs.to_xarray(study)
    assert ds["operating.pinion_speed"].attrs["units"] == "rad/s"
    assert ds["operating.pinion_speed"].values.tolist() == speeds
    bad = tmp_path / "bad.toml"
    bad.write_text(path.read_text().replace('"100 um"', '"100 N"'))
    with pytest.raises(gs.StudyError, match=r"parameter\[1\].values: .*'mesh.backlash'"):
        gs.load(bad)
