"""Native run-ups (issue 19 item 2) against independent scipy models written from
`docs/runup.md`, `docs/model.md` and `docs/train.md` only.

Pair: `m_e x'' + F(x − e(p), x' − ė) = F_ext(t)` with the rectangular stiffness k(p), contact
loss as terminal events, the STE `e(p) = c1 cos 2πp`, `ė = f_m(t) de/dp`, and the mesh phase
`p(t) = p0 + z1/2π ∫ Ω dt` of a piecewise-linear speed (integrated here knot by knot; the
stiffness switches are found by `brentq` on it, not by a quadratic formula). A torque table
makes `F_ext(t) = T1(t)/r_b1` (balanced load following the torque).

Drivetrain: the same stage as a grounded two-gear train (a ground spring on the pinion, so the
nominal acceleration adds the inertial force `−M v Ω̇`, `v = (r_b1, r_b1)`: rolling on the
base circles) in the two
physical rotations `u_i = r_bi θ_i`, checked against `geardyn simulate` of the drivetrain
scene; and the single pair's scene written as a free two-gear drivetrain, where the inertial
term vanishes, against the pair model.

Everything runs through `solve_ivp(DOP853, rtol=1e-12)`, cut at every stiffness switch and
profile knot.
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from conftest import run_geardyn

TWO_PI = 2.0 * math.pi
Z1, Z2 = 38, 55
RB1, RB2 = 0.04535, 0.06564
I1, I2 = 0.002621, 0.01091
K_MEAN, EPS, CR = 2.9831e8, 0.35, 1.504
ZETA = 0.05
STE = 1.0e-6
M_E = 1.0 / (RB1**2 / I1 + RB2**2 / I2)
C_M = 2.0 * ZETA * math.sqrt(K_MEAN * M_E)
F_FRAC = CR - math.floor(CR)
K_LOW = K_MEAN * (1.0 - F_FRAC * EPS)
K_HIGH = K_LOW + EPS * K_MEAN
#: Phase within a cycle where the stiffness rises (docs/model.md, "rectangular").
S_RISE = 1.0 - F_FRAC

#: A run-up through the primary resonance (f_n = 2985 Hz is Ω ≈ 494 rad/s): held, ramped,
#: held again.
SPEED_T = [0.0, 0.004, 0.024]
SPEED_V = [380.0, 380.0, 600.0]
TORQUE_T = [0.0, 0.03]
TORQUE_V = [100.0, 160.0]
STOP = 0.03
H = 2e-5
#: DTE agreement, in units of the mean static deflection (as tests/python/test_reference_vs_geardyn.py).
TOL = 1e-7


class Piecewise:
    """Linear between knots, held outside."""

    def __init__(self, times, values):
        self.t = np.asarray(times, float)
        self.v = np.asarray(values, float)

    def __call__(self, t):
        return float(np.interp(t, self.t, self.v))

    def integral(self, t):
        """∫_0^t of the function (trapezoids over the knots; exact for a piecewise-linear one)."""
        pts = [0.0] + [k for k in self.t if 0.0 < k < t] + [t]
        return sum(0.5 * (self(a) + self(b)) * (b - a) for a, b in zip(pts[:-1], pts[1:]))


def phase_fn(speed, teeth, p0=0.0):
    return lambda t: p0 + teeth / TWO_PI * speed.integral(t)


def switch_times(phase, stop, extra):
    """Every time in (0, stop) where the shifted phase crosses an integer or S_RISE, and the
    profile knots `extra`."""
    out = set(k for k in extra if 0.0 < k < stop)
    p_end = phase(stop)
    n = math.floor(phase(0.0))
    while n <= p_end:
        for s in (0.0, S_RISE):
            target = n + s
            if phase(0.0) < target < p_end:
                out.add(brentq(lambda t: phase(t) - target, 0.0, stop, xtol=1e-16, rtol=1e-15))
        n += 1
    return sorted(out) + [stop]


def stiffness(p):
    s = p - math.floor(p)
    return K_LOW if s < S_RISE else K_HIGH


def pair_scene(tmp_path, contact, torque_profile, speed_kind="table", ste=True):
    speed = (f'kind = "table"\ntimes = {SPEED_T}\nvalues = {SPEED_V}' if speed_kind == "table"
             else 'kind = "ramp"\nfrom = 380.0\nto = 600.0\nstart = 0.004\nend = 0.024')
    torque = (f'[operating.torque_profile]\nkind = "table"\ntimes = {TORQUE_T}\nvalues = {TORQUE_V}'
              if torque_profile else "")
    text = f"""
