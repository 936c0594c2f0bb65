"""Independent scipy reference for tooth friction in the drivetrain graph (issue 6, part B).

The model is Liu (2007) Ch. 5, eq. (4.44) with the piecewise stiffness (4.43) and the
time-varying friction terms of (4.46)-(4.48), written here from the notes
(`models-liu-parker-2007.md` §4.2-4.3 and their [R] corrections), not from the Rust code:

    M x'' + C x' + [K(t) + L(t)] x = F,   x = [u, x_1, y_1, x_2, y_2],
    u = r_1θ_1 + r_2θ_2 (rotational DTE), y along the line of action, x off it,
    M = diag(J_e, m_1, m_1, m_2, m_2),  J_e = J_1J_2/(r_2²J_1 + r_1²J_2),  F = [T_1/r_1, 0, 0, 0, 0],
    K: rows as in the notes (the print merges rows 2-3), k_m = Σ Γ_i k_i,
    L: first row L_m·[1, 0, 1, 0, −1], x_1 row −L_μ·[...], x_2 row +L_μ·[...],
    L_m = μ Σ [η l_i/r_1 + (1−η)(D − l_i)/r_2] s_i Γ_i k_i,  L_μ = μ Σ s_i Γ_i k_i,
    η = r_1²J_2/(r_2²J_1 + r_1²J_2),  D = (r_1 + r_2) tan φ,
    s_i = sgn(v̄_i),  v̄_i = Ω_1 r_1 (tan φ_1,i − tan φ_2,i) = Ω_1 l_i − Ω_1 (r_1/r_2)(D − l_i)
    (the printed sliding velocity: negative in approach, positive in recess),
    C = M S diag(2ζω) Sᵀ M on the modes of the mean frictionless system (k_m → k̄, L = 0).

Mesh cycle with the pitch point at τ = 0 (§4.2): pair 1 in recess on [0, c − 1 + γ) with arm
l_1 = ρ_0 + p_b τ, pair 2 in approach on [γ, 1) with l_2 = ρ_0 − p_b(1 − τ) (notes §4.3 [R]),
ρ_0 = r_1 tan φ, p_b = 2πr_1/z_1; stiffness (4.43) with the friction-bending factor applied
pair by pair (the "physical" variant of notes §4.2 [R]): recess (1 − β), approach (1 + β):

    [0, γ):           k_1 = (1−β)K_s,                       k_2 = 0
    [γ, c−1+γ):       k_1 = (1−β)K_d (α → 1−α),             k_2 = (1+β)K_d (1−α → α)
    [c−1+γ, 1):       k_1 = 0,                              k_2 = (1+β)K_s

K_s = k̄[1 + ε(1 − c)], K_d = k̄[1 + ε(2 − c)].

Sign conventions (the thesis mixes two): (4.43) puts (1 − β) in recess, where the printed v̄
is positive; (4.44)'s L_m with s_i = sgn(v̄_i) is the physical friction moment (it makes the
static mesh force larger in approach, as (4.40) with the text's "sgn = +1 in approach" and
Fig. 5.3 say). Both are used as printed here, each with its own sign.

Mapping to the drivetrain scene `examples/friction_pair.toml` (line of action along the scene's
x axis, pinion counter-clockwise): mesh1.dte = u, pinion.x = y_1, gear.x = y_2, and the
off-line-of-action axis of (4.44) points against the flanks' sliding velocity, which is the
scene's +y: pinion.y = −x_1, gear.y = −x_2. The mesh phase of the scene starts where the
number of pairs drops (docs/train.md), Liu's τ = c − 1 + γ.

Integrated with scipy's DOP853 at rtol 1e-12 piece by piece between the known stiffness and
friction switches (τ = 0, γ, c − 1 + γ); the case keeps contact throughout (checked).
"""

import math
import pathlib
import subprocess

import numpy as np
from scipy.integrate import solve_ivp
from scipy.linalg import eigh

REPO = pathlib.Path(__file__).resolve().parents[2]
SCENE = REPO / "examples" / "friction_pair.toml"

