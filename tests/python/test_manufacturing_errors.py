"""Independent scipy reference for gear runout and pitch errors (issue 19, acceptance 3).

The model is written here from `docs/errors.md` and `docs/model.md`, not from the Rust code:
a spur pair in the DTE coordinate x,

    m_e x'' + c (x' − ė) + k(s) (x − e) = T_1 / r_1,    m_e = 1 / (r_1²/I_1 + r_2²/I_2),
    k(s) rectangular: k_low on s ∈ [0, 1 − f), k_high on [1 − f, 1), s = frac(p), p = f_m t,
    e(p) = −A_1 cos(2π p / z_1 + φ_1)        (pinion runout: driver, ccw)
           + A_2 cos(−2π p / z_2 + φ_2)      (gear runout: driven, cw)
           + F_1[floor(p) mod z_1]           (pinion cumulative pitch deviation)
    ė = f_m de/dp (the pitch steps act through the spring only),

started from x = T_1/(r_1 k̄) + e(0), x' = 0. Integrated with scipy's DOP853 at rtol 1e-12
piece by piece between the stiffness switches (the pitch steps fall on the s = 0 switches).

Checks: the time series agree; over one hunting period (lcm(z_1, z_2) = 200 mesh cycles,
an integer number of samples) the DTE spectrum has its lines on the grid f_m/200, the
sidebands f_m ± k f_1 and f_m ± k f_2 of both shaft frequencies are present, and their
amplitudes agree with the reference within 1 %.
"""

import math
import subprocess

import numpy as np
from scipy.integrate import solve_ivp

Z = [25, 40]
R = [0.0352, 0.0564]
I = [0.0010, 0.0040]
K_MEAN = 3.0e8
EPS = 0.2
CONTACT_RATIO = 1.6
DAMPING = 500.0
T1 = 150.0
F_MESH = 3000.0                     # Hz: below the 3.93 kHz resonance
SPEED = 2 * math.pi * F_MESH / Z[0]  # rad/s of the pinion
RUNOUT = [(5e-6, 0.3), (3e-6, -1.0)]
PITCH = [0.0, 1e-6, 2e-6, 1e-6, 0.0, -1e-6] + [0.0] * 19
HUNT = 200                           # mesh cycles per hunting period
SAMPLES = 8192                       # per hunting period
PERIODS = 3                          # the first holds the start transient


def scene(output_interval, stop_time):
    pitch = ", ".join(repr(v) for v in PITCH)
    return f"""
name = "runout_pitch_pair"
[[gear]]
name = "pinion"
teeth = {Z[0]}
base_radius = {R[0]}
inertia = {I[0]}
runout = {{ amplitude = {RUNOUT[0][0]}, phase = {RUNOUT[0][1]} }}
cumulative_pitch_errors = [{pitch}]
[[gear]]
name = "gear"
teeth = {Z[1]}
base_radius = {R[1]}
inertia = {I[1]}
runout = {{ amplitude = {RUNOUT[1][0]}, phase = {RUNOUT[1][1]} }}
[mesh]
pinion = "pinion"
gear = "gear"
contact = "linear"
damping = {DAMPING}
[mesh.stiffness]
kind = "rectangular"
mean = {K_MEAN}
peak_to_peak_ratio = {EPS}
contact_ratio = {CONTACT_RATIO}
[operating]
pinion_speed = {SPEED!r}
input_torque = {T1}
[solver]
method = "auto"
rtol = 1e-11
atol = 1e-18
stop_time = {stop_time!r}
output_interval = {output_interval!r}
"""


