"""The spur_stage FMU (torque ports, docs/ports.md) in fmpy: port variables declared with units,
first-order output derivatives of the port angles and speeds, and a port torque input that
moves the shafts as the model's own equations of motion say.

Oracles: the derivative of `input.angle` against a forward difference of the angle over
1e-7 s (error ½·d·θ'' ≈ 5e-7 relative); the momentum J1ω1 + (r1/r2)J2ω2, which the mesh force
cannot change, against (T_in + (r1/r2)T_out)·t (inertias and radii from the scene).
"""

from __future__ import annotations

import tomllib

import numpy as np
import pytest

from conftest import initialized_slave, FMU_DIR, REPO

FMU = FMU_DIR / "spur_stage.fmu"


@pytest.fixture()
def slave(tmp_path):
    with initialized_slave(FMU, tmp_path) as s:
        yield s


def test_port_variables_are_declared(slave):
    _, vr, md = slave
    by = {v.name: v for v in md.modelVariables}
    assert md.coSimulation.maxOutputDerivativeOrder == 1
    for port in ("input", "output"):
        assert by[f"{port}.torque"].causality == "input" and by[f"{port}.torque"].unit == "N.m"
        for q, unit in (("angle", "rad"), ("speed", "rad/s"), ("acceleration", "rad/s2")):
            v = by[f"{port}.{q}"]
            assert v.causality == "output" and v.unit == unit and v.description


def test_output_derivatives_are_the_rates(slave):
    s, vr, _ = slave
    h = 1e-4
    s.doStep(0.0, h)
    t = h
    names = ["input.angle", "input.speed", "output.angle", "output.speed"]
    rates = s.getRealOutputDerivatives([vr[n] for n in names], [1] * 4)
    now = s.getReal([vr["input.speed"], vr["input.acceleration"], vr["output.speed"],
                     vr["output.acceleration"]])
    assert list(rates) == list(now)
    # Forward difference of the angle over d (a step from a saved state, then again).
    d = 1e-7
    state = s.getFMUstate()
    s.doStep(t, d)
    a_plus = s.getReal([vr["input.angle"]])[0]
    s.setFMUstate(state)
    a_now = s.getReal([vr["input.angle"]])[0]
    s.doStep(t, d)
    assert s.getReal([vr["input.angle"]])[0] == a_plus  # the state restores bit for bit
    fd = (a_plus - a_now) / d
    print(f"d(input.angle)/dt = {rates[0]!r}, forward difference {fd!r}")
    assert abs(fd - rates[0]) <= 1e-6 * abs(rates[0])
    s.freeFMUstate(state)
    # Other outputs have no derivative: a clear error (the instance enters the error state).
    with pytest.raises(Exception):
        s.getRealOutputDerivatives([vr["mesh1.dte"]], [1])


def test_torque_step_changes_the_momentum(slave):
    # J1 ω1' = T_in − r1 F and J2 ω2' = T_out + r2 F, so the mesh force drops out of
    # L = J1 ω1 + (r1/r2) J2 ω2: it changes by (T_in + (r1/r2) T_out)·t exactly, whatever the
    # mesh vibration (the scene's torques are balanced; the step adds 10 N·m at the pinion).
    s, vr, _ = slave
    scene = tomllib.loads((REPO / "fmu" / "spur_stage" / "scene.toml").read_text())
    (p, g) = scene["gear"]
    ratio = p["base_radius"] / g["base_radius"]
    torques = {q["name"]: q["torque"] for q in scene["port"]}
    t_in = torques["input"] + 10.0
    s.setReal([vr["input.torque"]], [t_in])

    def momentum():
        w1, w2 = s.getReal([vr["input.speed"], vr["output.speed"]])
        return p["inertia"] * w1 + ratio * g["inertia"] * w2

    l0 = momentum()
    t, h, n = 0.0, 1e-4, 100
    for _ in range(n):
        s.doStep(t, h)
        t += h
    expected = (t_in + ratio * torques["output"]) * t
    got = momentum() - l0
    print(f"ΔL = {got!r} N.m.s, (T_in + r1/r2 T_out) t = {expected!r} N.m.s")
    assert abs(got - expected) <= 1e-9 * abs(expected)