name = "runup_pair"
[[gear]]
name = "pinion"
teeth = {Z1}
base_radius = {RB1}
inertia = {I1}
[[gear]]
name = "gear"
teeth = {Z2}
base_radius = {RB2}
inertia = {I2}
[mesh]
pinion = "pinion"
gear = "gear"
contact = "{contact}"
damping_ratio = {ZETA}
[mesh.stiffness]
kind = "rectangular"
mean = {K_MEAN}
peak_to_peak_ratio = {EPS}
contact_ratio = {CR}
{"[mesh.ste]" if ste else ""}
{f"cos = [{STE}]" if ste else ""}
[operating]
{"" if torque_profile else "input_torque = 100.0"}
[operating.speed_profile]
{speed}
{torque}
[solver]
stop_time = {STOP}
output_interval = {H}
"""
    path = tmp_path / "runup_pair.toml"
    path.write_text(text)
    return path


def pair_reference(times, contact_loss, torque_profile, ste=True):
    """The independent pair model on `times`: DTE."""
    speed = Piecewise(SPEED_T, SPEED_V)
    torque = Piecewise(TORQUE_T, TORQUE_V) if torque_profile else Piecewise([0.0, 1.0], [100.0, 100.0])
    phase = phase_fn(speed, Z1)
    c1 = STE if ste else 0.0

    def e(t):
        return c1 * math.cos(TWO_PI * phase(t))

    def e_rate(t):
        return -c1 * TWO_PI * math.sin(TWO_PI * phase(t)) * Z1 * speed(t) / TWO_PI

    def f_ext(t):
        return torque(t) / RB1

    breaks = switch_times(phase, times[-1], SPEED_T + (TORQUE_T if torque_profile else []))
    y = np.array([f_ext(0.0) / K_MEAN + e(0.0), 0.0])
    in_contact = True
    out = np.empty(len(times))
    out[0] = y[0]
    k_out, t = 1, 0.0
    for t_break in breaks:
        while t < t_break:
            k = stiffness(phase(0.5 * (t + t_break)))

            def rhs(tt, s, k=k, on=in_contact):
                d, dr = s[0] - e(tt), s[1] - e_rate(tt)
                force = k * d + C_M * dr if on else 0.0
                return [s[1], (f_ext(tt) - force) / M_E]

            def guard(tt, s):
                return s[0] - e(tt)

            guard.terminal = True
            guard.direction = -1.0 if in_contact else 1.0
            sol = solve_ivp(rhs, (t, t_break), y, method="DOP853", rtol=1e-12, atol=1e-20,
                            events=[guard] if contact_loss else None, dense_output=True,
                            max_step=2e-6)
            hit = contact_loss and sol.t_events[0].size > 0 and sol.t_events[0][0] > t
            t_stop = sol.t_events[0][0] if hit else t_break
            while k_out < len(times) and times[k_out] <= t_stop:
                out[k_out] = sol.sol(times[k_out])[0]
                k_out += 1
            if hit:
                y = sol.y_events[0][0].copy()
                y[0] = e(t_stop)
                in_contact = not in_contact
            else:
                y = sol.y[:, -1].copy()
            t = t_stop
    return out


def run(scene, tmp_path, *args):
    out = tmp_path / "out.csv"
    proc = run_geardyn("simulate", scene, "--out", out, *args)
    method = [ln for ln in proc.stdout.splitlines() if "method" in ln]
    return np.genfromtxt(out, delimiter=",", names=True, deletechars=""), (method[0] if method else "")


@pytest.mark.parametrize("contact,torque_profile,speed_kind", [
    ("contact_loss", False, "table"),
    ("linear", True, "ramp"),
])
def test_pair_runup_matches_scipy(contact, torque_profile, speed_kind, tmp_path, geardyn_bin,
                                  capsys):
    scene = pair_scene(tmp_path, contact, torque_profile, speed_kind)
    cli, _ = run(scene, tmp_path, "--method", "rk", "--rtol", "1e-12", "--atol", "1e-18")
    ref = pair_reference(cli["time"], contact == "contact_loss", torque_profile)
    static = 100.0 / RB1 / K_MEAN
    err = np.max(np.abs(cli["mesh.dte"] - ref)) / static
    with capsys.disabled():
        print(f"\n  pair run-up ({contact}, torque profile {torque_profile}): max |DTE − scipy| = "
              f"{err:.2e} static deflections, DTE peak-to-peak {np.ptp(ref) / static:.3f}")
    assert err <= TOL
    # The run crosses the resonance: the response is far from the quasi-static one.
    assert np.ptp(ref) > 0.3 * static
    # The phase column follows the quadratic phase.
    speed = Piecewise(SPEED_T, SPEED_V)
    p = np.array([Z1 / TWO_PI * speed.integral(t) for t in cli["time"]])
    dp = np.abs(cli["mesh.phase"] - (p - np.floor(p)))
    assert np.max(np.minimum(dp, 1.0 - dp)) <= 1e-9


def test_exact_propagator_on_a_runup_without_ste(tmp_path, geardyn_bin):
    """Piecewise-constant stiffness without STE keeps LTI segments at any speed: `auto` takes
    the exact propagator, which agrees with the scipy model."""
    scene = pair_scene(tmp_path, "contact_loss", False, ste=False)
    cli, method = run(scene, tmp_path)
    assert method.split()[1] == "exact", method
    ref = pair_reference(cli["time"], True, False, ste=False)
    static = 100.0 / RB1 / K_MEAN
    assert np.max(np.abs(cli["mesh.dte"] - ref)) / static <= TOL


def train_scene(tmp_path, ground_stiffness):
    ground = f"ground_stiffness = {ground_stiffness}" if ground_stiffness else ""
    text = f"""
