"""Checks of the Python reference itself against closed forms (the oracle's oracle).

The reference is trusted in `test_reference_vs_geardyn.py`; here it is compared with solutions
that need no numerical integration at all:

* constant stiffness, linear contact, damped, STE with two harmonics, unbalanced load and a
  non-static start: harmonic balance plus the homogeneous solution, in closed form;
* rectangular stiffness, linear contact: the product of matrix exponentials of the
  affine segments (scipy.linalg.expm), with switch instants computed here from the spec;
* constant stiffness with contact loss and with backlash, undamped, no STE: the event times
  (separation, back-side impact) from the circular/parabolic arcs.
"""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
from scipy.linalg import expm

import gear_reference as ref

BASE = {
    "name": "selfcheck",
    "gear": [
        {"name": "pinion", "teeth": 38, "base_radius": 0.04535, "inertia": 0.002621},
        {"name": "gear", "teeth": 55, "base_radius": 0.06564, "inertia": 0.01091},
    ],
    "mesh": {
        "pinion": "pinion",
        "gear": "gear",
        "contact": "linear",
        "damping": 1200.0,
        "initial_phase": 0.15,
        "stiffness": {"kind": "constant", "value": 3.0e8},
    },
    "operating": {"pinion_speed": 420.0, "input_torque": 80.0, "load_torque": 110.0},
}


def _scene(**edits) -> ref.Scene:
    doc = copy.deepcopy(BASE)
    for path, value in edits.items():
        table = doc
        keys = path.split("__")
        for key in keys[:-1]:
            table = table.setdefault(key, {})
        table[keys[-1]] = value
    return ref.scene_from_dict(doc)


def _m_e_f_ext():
    g1, g2 = BASE["gear"]
    m_e = 1.0 / (g1["base_radius"] ** 2 / g1["inertia"] + g2["base_radius"] ** 2 / g2["inertia"])
    op = BASE["operating"]
    f_ext = m_e * (g1["base_radius"] * op["input_torque"] / g1["inertia"]
                   + g2["base_radius"] * op["load_torque"] / g2["inertia"])
    return m_e, f_ext


def test_constant_stiffness_forced_closed_form():
    cos, sin = [2.0e-6, -5.0e-7], [1.0e-6, 3.0e-7]
    x0, v0 = 4.0e-6, 2.0e-3
    scene = _scene(mesh__ste={"cos": cos, "sin": sin}, initial={"dte": x0, "dte_rate": v0})
    m, f_ext = _m_e_f_ext()
    k, c = 3.0e8, 1200.0
    f_m = 38 * 420.0 / (2 * math.pi)
    p0 = 0.15
    t = np.linspace(0.0, 0.01, 1001)

    # Particular solution: m x'' + c x' + k x = F + k e + c ė, e = Σ Re(E_h e^{i w_h t}).
    xp = np.full(t.shape, f_ext / k)
    vp = np.zeros(t.shape)
    xp0, vp0 = f_ext / k, 0.0
    for h, (a, b) in enumerate(zip(cos, sin), start=1):
        w = 2 * math.pi * h * f_m
        e_h = (a - 1j * b) * np.exp(1j * 2 * math.pi * h * p0)
        x_h = (k + 1j * c * w) * e_h / (k - m * w * w + 1j * c * w)
        xp += np.real(x_h * np.exp(1j * w * t))
        vp += np.real(1j * w * x_h * np.exp(1j * w * t))
        xp0 += x_h.real
        vp0 += (1j * w * x_h).real
    omega = math.sqrt(k / m)
    zeta = c / (2 * math.sqrt(k * m))
    wd = omega * math.sqrt(1 - zeta * zeta)
    amp_a = x0 - xp0
    amp_b = (v0 - vp0 + zeta * omega * amp_a) / wd
    x_exact = xp + np.exp(-zeta * omega * t) * (amp_a * np.cos(wd * t) + amp_b * np.sin(wd * t))

    result = ref.simulate(scene, 0.01, output_times=t)
    scale = f_ext / k
    err = np.max(np.abs(result.dte - x_exact)) / scale
    assert err <= 1e-10, f"closed form vs reference: {err:.3e} of the static deflection"
    assert scene.static_deflection == pytest.approx(f_ext / k, rel=1e-14)
    assert scene.m_e == pytest.approx(m, rel=1e-14)