def reference(times):
    m_e = 1.0 / (R[0] ** 2 / I[0] + R[1] ** 2 / I[1])
    force = T1 / R[0]
    f = CONTACT_RATIO - math.floor(CONTACT_RATIO)
    k_low = K_MEAN * (1.0 - f * EPS)
    k_high = k_low + EPS * K_MEAN
    (a1, phi1), (a2, phi2) = RUNOUT
    w1, w2 = 2 * math.pi / Z[0], 2 * math.pi / Z[1]

    def runout(p):
        e = -a1 * math.cos(w1 * p + phi1) + a2 * math.cos(-w2 * p + phi2)
        de = a1 * w1 * math.sin(w1 * p + phi1) + a2 * w2 * math.sin(-w2 * p + phi2)
        return e, de

    def rhs_for(cycle, k):
        pitch = PITCH[cycle % Z[0]]

        def rhs(t, y):
            e, de = runout(F_MESH * t)
            e += pitch
            return [y[1], (force - DAMPING * (y[1] - F_MESH * de) - k * (y[0] - e)) / m_e]
        return rhs

    y = np.array([force / K_MEAN + runout(0.0)[0] + PITCH[0], 0.0])
    out = np.empty(len(times))
    out[0] = y[0]
    k_out = 1
    t_end = times[-1]
    cycle = 0
    while cycle / F_MESH < t_end:
        for k, (s0, s1) in ((k_low, (0.0, 1.0 - f)), (k_high, (1.0 - f, 1.0))):
            t0, t1 = (cycle + s0) / F_MESH, min((cycle + s1) / F_MESH, t_end)
            if t1 <= t0:
                continue
            sol = solve_ivp(rhs_for(cycle, k), (t0, t1), y, method="DOP853", rtol=1e-12,
                            atol=1e-20, dense_output=True)
            while k_out < len(times) and times[k_out] <= t1 * (1 + 1e-15):
                out[k_out] = sol.sol(times[k_out])[0]
                k_out += 1
            y = sol.y[:, -1]
        cycle += 1
    assert k_out == len(times)
    return out


def line_amplitudes(x):
    """One-sided amplitudes of an integer-period record (exact DFT lines)."""
    spectrum = np.fft.rfft(x) / len(x)
    amplitude = 2.0 * np.abs(spectrum)
    amplitude[0] /= 2.0
    return amplitude


