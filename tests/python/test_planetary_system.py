"""The SSP example of issue 33 (acceptance 6): examples/systems/planetary_drivetrain, an e-motor
driving the sun of the planetary stage fmu/planetary_stage (ring held), the carrier driving a
vehicle load, five geardyn FMUs: emotor → shaft_in → planetary_stage → shaft_out →
vehicle_load.

* The SSD binds the steady cruise point, recomputed here from the shipped scenes: Willis'
  speed ratio from the tooth counts, the load's resistance law, the motor's P controller, the
  shafts' pre-twist; the carrier's start angle is the stage FMU's own output at t = 0.
* `geardyn run` runs it over 0.05 s: it starts in the steady point, the
  mean speed ratio of the stage over the last 20 mesh periods is Willis' 1 + Z_r/Z_s, and the
  cruise holds.
* geardyn's master (Jacobi, zero-order hold) and libcosim (`CosimExecution.from_ssp_file`,
  the same algorithm) on the same SSD agree to rounding (1e-11 of each signal's largest value,
  as for the parallel drivetrain in test_drivetrain_cosim.py).
* The default coupling (Gauss-Seidel, linear extrapolation) converges to the monolithic native
  run of the same drivetrain (the same elements and start as one scene, docs/ports.md
  "Elements in the scene", written here from the shipped scenes and the SSD's bindings): the
  largest error of every signal falls with the communication step at an observed order ≥ 1.
"""

from __future__ import annotations

import contextlib
import math
import shutil
import tomllib
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from conftest import FMU_DIR, REPO, run_geardyn
from test_drivetrain_cosim import libcosim

SYSTEM = REPO / "examples" / "systems" / "planetary_drivetrain"
FMUS = ("emotor", "shaft_in", "planetary_stage", "shaft_out", "vehicle_load")
SSV = "{http://ssp-standard.org/SSP1/SystemStructureParameterValues}"
SSD = "{http://ssp-standard.org/SSP1/SystemStructureDescription}"
# (co-simulation column, monolithic column)
SIGNALS = [("gear.sp1.dte", "sp1.dte"), ("gear.rp1.dte", "rp1.dte"), ("gear.input.speed", "sun.speed"),
           ("gear.output.speed", "carrier.speed"), ("motor.flange.speed", "motor.speed"),
           ("load.flange.speed", "load.speed"), ("shaft1.shaft.torque", "shaft1.torque"),
           ("shaft2.shaft.torque", "shaft2.torque")]
COLS = [c for c, _ in SIGNALS]
CRUISE = 3000 * 2 * math.pi / 60  # rad/s at the sun


@pytest.fixture(scope="module")
def fmus(shipped_fmus):
    for f in FMUS:
        assert (FMU_DIR / f"{f}.fmu").exists(), f
    return FMU_DIR


def bindings():
    """The SSD's parameter values per component (name -> value)."""
    root = ET.parse(SYSTEM / "SystemStructure.ssd").getroot()
    out = {}
    for comp in root.iter(f"{SSD}Component"):
        out[comp.get("name")] = {p.get("name"): float(p.find(f"{SSV}Real").get("value"))
                                 for p in comp.iter(f"{SSV}Parameter")}
    return out


def scene(name):
    with open(REPO / "fmu" / name / "scene.toml", "rb") as fh:
        return tomllib.load(fh)


def teeth():
    z = {g["name"]: g["teeth"] for g in scene("planetary_stage")["gear"]}
    return z["sun"], z["ring"]


def willis():
    z_s, z_r = teeth()
    return 1 + z_r / z_s


def t_mesh():
    z_s, _ = teeth()
    return 2 * math.pi / (z_s * CRUISE * (1 - 1 / willis()))


def geardyn(out, h, stop, algorithm="gauss-seidel", extrapolation="linear", cols=COLS):
    r = run_geardyn("run", SYSTEM, "--out", out, "--stop-time", repr(stop), "--output-interval", repr(h),
                    "--algorithm", algorithm, "--extrapolation", extrapolation, "--outputs", ",".join(cols),
                    check=False)
    assert r.returncode == 0, r.stderr
    return np.genfromtxt(out, delimiter=",", names=True, deletechars="")


