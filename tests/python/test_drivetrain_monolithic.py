"""Issue 18 point 5's oracle: the monolithic native drivetrain `examples/drivetrain_monolithic.toml`
(e-motor → shaft → spur_stage → shaft → vehicle load as ONE scene with carried rotation,
docs/ports.md "Elements in the scene") against the independent scipy model of the whole
drivetrain, `drivetrain_reference.py` (one ODE system, DOP853 rtol 1e-12, stiffness knots and
contact changes as events; written from docs/elements.md and docs/ports.md, not from the Rust
code).

The reference's data are read here from the example file itself (gears, mesh, elements); its
start state is built independently from the documented rule: every body at its nominal speed,
the pinion at angle 0, the gear stage at its static deflection under the start torques, each
shaft pre-twisted by its start torque over its stiffness.

Tolerances: the DTE to 1e-8 of the static deflection, the speeds to 1e-9 relative, the shaft
torques to 1e-8 relative to their start values. A 1 % change of the load inertia in the
reference must break the comparison.
"""

from __future__ import annotations

import copy
import math
import tomllib

import numpy as np
import pytest

import drivetrain_reference as dr
import ports_reference as pr
from conftest import REPO, run_geardyn

SCENE = REPO / "examples" / "drivetrain_monolithic.toml"
DTE_TOL = 1e-8
SPEED_TOL = 1e-9
TORQUE_TOL = 1e-8


def reference_model():
    with open(SCENE, "rb") as fh:
        doc = tomllib.load(fh)
    op = doc["operating"]
    t_in, t_load = op["input_torque"], op["load_torque"]
    (motor,), (load,) = doc["motor"], doc["load"]
    sh = {s["name"]: s for s in doc["shaft"]}
    assert sh["shaft1"]["gears"] == [motor["name"], "pinion"]
    assert sh["shaft2"]["gears"] == ["gear", load["name"]]
    base_doc = copy.deepcopy({k: doc[k] for k in ("name", "gear", "mesh", "operating")})
    (base_doc["mesh"],) = base_doc["mesh"]
    base_doc["operating"] = {"pinion_speed": op["pinion_speed"], "input_torque": t_in, "load_torque": 0.0}
    base = pr.ref.scene_from_dict(base_doc)
    s = pr.PortScene(base, t_in, -t_load, base.pinion_speed)
    # The gear stage's start deflection S0 = F_ext/k̄ + e(p0); the wheel angle −S0/r_b2.
    s0 = pr.f_ext(s) / base.stiffness.mean + pr.ref._fourier_sum(base.ste_cos, base.ste_sin, base.p0)
    k1, k2 = sh["shaft1"]["stiffness"], sh["shaft2"]["stiffness"]
    om = s.omega
    c = motor["controller"]
    assert c["ki"] == 0.0  # the reference is a P controller
    el = dr.Elements(
        j_m=motor["inertia"], d_m=motor["damping"], kp=c["kp"], omega_ref=c["speed_reference"],
        ripple=[(r["order"], r["amplitude"], r.get("phase", 0.0)) for r in motor["ripple"]],
        t_max=(motor["curve"]["speed"], motor["curve"]["torque"]),
        k1=k1, c1=sh["shaft1"]["damping"], k2=k2, c2=sh["shaft2"]["damping"],
        j_l=load["inertia"], t0=load["torque"], c_v=load["viscous"], c_d=load["drag"],
        theta_m0=t_in / k1, omega_m0=om,
        theta_l0=-s0 / base.r_b2 - t_load / k2, omega_l0=om * base.r_b1 / base.r_b2)
    return s, el


def geardyn(tmp_path, stop, interval):
    out = tmp_path / "mono.csv"
    run_geardyn("simulate", SCENE, "--out", out, "--stop-time", repr(stop), "--output-interval",
                repr(interval), "--rtol", "1e-12", "--atol", "1e-18", "--quiet")
    return np.genfromtxt(out, delimiter=",", names=True, deletechars="")


def compare(tmp_path, stop, interval, tweak=None):
    s, el = reference_model()
    if tweak:
        tweak(el)
    g = geardyn(tmp_path, stop, interval)
    r = dr.simulate(s, el, stop, g["time"])
    scale = abs(pr.f_ext(s) / s.base.stiffness.mean)
    err = {"dte": np.max(np.abs(r["dte"] - g["mesh1.dte"])) / scale}
    for ours, theirs in (("pinion.speed", "pinion.speed"), ("gear.speed", "gear.speed"),
                         ("motor.speed", "motor.speed"), ("load.speed", "load.speed")):
        err[ours] = np.max(np.abs(r[theirs] - g[ours]) / np.abs(r[theirs]))
    err["shaft1.torque"] = np.max(np.abs(r["tau1"] - g["shaft1.torque"])) / abs(s.t_in)
    err["shaft2.torque"] = np.max(np.abs(r["tau2"] - g["shaft2.torque"])) / abs(s.t_out)
    return err, g, r


def test_monolithic_drivetrain_matches_scipy(geardyn_bin, tmp_path):
    err, g, r = compare(tmp_path, 0.01, 1e-5)
    print("drivetrain_monolithic 0.01 s, " + f"{r['events']} reference events: "
          + ", ".join(f"{k} {v:.2e}" for k, v in err.items()))
    assert r["events"] > 30  # 38 stiffness knots in 10 ms at 3000 rpm, no contact changes
    # The start matches the documented rule (and the co-simulated system's SSD start values).
    assert g["motor.angle"][0] == pytest.approx(0.0025106658760038576, rel=1e-12)
    assert g["load.angle"][0] == pytest.approx(-0.0015253264657221178, rel=1e-12)
    assert err["dte"] <= DTE_TOL
    for k in ("pinion.speed", "gear.speed", "motor.speed", "load.speed"):
        assert err[k] <= SPEED_TOL, k
    for k in ("shaft1.torque", "shaft2.torque"):
        assert err[k] <= TORQUE_TOL, k


def test_comparison_detects_a_one_percent_load_inertia_change(geardyn_bin, tmp_path):
    def tweak(el):
        el.j_l *= 1.01

    err, _, _ = compare(tmp_path, 0.005, 1e-5, tweak=tweak)
    assert max(err.values()) > 100 * SPEED_TOL