name = "runup_train"
[model]
bearings = "rigid"
[[gear]]
name = "pinion"
teeth = {Z1}
base_radius = {RB1}
inertia = {I1}
{ground}
[[gear]]
name = "gear"
teeth = {Z2}
base_radius = {RB2}
inertia = {I2}
[[mesh]]
pinion = "pinion"
gear = "gear"
contact = "contact_loss"
model = "lumped"
damping = {C_M}
[mesh.stiffness]
kind = "rectangular"
mean = {K_MEAN}
peak_to_peak_ratio = {EPS}
contact_ratio = {CR}
[operating]
input_torque = 100.0
[operating.speed_profile]
kind = "table"
times = {SPEED_T}
values = {SPEED_V}
[solver]
stop_time = {STOP}
output_interval = {H}
"""
    path = tmp_path / "runup_train.toml"
    path.write_text(text)
    return path


def grounded_reference(times, k_s, inertia=True):
    """Two rotations u = (r_b1 θ1, r_b2 θ2), θ in each gear's nominal sense (docs/train.md):
    M u'' + K_g u + d F = F_T − M v Ω̇, M = diag(I/r_b²), d = (1, −1), K_g = diag(k_s/r_b1², 0),
    F_T = (T1/r_b1, −T2/r_b2), balanced T2 = T1 r_b2/r_b1, v = (r_b1, r_b2 ω2/ω1) with
    ω2/ω1 = r_b1/r_b2 (rolling without slip on the base circles)."""
    speed = Piecewise(SPEED_T, SPEED_V)
    phase = phase_fn(speed, Z1)
    m = np.array([I1 / RB1**2, I2 / RB2**2])
    kg = np.array([k_s / RB1**2, 0.0])
    t1 = 100.0
    f_t = np.array([t1 / RB1, -(t1 * RB2 / RB1) / RB2])
    v = np.array([RB1, RB2 * (RB1 / RB2)])

    def accel(t):
        # Ω̇ of the piece containing t (right-continuous).
        for a, b, va, vb in zip(SPEED_T[:-1], SPEED_T[1:], SPEED_V[:-1], SPEED_V[1:]):
            if a <= t < b:
                return (vb - va) / (b - a)
        return 0.0

    # Static equilibrium on the mean stiffness: (K_g + k̄ d dᵀ) u = F_T.
    d = np.array([1.0, -1.0])
    u0 = np.linalg.solve(np.diag(kg) + K_MEAN * np.outer(d, d), f_t)
    y = np.concatenate([u0, [0.0, 0.0]])
    breaks = switch_times(phase, times[-1], SPEED_T)
    in_contact = True
    out = np.empty(len(times))
    out[0] = u0[0] - u0[1]
    k_out, t = 1, 0.0
    for t_break in breaks:
        while t < t_break:
            mid = 0.5 * (t + t_break)
            k = stiffness(phase(mid))
            alpha = accel(mid) if inertia else 0.0

            def rhs(_t, s, k=k, on=in_contact, alpha=alpha):
                u, ud = s[:2], s[2:]
                defl, rate = u[0] - u[1], ud[0] - ud[1]
                force = k * defl + C_M * rate if on else 0.0
                acc = (f_t - kg * u - d * force - m * v * alpha) / m
                return np.concatenate([ud, acc])

            def guard(_t, s):
                return s[0] - s[1]

            guard.terminal = True
            guard.direction = -1.0 if in_contact else 1.0
            sol = solve_ivp(rhs, (t, t_break), y, method="DOP853", rtol=1e-12, atol=1e-20,
                            events=[guard], dense_output=True, max_step=2e-6)
            hit = sol.t_events[0].size > 0 and sol.t_events[0][0] > t
            t_stop = sol.t_events[0][0] if hit else t_break
            while k_out < len(times) and times[k_out] <= t_stop:
                s = sol.sol(times[k_out])
                out[k_out] = s[0] - s[1]
                k_out += 1
            if hit:
                y = sol.y_events[0][0].copy()
                mean = 0.5 * (y[0] + y[1])
                y[0] = y[1] = mean
                in_contact = not in_contact
            else:
                y = sol.y[:, -1].copy()
            t = t_stop
    return out


def test_grounded_train_runup_has_the_inertial_force(tmp_path, geardyn_bin, capsys):
    """A ground spring on the pinion: the nominal acceleration forces the vibration by
    `−M v Ω̇`; without that term the reference misses by far more than the tolerance."""
    k_s = 2.0e5
    scene = train_scene(tmp_path, k_s)
    cli, _ = run(scene, tmp_path, "--method", "rk", "--rtol", "1e-12", "--atol", "1e-18")
    ref = grounded_reference(cli["time"], k_s)
    static = 100.0 / RB1 / K_MEAN
    err = np.max(np.abs(cli["mesh1.dte"] - ref)) / static
    with capsys.disabled():
        print(f"\n  grounded two-gear train run-up: max |DTE − scipy| = {err:.2e} static deflections")
    assert err <= TOL
    without = grounded_reference(cli["time"], k_s, inertia=False)
    miss = np.max(np.abs(cli["mesh1.dte"] - without)) / static
    with capsys.disabled():
        print(f"  the same reference without −M v Ω̇ misses by {miss:.2e} static deflections")
    assert miss > 1e4 * TOL


def test_free_train_runup_equals_the_pair_model(tmp_path, geardyn_bin, capsys):
    """The free two-gear drivetrain: no inertial term (the nominal motion is the rigid-body
    mode), so the pair's scipy model is its oracle too."""
    scene = train_scene(tmp_path, None)
    cli, _ = run(scene, tmp_path, "--method", "rk", "--rtol", "1e-12", "--atol", "1e-18")
    ref = pair_reference(cli["time"], True, False, ste=False)
    static = 100.0 / RB1 / K_MEAN
    err = np.max(np.abs(cli["mesh1.dte"] - ref)) / static
    with capsys.disabled():
        print(f"\n  free two-gear train run-up vs the pair model: {err:.2e} static deflections")
    assert err <= TOL