def test_the_ssd_binds_the_steady_cruise_point(fmus, tmp_path):
    b = bindings()
    w_s = CRUISE
    w_c = w_s / willis()
    t_s = b["gear"]["input.torque"]
    t_c = t_s * willis()
    m, sh1, sh2, ld = (scene(n)["element"] for n in ("emotor", "shaft_in", "shaft_out", "vehicle_load"))
    expected = {
        ("gear", "operating.input_speed"): w_s,
        ("gear", "output.torque"): -t_c,
        ("motor", "controller.ki"): 0.0,
        ("motor", "controller.speed_reference"): w_s + (t_s + m["damping"] * w_s) / m["controller"]["kp"],
        ("motor", "initial.speed"): w_s,
        ("motor", "initial.angle"): t_s / sh1["stiffness"],
        ("shaft1", "flange_a.angle"): t_s / sh1["stiffness"],
        ("shaft1", "flange_a.speed"): w_s,
        ("shaft1", "flange_b.angle"): 0.0,
        ("shaft1", "flange_b.speed"): w_s,
        ("shaft2", "flange_a.speed"): w_c,
        ("shaft2", "flange_b.speed"): w_c,
        ("load", "initial.speed"): w_c,
        ("load", "torque"): t_c - ld["viscous"] * w_c - ld["drag"] * w_c * w_c,
    }
    for (el, var), v in expected.items():
        assert b[el][var] == pytest.approx(v, rel=1e-14, abs=1e-300), (el, var)
    # The carrier's start angle: the stage FMU's output at t = 0 under the bound values.
    import fmpy  # noqa: F401  (initialized_slave needs it)
    from fmpy.fmi2 import FMU2Slave  # noqa: F401

    with slave_with_starts(fmus / "planetary_stage.fmu", tmp_path, b["gear"]) as (s, vr):
        theta_c0, w_c0 = s.getReal([vr["output.angle"], vr["output.speed"]])
    assert w_c0 == pytest.approx(w_c, rel=1e-15)
    assert b["shaft2"]["flange_a.angle"] == pytest.approx(theta_c0, rel=1e-14)
    for el, var in (("shaft2", "flange_b.angle"), ("load", "initial.angle")):
        assert b[el][var] == pytest.approx(theta_c0 - t_c / sh2["stiffness"], rel=1e-14), (el, var)
    assert 0 < t_s + m["damping"] * w_s < np.interp(w_s, m["curve"]["speed"], m["curve"]["torque"])


@contextlib.contextmanager
def slave_with_starts(fmu, tmp_path, starts):
    """An fmpy slave of `fmu` initialized with the start values `starts` (name -> value):
    yields (slave, value reference by name)."""
    import fmpy
    from fmpy.fmi2 import FMU2Slave

    md = fmpy.read_model_description(fmu)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unzip = fmpy.extract(fmu, unzipdir=tmp_path / "x")
    s = FMU2Slave(guid=md.guid, unzipDirectory=unzip, modelIdentifier=md.coSimulation.modelIdentifier,
                  instanceName="stage")
    s.instantiate()
    s.setupExperiment(startTime=0.0)
    s.setReal([vr[k] for k in starts], list(starts.values()))
    s.enterInitializationMode()
    s.exitInitializationMode()
    try:
        yield s, vr
    finally:
        s.terminate()
        s.freeInstance()
        shutil.rmtree(tmp_path / "x", ignore_errors=True)


