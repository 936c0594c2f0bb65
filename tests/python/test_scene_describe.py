"""Scenes that can be introspected (issue 35, "Any parameter"): ``scene.describe(path)`` gives
the value or the default, the unit, the bounds and a description, on spur_pair,
idler_gearset and countershaft_gearset.

The answers are checked against what the program does, not against the schema they come
from:

- **defaults**: a scene that writes each described default explicitly runs bit for bit as
  the scene that leaves the key out (the solver's own defaults decide the run);
- **bounds**: every number the scene writes that has declared bounds is refused, naming its
  path, one step outside them (the scene reader decides);
- **units**: the unit is the one `geardyn.unit` and the study stores give.
"""

import math

import numpy as np
import pytest

import geardyn
from conftest import REPO

SCENES = {
    "spur_pair": REPO / "fmu" / "spur_pair" / "scene.toml",
    "idler_gearset": REPO / "fmu" / "idler_gearset" / "scene.toml",
    "countershaft_gearset": REPO / "fmu" / "countershaft_gearset" / "scene.toml",
}

# Keys with a fixed default that the example scenes may leave out.
DEFAULTED = ["solver.method", "solver.rk_method", "solver.rtol", "solver.atol",
             "solver.exact_memory_mb", "initial.dte", "initial.dte_rate",
             "gear[0].ground_damping", "gear[1].ground_stiffness"]


@pytest.fixture(params=list(SCENES))
def scene(request):
    return geardyn.Scene.from_file(SCENES[request.param])


def test_values_defaults_units_and_descriptions(scene):
    atol = scene.describe("solver.atol")
    assert atol.default == 1e-15 and atol.bounds == "> 0" and atol.kind == "number"
    assert "tolerance" in atol.description
    if "solver.atol" not in scene:
        assert atol.is_default and atol.value == atol.default
    scene["solver.atol"] = 1e-14
    set_ = scene.describe("solver.atol")
    assert set_.value == 1e-14 and not set_.is_default and set_.default == 1e-15
    teeth = scene.describe("gear[0].teeth")
    assert teeth.value == scene["gear[0].teeth"] and teeth.kind == "integer" and teeth.required
    assert teeth.minimum == (1.0, True) and teeth.unit == "1"
    # Either spelling of the input speed, whichever the file wrote.
    written = "operating.pinion_speed" if "operating.pinion_speed" in scene else "operating.input_speed"
    speed = scene.describe("operating.pinion_speed")
    assert speed.value == scene[written] and speed.unit == "rad/s"
    assert speed.minimum == (0.0, True) and speed.maximum is None
    assert "speed" in speed.description.lower()
    # Every number the scene writes has a unit (or is a ratio, "1") and a description.
    for path in scene.paths():
        p = scene.describe(path)
        assert p.description, path
        # Without one unit: the RK tolerance on mixed states, the work budget (work units),
        # and a profile's values (the unit of the profile's quantity).
        if p.kind in ("number", "integer") and path not in ("solver.atol", "solver.work_budget") \
                and not path.startswith(("operating.speed_profile", "operating.torque_profile")):
            assert p.unit is not None, path
            assert p.unit == geardyn.unit(path), path
    # A choice lists its values.
    contact = scene.describe("mesh[0].contact" if scene.is_train else "mesh.contact")
    assert contact.choices == ["linear", "contact_loss", "backlash"]
    assert contact.value in contact.choices
    assert "Parameter(solver.atol: 1e-14 [" not in repr(set_)  # atol has no single unit
    assert repr(teeth).startswith("Parameter(gear[0].teeth: ")


def test_described_defaults_are_the_ones_the_solver_uses(scene):
    """Writing each described default explicitly leaves the run bit for bit the same."""
    scene["solver.stop_time"] = 2e-3
    explicit = scene.copy()
    written = []
    for path in DEFAULTED:
        p = scene.describe(path)
        if not p.is_default or p.default is None:
            continue
        explicit[path] = p.default
        written.append(path)
    assert {"solver.rtol", "solver.atol"} <= set(written), written
    a, b = geardyn.simulate(scene), geardyn.simulate(explicit)
    assert a.names == b.names
    for name in ["time", *a.names]:
        np.testing.assert_array_equal(a[name], b[name], err_msg=name)


def test_every_declared_bound_is_the_one_validation_applies(scene):
    """Each number the scene writes, one step outside its declared bounds, is refused with
    its path; the bounds the scene's own values sit in are never violated."""
    checked = 0
    for path in scene.paths():
        p = scene.describe(path)
        if p.kind not in ("number", "integer") or not p.bounds:
            continue
        assert _inside(p.value, p), (path, p.value, p.bounds)
        for outside in _outside(p):
            trial = scene.copy()
            with pytest.raises(geardyn.GeardynError) as e:
                trial[path] = outside
            # Validation names a pair's component as [x]/[y] where the path has [0]/[1].
            named = path.rsplit("[", 1)[0] if path.endswith("]") else path
            assert named in str(e.value), (path, outside, str(e.value))
            checked += 1
    assert checked >= 5, checked


def test_unknown_paths_are_named_with_the_keys_there(scene):
    with pytest.raises(geardyn.GeardynError, match=r"'solver' has no key 'atoll' \(keys: .*atol"):
        scene.describe("solver.atoll")
    with pytest.raises(geardyn.GeardynError, match="index 'a'"):
        scene.describe("gear[a].teeth")
    # Without a scene: the format's answer.
    assert geardyn.describe("solver.rtol").bounds == "> 0 and < 1"
    assert geardyn.describe("solver.rtol").value == 1e-9


def _inside(v, p):
    lo, hi = p.minimum, p.maximum
    ok_lo = lo is None or v > lo[0] or (lo[1] and v == lo[0])
    ok_hi = hi is None or v < hi[0] or (hi[1] and v == hi[0])
    return ok_lo and ok_hi


def _outside(p):
    out = []
    for end, sign in ((p.minimum, -1.0), (p.maximum, 1.0)):
        if end is None:
            continue
        value, inclusive = end
        if p.kind == "integer":
            out.append(int(value) + int(sign))
        elif inclusive:
            out.append(value + sign * max(abs(value) * 1e-6, 1e-12))
        else:
            out.append(value)
    assert all(math.isfinite(x) for x in out)
    return out