# Table 5.1 and the scene's stated assumptions.
Z1 = 38
R = [0.04535, 0.06564]
J = [2.62e-3, 3.27e-3]
MASS = [2.2325, 4.4380]
K_BEARING = [1.27e8, 1.4732e8]  # both axes
K_MEAN, EPS, C_RATIO, ALPHA = 2.98e8, 0.28, 1.4, 0.6
MU, BETA_TILDE, PITCH = 0.1, 0.5, 0.72
GAMMA = 1.0 - PITCH
PHI = math.radians(20.0)
T1 = 100.0
ZETA = 0.02
SPEED = 2 * math.pi * 1500.0 / Z1
PERIODS = 60
SAMPLES_PER_PERIOD = 20


def parameters():
    r1, r2 = R
    j1, j2 = J
    den = r2 ** 2 * j1 + r1 ** 2 * j2
    return dict(
        je=j1 * j2 / den,
        eta=r1 ** 2 * j2 / den,
        d=(r1 + r2) * math.tan(PHI),
        rho0=r1 * math.tan(PHI),
        pb=2 * math.pi * r1 / Z1,
        beta=BETA_TILDE * MU,
        ks=K_MEAN * (1 + EPS * (1 - C_RATIO)),
        kd=K_MEAN * (1 + EPS * (2 - C_RATIO)),
    )


def segment_of(tau):
    """Segment 1, 2 or 3 of (4.46)-(4.48) holding τ ∈ [0, 1)."""
    return 1 if tau < GAMMA else (2 if tau < C_RATIO - 1 + GAMMA else 3)


def pair_stiffness_and_arms(tau, p, segment):
    """(k_i, l_i) of pairs 1 and 2 at cycle position τ (pitch point at 0), with the formulas of
    `segment` (so that a piece's end point is evaluated with the piece's own law)."""
    beta, ks, kd = p["beta"], p["ks"], p["kd"]
    if segment == 1:
        k = [(1 - beta) * ks, 0.0]
    elif segment == 2:
        w = (tau - GAMMA) / (C_RATIO - 1)
        k = [(1 - beta) * kd * (ALPHA + (1 - 2 * ALPHA) * w),
             (1 + beta) * kd * ((1 - ALPHA) + (2 * ALPHA - 1) * w)]
    else:
        k = [0.0, (1 + beta) * ks]
    arms = [p["rho0"] + p["pb"] * tau, p["rho0"] - p["pb"] * (1 - tau)]
    return k, arms


def matrices(tau, p, segment, contact=True):
    """K + L of eq. (4.44) at cycle position τ."""
    k, arms = pair_stiffness_and_arms(tau, p, segment)
    gamma = 1.0 if contact else 0.0
    r1, r2 = R
    omega1 = SPEED
    km = lm = lmu = 0.0
    for ki, li in zip(k, arms):
        if ki == 0.0:
            continue
        vbar = omega1 * li - omega1 * (r1 / r2) * (p["d"] - li)
        s = math.copysign(1.0, vbar)
        km += gamma * ki
        lm += MU * (p["eta"] * li / r1 + (1 - p["eta"]) * (p["d"] - li) / r2) * s * gamma * ki
        lmu += MU * s * gamma * ki
    kx1, kx2 = K_BEARING
    ky1, ky2 = K_BEARING
    kmat = np.array([
        [km, 0, km, 0, -km],
        [0, kx1, 0, 0, 0],
        [km, 0, km + ky1, 0, -km],
        [0, 0, 0, kx2, 0],
        [-km, 0, -km, 0, km + ky2],
    ])
    pattern = np.array([1.0, 0.0, 1.0, 0.0, -1.0])
    lmat = np.zeros((5, 5))
    lmat[0] = lm * pattern
    lmat[1] = -lmu * pattern
    lmat[3] = lmu * pattern
    return kmat + lmat


def mass_and_damping(p):
    m = np.diag([p["je"], MASS[0], MASS[0], MASS[1], MASS[1]])
    kx1, kx2 = K_BEARING
    kbar = K_MEAN
    kmean = np.array([
        [kbar, 0, kbar, 0, -kbar],
        [0, kx1, 0, 0, 0],
        [kbar, 0, kbar + kx1, 0, -kbar],
        [0, 0, 0, kx2, 0],
        [-kbar, 0, -kbar, 0, kbar + kx2],
    ])
    w2, s = eigh(kmean, m)
    c = m @ s @ np.diag(2 * ZETA * np.sqrt(w2)) @ s.T @ m
    return m, c