def test_geardyn_run_runs_it(fmus, tmp_path, report):
    """0.05 s (44 mesh periods) at T_mesh/20: the steady start, Willis'
    ratio of the mean speeds over the last 20 mesh periods, the cruise kept."""
    h = t_mesh() / 20
    d = geardyn(tmp_path / "r.csv", h, 0.05, cols=COLS + ["gear.input.angle", "gear.output.angle"])
    assert d["time"][-1] == pytest.approx(0.05, rel=1e-12)
    b = bindings()
    t_s = b["gear"]["input.torque"]
    assert d["shaft1.shaft.torque"][0] == pytest.approx(t_s, rel=1e-12)
    assert d["shaft2.shaft.torque"][0] == pytest.approx(t_s * willis(), rel=1e-12)
    assert d["gear.input.speed"][0] / d["gear.output.speed"][0] == pytest.approx(willis(), rel=1e-15)
    # The last row on the grid (the master also writes the off-grid stop time) and the row 20
    # mesh periods before it.
    b_ = int(np.flatnonzero(np.abs(d["time"] / h - np.round(d["time"] / h)) < 1e-6)[-1])
    a = b_ - 20 * 20
    assert d["time"][b_] - d["time"][a] == pytest.approx(20 * t_mesh(), rel=1e-9)
    ratio = float((d["gear.input.angle"][b_] - d["gear.input.angle"][a])
                  / (d["gear.output.angle"][b_] - d["gear.output.angle"][a]))
    drift = abs(d["motor.flange.speed"] / CRUISE - 1).max()
    report(f"planetary_drivetrain, geardyn run 0.05 s at T_mesh/20: mean speed ratio sun/carrier over the last "
           f"20 mesh periods {ratio!r} (Willis {willis()!r}, {ratio / willis() - 1:.2e}); motor speed within "
           f"{drift:.2e} of 3000 rpm")
    assert abs(ratio / willis() - 1) <= 1e-5
    assert drift <= 5e-3
    # The mesh carries the load: the DTE stays positive and moves.
    assert d["gear.sp1.dte"].min() > 0 and np.ptp(d["gear.sp1.dte"]) > 0.05 * d["gear.sp1.dte"].mean()


def test_geardyn_jacobi_matches_libcosim(fmus, tmp_path, report):
    """Same SSD, same algorithm (Jacobi, zero-order hold): agreement to rounding."""
    folder = tmp_path / SYSTEM.name
    (folder / "resources").mkdir(parents=True)
    ssd = (SYSTEM / "SystemStructure.ssd").read_text()
    for f in FMUS:
        shutil.copy(FMU_DIR / f"{f}.fmu", folder / "resources" / f"{f}.fmu")
        assert f"../../../out/fmus/{f}.fmu" in ssd
        ssd = ssd.replace(f"../../../out/fmus/{f}.fmu", f"resources/{f}.fmu")
    (folder / "SystemStructure.ssd").write_text(ssd)
    h, n = 1e-5, 1000  # libcosim counts time in integer ns; 10 ms, 8.7 mesh periods
    ours = geardyn(tmp_path / "g.csv", h, n * h, "jacobi", "none")
    theirs = libcosim(folder, h, n, COLS)
    assert len(ours) == n + 1
    # Jacobi with a hold is stable at this step (at T_mesh/20 it diverges, as for the parallel
    # drivetrain, test_system_divergence.py): the comparison is of a meaningful run.
    assert abs(ours["gear.input.speed"] / CRUISE - 1).max() < 1e-2
    worst = 0.0
    for j, c in enumerate(COLS):
        diff = float(np.abs(ours[c][1:] - theirs[:, j]).max() / np.abs(theirs[:, j]).max())
        worst = max(worst, diff)
        assert diff <= 1e-11, (c, diff)
    gs = geardyn(tmp_path / "gs.csv", h, n * h, "gauss-seidel", "none")
    d_gs = np.abs(gs["gear.sp1.dte"][1:] - theirs[:, 0]).max() / np.abs(theirs[:, 0]).max()
    assert d_gs > 1e-4, d_gs
    report(f"planetary_drivetrain, geardyn Jacobi/hold vs libcosim fixed-step, h = {h}, {n} steps: "
           f"max |diff| / max|value| = {worst:.2e} over {len(COLS)} signals (Gauss-Seidel differs by {d_gs:.1e})")