def test_runout_and_pitch_sidebands_match_scipy(tmp_path, geardyn_bin, report):
    period = HUNT / F_MESH
    dt = period / SAMPLES
    stop = PERIODS * period
    path = tmp_path / "scene.toml"
    path.write_text(scene(dt, stop))
    out = tmp_path / "out.csv"
    subprocess.run([str(geardyn_bin), "simulate", str(path), "--out", str(out), "--quiet"],
                   check=True)
    data = np.genfromtxt(out, delimiter=",", names=True, deletechars="")
    times = data["time"]
    dte = data["mesh1.dte"]
    assert len(times) == PERIODS * SAMPLES + 1
    ref = reference(times)

    scale = np.max(np.abs(ref - np.mean(ref)))
    time_error = np.max(np.abs(dte - ref)) / scale
    report(f"runout+pitch pair: max |DTE − scipy| = {time_error:.2e} of the DTE swing")
    assert time_error < 1e-6

    last = slice(len(times) - 1 - SAMPLES, len(times) - 1)
    amp, amp_ref = line_amplitudes(dte[last]), line_amplitudes(ref[last])
    bin_hz = 1.0 / period  # f_m / 200: every line sits on a bin
    mesh_bin = HUNT
    assert math.isclose(mesh_bin * bin_hz, F_MESH, rel_tol=1e-12)
    # f_1 and f_2 are 8 and 5 bins. The pinion's pitch steps carry every shaft order; the
    # gear's pure runout only the first (the model is linear).
    shaft_bins = {"pinion": (HUNT // Z[0], (1, 2, 3)), "gear": (HUNT // Z[1], (1,))}
    worst = 0.0
    lines = []
    for name, (step, orders) in shaft_bins.items():
        for k in orders:
            for sign in (-1, 1):
                b = mesh_bin + sign * k * step
                # A sideband that is really there: far above the floor (~1e-17 m) the
                # time-domain agreement leaves.
                assert amp_ref[b] > 1e-6 * amp_ref[mesh_bin], (name, k, sign, amp_ref[b])
                rel = abs(amp[b] - amp_ref[b]) / amp_ref[b]
                worst = max(worst, rel)
                lines.append(f"{b * bin_hz:.2f} Hz {amp[b]:.4e}/{amp_ref[b]:.4e} m")
    # The shaft-order lines themselves (the runout seen directly in the DTE).
    for step, _ in shaft_bins.values():
        rel = abs(amp[step] - amp_ref[step]) / amp_ref[step]
        worst = max(worst, rel)
    report("sidebands f_m ± k f_shaft (geardyn/scipy): " + "; ".join(lines[:4]) + " …")
    report(f"worst sideband amplitude error {worst:.2e}")
    assert worst < 1e-2
    # Periodic over the hunting period (so the record is leakage-free): the last two coincide.
    previous = slice(len(times) - 1 - 2 * SAMPLES, len(times) - 1 - SAMPLES)
    drift = np.max(np.abs(dte[last] - dte[previous])) / scale
    report(f"hunting-period repeat error {drift:.2e}")
    assert drift < 1e-6


# --- A drivetrain: the idler of Liu's 2-DOF gearset with runout and pitch errors -------------
#
# The reference is the 2-DOF model of `test_idler_reference.py` (Liu 2007 eqs. 3.1-3.2, the
# same contact integrator) with the error terms of `docs/errors.md` added to its springs,
# `k_j (x_j − e_j(t))` (modal damping only, so ė does not enter). The idler (z = 55, turning
# cw, σ = −1) is the driven gear of mesh 1 and the driver of mesh 2:
#
#   β_1 = centre_angle_1 + pressure_angle,  β_2 = centre_angle_2 − pressure_angle,
#   e_1 = +A cos(−θ + φ − β_1) + F[c_1 mod 55],
#   e_2 = −A cos(−θ + φ − β_2) + F[(c_2 + k) mod 55],  θ = 2π f_m t / 55,
#   k = round(σ z (α_2 − α_1) / 2π), α_1 = centre_angle_1 + π (towards the pinion),
#   α_2 = centre_angle_2 (towards the gear),
#
# with c_j = floor(p_j) the stiffness cycle of mesh j.

import test_idler_reference as idler  # noqa: E402
from contact_ivp import integrate  # noqa: E402

IDLER_RUNOUT = (1.0e-6, 0.7)
IDLER_PITCH = [0.5e-6, -0.3e-6] + [0.0] * 50 + [0.2e-6, 0.0, 0.4e-6]
CENTRE = (0.0, 1.2)
PRESSURE = 0.35
IDLER_HUNT = 55          # mesh cycles per idler revolution (both meshes have f_m)
IDLER_PERIODS = 5        # hunting periods; the last one is analysed
IDLER_SAMPLES = 20       # per mesh cycle


def idler_scene(stop, h):
    pitch = ", ".join(repr(v) for v in IDLER_PITCH)
    text = idler.SCENE.replace('contact = "contact_loss"', 'contact = "linear"')
    text = text.replace('method = "exact"', f'method = "auto"\nrtol = 1e-11\natol = 1e-18\n'
                        f'stop_time = {stop!r}\noutput_interval = {h!r}')
    text = text.replace(f'name = "idler"\nteeth = {idler.Z[1]}',
                        f'name = "idler"\nteeth = {idler.Z[1]}\n'
                        f'runout = {{ amplitude = {IDLER_RUNOUT[0]}, phase = {IDLER_RUNOUT[1]} }}\n'
                        f'cumulative_pitch_errors = [{pitch}]')
    text = text.replace('pinion = "pinion"\ngear = "idler"',
                        f'pinion = "pinion"\ngear = "idler"\ncentre_angle = {CENTRE[0]}\n'
                        f'pressure_angle = {math.degrees(PRESSURE)!r}')  # degrees
    text = text.replace('pinion = "idler"\ngear = "gear"',
                        f'pinion = "idler"\ngear = "gear"\ncentre_angle = {CENTRE[1]}\n'
                        f'pressure_angle = {math.degrees(PRESSURE)!r}')  # degrees
    assert text.count("runout") == 1 and text.count("centre_angle") == 2
    return text


def idler_errors(t):
    fm = idler.mesh_frequency()
    a, phi = IDLER_RUNOUT
    theta = 2 * math.pi * fm * t / idler.Z[1]
    beta = (CENTRE[0] + PRESSURE, CENTRE[1] - PRESSURE)
    k = round(-idler.Z[1] * (CENTRE[1] - (CENTRE[0] + math.pi)) / (2 * math.pi))
    c1 = math.floor(fm * t)
    c2 = math.floor(idler.PHASE2 + fm * t)
    return np.array([
        a * math.cos(-theta + phi - beta[0]) + IDLER_PITCH[c1 % 55],
        -a * math.cos(-theta + phi - beta[1]) + IDLER_PITCH[(c2 + k) % 55],
    ])


def idler_reference(times):
    mass, damping, _ = idler.model_matrices()
    minv = np.linalg.inv(mass)
    force = idler.T1 / idler.R[0]
    fm = idler.mesh_frequency()
    phases = [0.0, idler.PHASE2]
    t_end = times[-1]
    switches = set()
    for j in range(2):
        for n in range(int(fm * t_end) + 3):
            for b in (n, n + 0.5):
                t = (b - phases[j]) / fm
                if 0 < t < t_end:
                    switches.add(t)
    breaks = sorted(switches) + [t_end]
    k_mean = np.array(idler.K_MEAN)
    y = np.concatenate([force / k_mean + idler_errors(0.0), [0.0, 0.0]])

    def rhs_for(mid, _contact):
        k = np.array([idler.stiffness(j, phases[j] + fm * mid) for j in range(2)])
        e = idler_errors(mid)  # piecewise: the pitch terms are constant between the breaks

        def rhs(t, state):
            a, phi = IDLER_RUNOUT
            e_t = e.copy()
            theta = 2 * math.pi * fm * t / idler.Z[1]
            theta_mid = 2 * math.pi * fm * mid / idler.Z[1]
            beta = (CENTRE[0] + PRESSURE, CENTRE[1] - PRESSURE)
            # Runout at t (the pitch part of e stays that of the segment).
            e_t[0] += a * (math.cos(-theta + phi - beta[0]) - math.cos(-theta_mid + phi - beta[0]))
            e_t[1] -= a * (math.cos(-theta + phi - beta[1]) - math.cos(-theta_mid + phi - beta[1]))
            x, v = state[:2], state[2:]
            return np.concatenate([v, minv @ (force - k * (x - e_t) - damping @ v)])
        return rhs

    # The linear law ignores the contact flags: a zero crossing of x_j (this speed is near
    # the resonance) only restarts the integration on x_j = 0, where the event put it.
    out, _ = integrate(times, y, breaks, rhs_for, 2)
    return out


def test_idler_runout_and_pitch_act_on_both_meshes(tmp_path, geardyn_bin, report):
    fm = idler.mesh_frequency()
    h = 1.0 / (fm * IDLER_SAMPLES)
    stop = IDLER_PERIODS * IDLER_HUNT / fm
    path = tmp_path / "idler.toml"
    path.write_text(idler_scene(stop, h))
    out = tmp_path / "out.csv"
    subprocess.run([str(geardyn_bin), "simulate", str(path), "--out", str(out), "--quiet"],
                   check=True)
    data = np.genfromtxt(out, delimiter=",", names=True, deletechars="")
    times = data["time"]
    n = IDLER_HUNT * IDLER_SAMPLES
    assert len(times) == IDLER_PERIODS * n + 1
    ours = np.column_stack([data["mesh1.dte"], data["mesh2.dte"]])
    ref = idler_reference(times)
    err = np.max(np.abs(ours - ref)) / np.max(np.abs(ref))
    report(f"idler with runout + pitch errors: max |DTE − scipy| = {err:.2e} relative")
    assert err < 1e-7

    last = slice(len(times) - 1 - n, len(times) - 1)
    worst = 0.0
    for j in range(2):
        ours_line = np.fft.rfft(ours[last, j]) / n
        ref_line = np.fft.rfft(ref[last, j]) / n
        # The idler's first shaft order (bin 1) with its phase: the runout is seen by the two
        # meshes at different places around the idler.
        assert abs(ref_line[1]) > 1e-3 * IDLER_RUNOUT[0]
        worst = max(worst, abs(ours_line[1] - ref_line[1]) / abs(ref_line[1]))
        for b in (IDLER_HUNT - 1, IDLER_HUNT + 1, IDLER_HUNT - 2, IDLER_HUNT + 2):
            assert abs(ref_line[b]) > 1e-6 * abs(ref_line[IDLER_HUNT])
            worst = max(worst, abs(abs(ours_line[b]) - abs(ref_line[b])) / abs(ref_line[b]))
    phase_gap = np.angle(np.fft.rfft(ref[last, 1])[1] / np.fft.rfft(ref[last, 0])[1])
    report(f"idler shaft-order line: mesh 2 − mesh 1 phase {phase_gap:+.4f} rad; "
           f"worst line error {worst:.2e}")
    assert worst < 1e-2