def reference(times, x0):
    p = parameters()
    m, c = mass_and_damping(p)
    minv = np.linalg.inv(m)
    force = np.array([T1 / R[0], 0, 0, 0, 0])
    fm = Z1 * SPEED / (2 * math.pi)
    offset = C_RATIO - 1 + GAMMA  # τ at the scene's phase 0
    t_end = times[-1]
    breaks = set()
    n = 0
    while True:
        for b in (0.0, GAMMA, C_RATIO - 1 + GAMMA):
            t = (n + b - offset) / fm
            if 0 < t < t_end:
                breaks.add(t)
        if (n - offset) / fm > t_end:
            break
        n += 1
    breaks = sorted(breaks) + [t_end]
    y = np.concatenate([x0, np.zeros(5)])
    out = np.empty((len(times), 5))
    out[0] = x0
    k_out = 1
    t = 0.0
    min_deflection = math.inf
    for t_break in breaks:
        mid = 0.5 * (t + t_break)
        cycle_mid = offset + fm * mid
        cycle = math.floor(cycle_mid)
        segment = segment_of(cycle_mid - cycle)

        def rhs(tt, state, cycle=cycle, segment=segment):
            # τ continues across the piece's ends with the piece's own law.
            kl = matrices(offset + fm * tt - cycle, p, segment)
            x, v = state[:5], state[5:]
            return np.concatenate([v, minv @ (force - kl @ x - c @ v)])

        sol = solve_ivp(rhs, (t, t_break), y, method="DOP853", rtol=1e-12, atol=1e-20,
                        dense_output=True)
        while k_out < len(times) and times[k_out] <= t_break:
            out[k_out] = sol.sol(times[k_out])[:5]
            k_out += 1
        deflection = sol.y[0] + sol.y[2] - sol.y[4]
        min_deflection = min(min_deflection, deflection.min())
        y = sol.y[:, -1].copy()
        t = t_break
    return out, min_deflection


def run_geardyn(tmp_path, geardyn_bin):
    fm = Z1 * SPEED / (2 * math.pi)
    h = 1.0 / (fm * SAMPLES_PER_PERIOD)
    csv = tmp_path / "friction.csv"
    subprocess.run([str(geardyn_bin), "simulate", str(SCENE), "--out", str(csv),
                    "--stop-time", repr(PERIODS / fm), "--output-interval", repr(h),
                    "--rtol", "1e-12", "--quiet"], check=True)
    return np.genfromtxt(csv, delimiter=",", names=True, deletechars="")


def test_scene_holds_the_reference_data():
    text = SCENE.read_text()
    for needle in ["coefficient = 0.1", "bending_factor = 0.5", "pitch_point = 0.72",
                   "load_share = 0.6", "contact_ratio = 1.4", "peak_to_peak_ratio = 0.28",
                   "mean = 2.98e8", "modal_damping_ratio = 0.02", f"input_speed = {SPEED!r}"]:
        assert needle in text, needle


def test_geardyn_matches_scipy_reference(tmp_path, geardyn_bin):
    data = run_geardyn(tmp_path, geardyn_bin)
    times = data["time"]
    assert len(times) == PERIODS * SAMPLES_PER_PERIOD + 1
    ours = np.column_stack([data["mesh1.dte"], -data["pinion.y"], data["pinion.x"],
                            -data["gear.y"], data["gear.x"]])
    ref, min_deflection = reference(times, ours[0])
    assert min_deflection > 0, "the reference case must keep contact"
    assert (data["mesh1.pairs_in_contact"] > 0).all()
    names = ["u (dte)", "x_1 (-pinion.y)", "y_1 (pinion.x)", "x_2 (-gear.y)", "y_2 (gear.x)"]
    worst = 0.0
    for i, name in enumerate(names):
        scale = np.max(np.abs(ref[:, i]))
        err = np.max(np.abs(ours[:, i] - ref[:, i])) / scale
        print(f"{name}: max |geardyn - scipy| / max|scipy| = {err:.3e} (scale {scale:.3e} m)")
        worst = max(worst, err)
    # The friction really acts: the off-line-of-action motion is not zero.
    assert np.max(np.abs(ref[:, 1])) > 1e-7
    assert worst <= 1e-9, worst