def test_runup_example_orders_and_resonance(repo_root, geardyn_bin, tmp_path, capsys):
    """`examples/runup_spur.toml` on the data (issue 19 acceptance 4, analysed here with numpy
    alone): in short windows the DTE spectrum peaks on the mesh orders, f = k·z1·n/60, lines
    through the origin; and the response envelope peaks where the mesh frequency crosses the
    natural frequency of the mean system, f_n = sqrt(k̄/m_e)/2π from the scene's numbers."""
    cli, method = run(repo_root / "examples" / "runup_spur.toml", tmp_path)
    t, x = cli["time"], cli["mesh.dte"]
    n0, n1, t_end = 1000.0, 8000.0, 2.0
    rpm = n0 + (n1 - n0) * np.minimum(t / t_end, 1.0)
    f_n = math.sqrt(K_MEAN / M_E) / TWO_PI
    n_res = f_n * 60.0 / Z1
    window = 1000                        # 20 ms: 50 Hz resolution, speed change 70 rpm
    dt = t[1] - t[0]
    rows = []
    for start in range(0, len(t) - window, window // 2):
        seg = x[start:start + window]
        n_mid = rpm[start + window // 2]
        spec = np.abs(np.fft.rfft((seg - seg.mean()) * np.hanning(window)))
        freq = np.fft.rfftfreq(window, dt)
        rows.append((n_mid, freq, spec, np.std(seg)))
    # Orders: the strongest line within ±15 % of k·z1·n/60 sits on it within the resolution.
    for k in (1, 2):
        pts = []
        for n_mid, freq, spec, _ in rows:
            f_k = k * Z1 * n_mid / 60.0
            band = (freq > 0.85 * f_k) & (freq < 1.15 * f_k)
            if f_k < 20e3 and band.any():
                pts.append((n_mid, freq[band][np.argmax(spec[band])]))
        pts = np.array(pts)
        slope, intercept = np.polyfit(pts[:, 0], pts[:, 1], 1)
        with capsys.disabled():
            print(f"\n  order {k}: f = {slope:.5f}·n + {intercept:.1f} Hz (expected {k * Z1 / 60:.5f}·n)")
        assert abs(slope / (k * Z1 / 60.0) - 1.0) < 5e-3
        assert abs(intercept) < 50.0     # through the origin, within one frequency bin
    # Resonance: the envelope peaks where order 1 crosses f_n.
    speeds = np.array([r[0] for r in rows])
    rms = np.array([r[3] for r in rows])
    n_peak = speeds[np.argmax(rms)]
    with capsys.disabled():
        print(f"  envelope peak at {n_peak:.0f} rpm; mesh order 1 meets f_n = {f_n:.1f} Hz at "
              f"{n_res:.0f} rpm")
    # Resolution 70 rpm per window; the damped peak of a 5 % damped mode lies 0.25 % lower.
    assert abs(n_peak - n_res) < 0.02 * n_res
    assert rms.max() > 4.0 * np.median(rms)
