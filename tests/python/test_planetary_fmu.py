"""The planetary stages as FMUs (issue 33, acceptance 6): each shipped planetary scene
(`examples/planetary/*.toml`, built here with `geardyn fmu build`: the nominal-speed form) and
the shipped co-simulation component `fmu/planetary_stage` (torque ports on the sun and the
carrier, the ring held, the rotation carried; built by scripts/build-fmus.sh) pass fmpy's
validation and, under fmpy and under libcosim, give the numbers of `geardyn simulate` on the
same grid (same step partition).

Tolerances as for the parallel stages (test_fmu_dte.py): every mesh's DTE identical to
<= 1e-12 of its largest value, the contact states equal; with ports the port speeds to 1e-12
relative. The native run is checked against the independent scipy model of the stage in
test_planetary_reference.py (acceptance 4).
"""

from __future__ import annotations

import tomllib

import fmpy
import fmpy.validation
import numpy as np
import pytest

from conftest import FMU_DIR, REPO, native_run, run_geardyn

H = 1e-5
STOP = 0.01
EXAMPLES = sorted((REPO / "examples" / "planetary").glob("*.toml"))
# The shipped scenes, and the 3-planet stage of the scipy oracle (test_planetary_reference.py)
# at its operating point, where the ring meshes lose contact: the contact changes through the
# FMU too (the shipped EV reducer is damped enough to keep its teeth in contact).
CONTACT_LOSS = "contact_loss_stage"
NAMES = [p.stem for p in EXAMPLES] + ["planetary_stage", CONTACT_LOSS]


@pytest.fixture(scope="module")
def scenes(tmp_path_factory):
    """name -> scene file."""
    from test_planetary_reference import scene_text

    out = tmp_path_factory.mktemp("planetary_scenes")
    paths = {p.stem: p for p in EXAMPLES}
    paths["planetary_stage"] = REPO / "fmu" / "planetary_stage" / "scene.toml"
    paths[CONTACT_LOSS] = out / f"{CONTACT_LOSS}.toml"
    paths[CONTACT_LOSS].write_text(scene_text().replace('name = "planetary_reference"', f'name = "{CONTACT_LOSS}"'))
    return paths


@pytest.fixture(scope="module")
def fmus(scenes, tmp_path_factory):
    """name -> FMU: the scenes built into a temporary folder, planetary_stage the shipped one."""
    out = tmp_path_factory.mktemp("planetary_fmus")
    built = {}
    for name, path in scenes.items():
        if name != "planetary_stage":
            run_geardyn("fmu", "build", path, "--out", out)
            built[name] = out / f"{name}.fmu"
    shipped = FMU_DIR / "planetary_stage.fmu"
    if not shipped.exists():
        pytest.fail(f"{shipped} missing: run `bash scripts/build-fmus.sh`")
    built["planetary_stage"] = shipped
    return built


def test_every_shipped_planetary_scene_is_covered():
    assert {p.stem for p in EXAMPLES} == {"lin_parker_1999", "ev_reducer_3p", "five_planet_stage"}


def columns(doc):
    """The compared columns: every mesh's DTE (continuous) and contact state (discrete); with
    ports the port speeds too."""
    meshes = [m["name"] for m in doc["mesh"]]
    cont = [f"{m}.dte" for m in meshes] + (["input.speed", "output.speed"] if "port" in doc else [])
    return cont, [f"{m}.contact_state" for m in meshes]


@pytest.fixture(scope="module")
def native(scenes, tmp_path_factory):
    """name -> (scene document, `geardyn simulate` of the scene on the grid H over STOP)."""
    out = tmp_path_factory.mktemp("planetary_native")
    return {n: (tomllib.loads(p.read_text()), native_run(p, out / f"{n}.csv", H, STOP)) for n, p in scenes.items()}


@pytest.mark.parametrize("name", NAMES)
def test_fmpy_validation_reports_no_problem(name, fmus, native, report):
    problems = fmpy.validation.validate_fmu(str(fmus[name]))
    assert problems == [], problems
    md = fmpy.read_model_description(str(fmus[name]))
    by = {v.name: v for v in md.modelVariables}
    doc = native[name][0]
    for m in doc["mesh"]:
        assert by[f"{m['name']}.dte"].causality == "output"
    if "port" in doc:
        for port in ("input", "output"):
            assert by[f"{port}.torque"].causality == "input"
            assert by[f"{port}.speed"].causality == "output"
    report(f"{name}.fmu: fmpy validate, no problem ({len(md.modelVariables)} variables)")


def _assert_identical(name, doc, got, native, report, host):
    cont, discrete = columns(doc)
    for c in cont:
        amp = np.abs(native[c]).max()
        err = np.abs(np.asarray(got[c]) - native[c]).max()
        report(f"{name} {host} vs simulate, h = {H}: {c} max|d| = {err:.3e} = {err / amp:.3e} of max")
        assert err <= 1e-12 * amp, (c, err / amp)
    for c in discrete:
        assert np.array_equal(got[c], native[c]), c


@pytest.mark.parametrize("name", NAMES)
def test_fmpy_matches_simulate(name, fmus, native, report):
    doc, n = native[name]
    cont, discrete = columns(doc)
    r = fmpy.simulate_fmu(str(fmus[name]), fmi_type="CoSimulation", output_interval=H, stop_time=STOP,
                          output=cont + discrete)
    assert len(r) == len(n)
    assert np.allclose(r["time"], n["time"], rtol=1e-15, atol=0)
    _assert_identical(name, doc, r, n, report, "fmpy")
    # The runs are not trivial: the stage vibrates (except Lin & Parker's example: constant
    # mean stiffness from its static state, which it keeps); the contact-loss stage loses
    # contact.
    dte = cont[0]
    moving = np.ptp(n[dte]) > 1e-3 * np.abs(n[dte]).max()
    assert moving == (name != "lin_parker_1999") and np.abs(n[dte]).min() > 0
    lost = sum(int((n[c] != 1).sum()) for c in discrete)
    report(f"{name}: {lost} rows with a mesh out of contact")
    assert (lost > 0) == (name == CONTACT_LOSS)


@pytest.mark.parametrize("name", NAMES)
def test_libcosim_matches_simulate(name, fmus, native, report):
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    log_output_level(CosimLogLevel.WARNING)
    doc, n = native[name]
    cont, _ = columns(doc)
    md = fmpy.read_model_description(str(fmus[name]))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    ex = CosimExecution.from_step_size(step_size=int(round(H * 1e9)))
    idx = ex.add_local_slave(CosimLocalSlave(fmu_path=str(fmus[name]), instance_name="stage"))
    obs = CosimObserver.create_last_value()
    ex.add_observer(observer=obs)
    steps = 400
    rows = []
    for _ in range(steps):
        assert ex.step()
        rows.append(obs.last_real_values(slave_index=idx, variable_references=[vr[c] for c in cont]))
    rows = np.array(rows)
    # libcosim keeps time in integer nanoseconds: its communication points are k·1e4 ns, the
    # same partition as the native grid.
    got = {c: rows[:, j] for j, c in enumerate(cont)}
    ref = {c: n[c][1 : steps + 1] for c in cont}
    for c in cont:
        amp = np.abs(n[c]).max()
        err = np.abs(got[c] - ref[c]).max()
        report(f"{name} libcosim vs simulate, h = {H}, {steps} steps: {c} max|d| = {err:.3e} = {err / amp:.3e} of max")
        assert err <= 1e-12 * amp, (c, err / amp)