def monolithic_scene():
    """The drivetrain as one native scene: the stage's scene without its ports, the elements of
    the shipped element scenes with the SSD's bindings, the start torques of the bindings."""
    b = bindings()
    text = (REPO / "fmu" / "planetary_stage" / "scene.toml").read_text()
    text = text[: text.index("[[port]]")]
    op = scene("planetary_stage")["operating"]
    old = f"input_speed = {op['input_speed']!r}"
    assert old in text
    text = text.replace(old, f"input_speed = {b['gear']['operating.input_speed']!r}\n"
                             f"input_torque = {b['gear']['input.torque']!r}\n"
                             f"load_torque = {-b['gear']['output.torque']!r}")
    m, sh1, sh2, ld = (scene(n)["element"] for n in ("emotor", "shaft_in", "shaft_out", "vehicle_load"))
    ripple = ", ".join(f"{{ order = {r['order']!r}, amplitude = {r['amplitude']!r}, phase = {r.get('phase', 0.0)!r} }}"
                       for r in m["ripple"])
    text += (f'\n[[motor]]\nname = "motor"\ninertia = {m["inertia"]!r}\ndamping = {m["damping"]!r}\n'
             f'curve = {{ speed = {m["curve"]["speed"]!r}, torque = {m["curve"]["torque"]!r} }}\n'
             f'controller = {{ kp = {m["controller"]["kp"]!r}, ki = {b["motor"]["controller.ki"]!r}, '
             f'speed_reference = {b["motor"]["controller.speed_reference"]!r} }}\nripple = [{ripple}]\n'
             f'\n[[load]]\nname = "load"\ninertia = {ld["inertia"]!r}\ntorque = {b["load"]["torque"]!r}\n'
             f'viscous = {ld["viscous"]!r}\ndrag = {ld["drag"]!r}\n')
    for name, gears, s in (("shaft1", '["motor", "sun"]', sh1), ("shaft2", '["carrier", "load"]', sh2)):
        text += (f'\n[[shaft]]\nname = "{name}"\ngears = {gears}\nstiffness = {s["stiffness"]!r}\n'
                 f'damping = {s["damping"]!r}\n')
    return text


def test_the_default_coupling_converges_to_the_monolithic_run(fmus, tmp_path, report):
    mono = tmp_path / "mono.toml"
    mono.write_text(monolithic_scene())
    stop = 0.01
    divisors = (40, 80, 160)
    errors = []
    for n in divisors:
        h = t_mesh() / n
        d = geardyn(tmp_path / "c.csv", h, stop)
        run_geardyn("simulate", mono, "--out", tmp_path / "n.csv", "--stop-time", repr(stop), "--output-interval",
                    repr(h), "--rtol", "1e-12", "--atol", "1e-18", "--quiet")
        r = np.genfromtxt(tmp_path / "n.csv", delimiter=",", names=True, deletechars="")
        d = d[: len(r)]  # the master also writes the off-grid stop time
        assert np.abs(r["time"] - d["time"]).max() <= 1e-12 * stop
        # Same start: the first rows agree to rounding.
        for c, k in SIGNALS:
            assert d[c][0] == pytest.approx(r[k][0], rel=1e-12), c
        errors.append({c: float(np.abs(d[c] - r[k]).max() / np.ptp(r[k])) for c, k in SIGNALS})
    for c, _ in SIGNALS:
        e = [x[c] for x in errors]
        orders = [math.log2(a / b) for a, b in zip(e, e[1:])]
        report(f"planetary_drivetrain GS/linear vs monolithic, {c}: max error / peak-to-peak at T_mesh/"
               f"{divisors} = " + ", ".join(f"{x:.3g}" for x in e) + "; orders " + ", ".join(f"{p:.2f}" for p in orders))
        assert all(p >= 1.0 for p in orders), (c, e)
        assert e[-1] <= 1e-2, (c, e)