def test_rectangular_linear_matches_matrix_exponentials():
    mean, eps, cr, phase, p0 = 3.0e8, 0.35, 1.6, 0.3, 0.15
    scene = _scene(mesh__stiffness={"kind": "rectangular", "mean": mean,
                                    "peak_to_peak_ratio": eps, "contact_ratio": cr,
                                    "phase": phase})
    m, f_ext = _m_e_f_ext()
    c = 1200.0
    f = cr - math.floor(cr)
    k_low = mean * (1 - f * eps)
    k_high = k_low + eps * mean
    f_m = 38 * 420.0 / (2 * math.pi)
    t_end = 0.004
    out = np.linspace(0.0, t_end, 81)

    # Switch instants: shifted phase p + phase crosses n (→ k_low) or n + 1 − f (→ k_high).
    q0 = p0 + phase
    switches = []
    for n in range(0, 40):
        for s in (0.0, 1.0 - f):
            tt = (n + s - q0) / f_m
            if 0 < tt < t_end:
                switches.append(tt)
    switches.sort()

    def k_at(tt):  # on the open segment containing tt
        s = (q0 + f_m * tt) % 1.0
        return k_low if s < 1.0 - f else k_high

    def affine(k):  # z = (x, v, 1)
        return np.array([[0, 1, 0], [-k / m, -c / m, f_ext / m], [0, 0, 0]], dtype=float)

    z = np.array([f_ext / mean, 0.0, 1.0])
    knots = sorted(set([0.0, *switches, *out]))
    exact = {0.0: z[0]}
    for a, b in zip(knots[:-1], knots[1:]):
        z = expm(affine(k_at(0.5 * (a + b))) * (b - a)) @ z
        exact[b] = z[0]
    x_exact = np.array([exact[tt] for tt in out])

    result = ref.simulate(scene, t_end, output_times=out)
    err = np.max(np.abs(result.dte - x_exact)) / (f_ext / mean)
    assert err <= 1e-10, f"expm product vs reference: {err:.3e} of the static deflection"
    assert len(result.stops) == len(switches)
    np.testing.assert_allclose(result.stops, switches, rtol=1e-13)
    ks = np.array([k_low if ((q0 + f_m * tt) % 1.0) < 1.0 - f else k_high for tt in out])
    np.testing.assert_array_equal(result.mesh_stiffness, ks)


def test_contact_loss_event_times():
    """Undamped, constant k, no STE, start at rest above the static point with amplitude A > s:
    the drive-side arc x = s + A cos ωt reaches δ = 0 at t1 = acos(−s/A)/ω; the free flight
    x = v1 τ + a τ²/2 (a = F/m) returns to 0 after τ = −2 v1/a; the motion is periodic."""
    m, f_ext = _m_e_f_ext()
    k = 3.0e8
    s = f_ext / k
    amp = 3.0 * s
    scene = _scene(mesh__contact="contact_loss", mesh__damping=0.0,
                   initial={"dte": s + amp, "dte_rate": 0.0})
    omega = math.sqrt(k / m)
    t1 = math.acos(-s / amp) / omega
    v1 = -amp * omega * math.sin(omega * t1)
    tau = -2.0 * v1 / (f_ext / m)
    # Re-contact with velocity −v1; the drive-side arc back over the top to the next separation
    # is the mirror image of [0, t1] and lasts 2 t1: the events repeat every 2 t1 + tau.
    period = 2 * t1 + tau
    expected = []
    for n in range(4):
        expected += [(t1 + n * period, 0), (t1 + tau + n * period, 1)]
    t_end = expected[-1][0] + 0.5 * t1
    result = ref.simulate(scene, t_end, output_times=[0.0, t_end])
    assert [st for _, st in result.events] == [st for _, st in expected]
    times = np.array([t for t, _ in result.events])
    np.testing.assert_allclose(times, [t for t, _ in expected], rtol=0, atol=1e-10 * period)


def test_backlash_back_side_impact_time():
    """Undamped, constant k, backlash 2b, no STE: separation at t1 as above, then free flight
    x = v1 τ + a τ²/2 reaches −2b at the smaller positive root; then the back-side arc about
    −2b + s leaves the back flank at the symmetric instant."""
    m, f_ext = _m_e_f_ext()
    k = 3.0e8
    s = f_ext / k
    two_b = 2.0 * s
    amp = 6.0 * s
    scene = _scene(mesh__contact="backlash", mesh__backlash=two_b, mesh__damping=0.0,
                   initial={"dte": s + amp, "dte_rate": 0.0})
    omega = math.sqrt(k / m)
    acc = f_ext / m
    t1 = math.acos(-s / amp) / omega
    v1 = -amp * omega * math.sin(omega * t1)
    # v1 τ + acc τ²/2 = −2b  →  τ = (−v1 − sqrt(v1² − 2 acc 2b)) / acc
    tau = (-v1 - math.sqrt(v1 * v1 - 2.0 * acc * two_b)) / acc
    t2 = t1 + tau
    v2 = v1 + acc * tau
    # Back side: u = x + 2b − s obeys u'' = −ω² u, starts at u = −s with velocity v2 < 0 and
    # leaves when u = −s again (moving up). With u = R cos(ωτ' + φ), u' = −Rω sin(ωτ' + φ):
    # R cos φ = −s, R sin φ = −v2/ω, and the exit is the next τ' > 0 with ωτ' + φ = −φ (mod 2π).
    phi = math.atan2(-v2 / omega, -s)
    dur = ((-2.0 * phi) % (2 * math.pi)) / omega
    t3 = t2 + dur
    result = ref.simulate(scene, t3 + 0.1 * dur, output_times=[0.0, t3 + 0.1 * dur])
    got = result.events[:3]
    assert [st for _, st in got] == [0, -1, 0]
    np.testing.assert_allclose([t for t, _ in got], [t1, t2, t3], rtol=0, atol=1e-10 * t3)
