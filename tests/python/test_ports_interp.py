"""Input derivatives of the spur_stage FMU's torque ports (canInterpolateInputs, issue 18
point 3; docs/ports.md): after fmi2SetRealInputDerivatives the port torques follow
u + u'·(t − tc) over the next step, then are u + u'·h with rate 0.

Oracles, none computed by the code under test:
* the independent scipy model `ports_reference.py` (DOP853 rtol 1e-12, events) with the torque
  ramp T(t) = T + T'·t in its right-hand side, and with the held torque for the FMU without
  derivatives (the FMU is built from the shipped scene with rtol 1e-12, atol 1e-18);
* the rigid-body closed form: the mesh force cannot change J1ω1 + (r1/r2)J2ω2, which grows
  by ∫(T_in + (r1/r2)T_out)dt, a quadratic in t for a ramp;
* the FMU's own replay from a saved state (bit for bit), for the rates in the FMU state.

Each test runs on two FMUs: the shipped stage (DOP853: its STE makes it non-LTI with the
rotation carried) and the stage without its STE with `method = "exact"` (the exact propagator
with the ramp as a lifted coordinate; docs/ports.md, "What stays piecewise-LTI").
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest

import ports_reference as pr
from conftest import initialized_slave, REPO, run_geardyn

SCENE = REPO / "fmu" / "spur_stage" / "scene.toml"
H = 5e-4  # one communication step, 1.4 mesh periods at 4500 rpm
RATE_IN, RATE_OUT = 2.0e5, -1.5e5  # N·m/s: +100 N·m and −75 N·m over the step
DTE_TOL = 1e-9  # of the static deflection
SPEED_TOL = 1e-9  # rad/s


@pytest.fixture(scope="module", params=["shipped", "exact"])
def stage(request, geardyn_bin, tmp_path_factory):
    """The FMU and the scene file it was built from."""
    d = tmp_path_factory.mktemp("stage")
    scene = d / "spur_stage"
    scene.mkdir()
    text = SCENE.read_text()
    if request.param == "exact":
        text = text.replace("[mesh.ste]\ncos = [1.0e-6]\n", "")
        text = text.replace('method = "auto"', 'method = "exact"')
        assert "[mesh.ste]" not in text and 'method = "exact"' in text
    (scene / "scene.toml").write_text(text + "rtol = 1e-12\natol = 1e-18\n")
    run_geardyn("fmu", "build", scene, "--out", d / "out")
    return d / "out" / "spur_stage.fmu", scene / "scene.toml"


@pytest.fixture(scope="module")
def fmu(stage):
    return stage[0]


@pytest.fixture()
def slave(fmu, tmp_path):
    with initialized_slave(fmu, tmp_path) as s:
        yield s


def read(s, vr, names):
    return dict(zip(names, s.getReal([vr[n] for n in names])))


OUT = ["mesh1.dte", "pinion.speed", "gear.speed", "input.torque", "output.torque"]


def reference(rates, scene):
    sc = pr.load(scene)
    sc.rate_in, sc.rate_out = rates
    r = pr.simulate(sc, H, [H])
    return r, abs(pr.f_ext(sc) / sc.base.stiffness.mean)


def errors(got, r, scale):
    dte = abs(got["mesh1.dte"] - r["dte"][0]) / scale
    speed = max(abs(got["pinion.speed"] - r["pinion.speed"][0]),
                abs(got["gear.speed"] - r["gear.speed"][0]))
    return dte, speed


def test_capability_declared_only_where_ports_take_torques(slave):
    _, _, md = slave
    assert md.coSimulation.canInterpolateInputs
    # The other gear FMUs keep holding their inputs.
    for xml in (REPO / "modelDescription").glob("*.xml"):
        cs = ET.parse(xml).getroot().find("CoSimulation")
        has_ports = ET.parse(xml).getroot().find(
            ".//ScalarVariable[@name='input.torque']") is not None
        if "[element]" in (REPO / "fmu" / xml.stem / "scene.toml").read_text():
            continue
        assert (cs.get("canInterpolateInputs") == "true") == has_ports, xml.name


def test_ramp_over_one_step_matches_scipy(slave, stage):
    s, vr, _ = slave
    s.setRealInputDerivatives([vr["input.torque"], vr["output.torque"]], [1, 1],
                              [RATE_IN, RATE_OUT])
    s.doStep(0.0, H)
    got = read(s, vr, OUT)
    r, scale = reference((RATE_IN, RATE_OUT), stage[1])
    dte, speed = errors(got, r, scale)
    held, _ = reference((0.0, 0.0), stage[1])
    gap = abs(held["dte"][0] - r["dte"][0]) / scale
    print(f"ramp: DTE error {dte:.3e} of the static deflection, speed {speed:.3e} rad/s; "
          f"ramp vs held reference {gap:.3e}")
    assert dte <= DTE_TOL and speed <= SPEED_TOL
    assert gap > 1e4 * DTE_TOL  # the comparison can tell a ramp from a held torque
    # At the end of the step the inputs are u + u'h.
    assert got["input.torque"] == pytest.approx(100.0 + RATE_IN * H, rel=1e-15)
    assert got["output.torque"] == pytest.approx(-144.73684210526315 + RATE_OUT * H, rel=1e-15)


def test_without_derivatives_the_torque_is_held(slave, stage):
    s, vr, _ = slave
    s.doStep(0.0, H)
    got = read(s, vr, OUT)
    r, scale = reference((0.0, 0.0), stage[1])
    dte, speed = errors(got, r, scale)
    print(f"held: DTE error {dte:.3e} of the static deflection, speed {speed:.3e} rad/s")
    assert dte <= DTE_TOL and speed <= SPEED_TOL


def momentum(s, vr, sc):
    b = sc.base
    w1, w2 = s.getReal([vr["pinion.speed"], vr["gear.speed"]])
    return b.inertia1 * w1 + (b.r_b1 / b.r_b2) * b.inertia2 * w2


def test_momentum_grows_by_the_ramped_torque_impulse(slave):
    s, vr, _ = slave
    sc = pr.load(SCENE)
    rho = sc.base.r_b1 / sc.base.r_b2
    p0 = momentum(s, vr, sc)
    s.setRealInputDerivatives([vr["input.torque"], vr["output.torque"]], [1, 1],
                              [RATE_IN, RATE_OUT])
    s.doStep(0.0, H)
    p1 = momentum(s, vr, sc)
    want1 = (sc.t_in + rho * sc.t_out) * H + (RATE_IN + rho * RATE_OUT) * H**2 / 2
    # Second step, no new rates: held at the ramp's end value.
    s.doStep(H, H)
    p2 = momentum(s, vr, sc)
    t_in1, t_out1 = sc.t_in + RATE_IN * H, sc.t_out + RATE_OUT * H
    want2 = (t_in1 + rho * t_out1) * H
    print(f"momentum change {p1 - p0!r} vs {want1!r}; {p2 - p1!r} vs {want2!r}")
    assert abs((p1 - p0) - want1) <= 1e-9 * abs(want1)
    assert abs((p2 - p1) - want2) <= 1e-9 * abs(want2)
    # A held torque over the first step would be off by the quadratic term.
    assert abs((RATE_IN + rho * RATE_OUT) * H**2 / 2) > 1e3 * 1e-9 * abs(want1)


def test_state_with_rates_round_trips_bit_for_bit(slave):
    s, vr, _ = slave
    s.doStep(0.0, H)
    s.setRealInputDerivatives([vr["input.torque"], vr["output.torque"]], [1, 1],
                              [RATE_IN, RATE_OUT])
    state = s.getFMUstate()
    blob = s.serializeFMUstate(state)
    s.doStep(H, H)
    first = s.getReal([vr[n] for n in OUT])
    # Rates changed after the capture: restoring brings the captured ones back.
    s.setFMUstate(state)
    s.setRealInputDerivatives([vr["input.torque"]], [1], [0.0])
    s.setFMUstate(state)
    s.doStep(H, H)
    again = s.getReal([vr[n] for n in OUT])
    assert [x.hex() for x in again] == [x.hex() for x in first]
    restored = s.deSerializeFMUstate(blob)
    s.setFMUstate(restored)
    s.doStep(H, H)
    assert [x.hex() for x in s.getReal([vr[n] for n in OUT])] == [x.hex() for x in first]
    # Held torques give a different step (the rates were really in the state).
    s.setFMUstate(state)
    s.setRealInputDerivatives([vr["input.torque"], vr["output.torque"]], [1, 1], [0.0, 0.0])
    s.doStep(H, H)
    assert s.getReal([vr["pinion.speed"]])[0] != first[1]
    s.freeFMUstate(state)
    s.freeFMUstate(restored)


def test_the_start_speed_takes_no_derivative(slave):
    s, vr, _ = slave
    with pytest.raises(Exception):
        s.setRealInputDerivatives([vr["operating.input_speed"]], [1], [1.0])
