"""Independent closed form for the helical SDOF model (issue 6 part A): the monodromy of
m_e δ'' + K_e(t) δ = 0 with the piecewise-linear K_e(t) of He & Singh 2007 eq. (25), formed
here from Airy functions per segment (notes models-he-singh-2007.md §4, "Recommended
numerically robust equivalent": Π(t) = [[Ai(w), Bi(w)], [−c Ai'(w), −c Bi'(w)]],
w = −(α + β t)/c², c = cbrt(β)), against the Taylor-series (Peano–Baker) propagator behind
`geardyn floquet`. The load response g over one period is checked against scipy DOP853.

geardyn supplies only the stiffness segments (k at each segment start and its slope, which
the Rust tests check against the paper geometry); every matrix here is computed by scipy."""

import json

import numpy as np
import pytest
from conftest import REPO, run_geardyn
from scipy.integrate import solve_ivp
from scipy.special import airy

SCENE = REPO / "fmu" / "helical_pair_friction"


def floquet(rpm, mu):
    out = run_geardyn("floquet", SCENE, "--speed", f"{rpm}rpm", "--mu", mu, "--json").stdout
    return json.loads(out)


def segment_transition(k0, slope, h, m):
    """Φ over one segment of δ'' + (k0 + slope τ)/m δ = 0, τ ∈ [0, h]."""
    alpha, beta = k0 / m, slope / m
    if abs(beta) * h < 1e-12 * alpha:
        w = np.sqrt(alpha + 0.5 * beta * h)
        c, s = np.cos(w * h), np.sin(w * h)
        return np.array([[c, s / w], [-w * s, c]])
    c = np.cbrt(beta)

    def wronskian(tau):
        ai, aip, bi, bip = airy(-(alpha + beta * tau) / c**2)
        return np.array([[ai, bi], [-c * aip, -c * bip]])

    return wronskian(h) @ np.linalg.inv(wronskian(0.0))


def airy_monodromy(data):
    m = data["equivalent_mass"]
    phi = np.eye(2)
    for seg in data["segments"]:
        phi = segment_transition(seg["k_start"], seg["slope"], seg["duration"], m) @ phi
    return phi


CASES = [(rpm, mu) for rpm in (1000, 18000, 19000) for mu in (0.0, 0.2, 0.4)]


@pytest.mark.parametrize("rpm,mu", CASES)
def test_monodromy_equals_airy_product(rpm, mu, report):
    data = floquet(rpm, mu)
    got = np.array(data["monodromy"])
    ref = airy_monodromy(data)
    # Compare in the balanced scaling (δ, δ'/ω): entries of one size.
    omega = np.sqrt(np.mean([s["k_start"] for s in data["segments"]]) / data["equivalent_mass"])
    scale = np.diag([1.0, 1.0 / omega])
    inv = np.diag([1.0, omega])
    dev = np.abs(scale @ (got - ref) @ inv).max()
    report(f"{rpm} rpm μ = {mu}: tr Φ geardyn {np.trace(got):+.10f}, Airy {np.trace(ref):+.10f}, "
           f"max balanced |ΔΦ| = {dev:.2e}")
    assert dev < 1e-9
    assert abs(np.linalg.det(ref) - 1.0) < 1e-9
    if mu == 0.2 and rpm in (18000, 19000):
        # The paper's statement: stable at 18,000 rpm, unstable at 19,000 rpm.
        assert (abs(np.trace(ref)) > 2.0) == (rpm == 19000)


@pytest.mark.parametrize("rpm,mu", [(1000, 0.2), (19000, 0.4)])
def test_load_response_equals_dop853(rpm, mu, report):
    data = floquet(rpm, mu)
    m, force = data["equivalent_mass"], data["force"]
    segs = data["segments"]

    def stiffness(t):
        for s in reversed(segs):
            if t >= s["start"]:
                return s["k_start"] + s["slope"] * (t - s["start"])
        return segs[0]["k_start"]

    def rhs(t, y):
        return [y[1], (force - stiffness(t) * y[0]) / m]

    # Integrate segment by segment so the solver never steps over a slope break.
    y = np.zeros(2)
    for s in segs:
        sol = solve_ivp(rhs, (s["start"], s["start"] + s["duration"]), y, method="DOP853",
                        rtol=1e-12, atol=1e-20)
        y = sol.y[:, -1]
    g = np.array(data["load_response"])
    dev = np.abs(g - y) / np.abs(y)
    report(f"{rpm} rpm μ = {mu}: g geardyn {g}, DOP853 {y}, rel. dev {dev.max():.2e}")
    assert dev.max() < 1e-8
