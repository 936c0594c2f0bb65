"""Independent scipy reference for gear runout and pitch errors (issue 19, acceptance 3).

The model is written here from `docs/errors.md` and `docs/model.md`, not from the Rust code:
a spur pair in the DTE coordinate x,

    m_e x'' + c (x' − ė) + k(s) (x − e) = T_1 / r_1,    m_e = 1 / (r_1²/I_1 + r_2²/I_2),
    k(s) rectangular: k_low on s ∈ [0, 1 − f + entry), k_high after, s = frac(p + δq),
    e(p) = −(w_1 − w_2)·ℓ                    (runout of both gears, ℓ at β = 20°)
           + F_1[floor(p + δq) mod z_1]      (pinion cumulative pitch deviation)
    ė = f_m de/dp (the pitch steps act through the spring only),

with the moving centre of the runouts (mesh position δq, start of contact `entry`) of
`runout_reference.py` (issue 31 item 7), started from x = T_1/(r_1 k̄) + e(0), x' = 0.
Integrated with scipy's DOP853 at rtol 1e-12 piece by piece between the stiffness switches
(the pitch steps fall on the s = 0 switches).

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
PRESSURE_DEG = 20.0
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
pressure_angle = {PRESSURE_DEG}
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
    from runout_reference import RunoutPair
    model = RunoutPair(teeth=tuple(Z), base_radii=tuple(R), inertias=tuple(I), k_mean=K_MEAN,
                       peak_to_peak=EPS, contact_ratio=CONTACT_RATIO, backlash=None,
                       damping=DAMPING, ste_cos1=0.0, speed=SPEED, torque=T1,
                       pressure_deg=PRESSURE_DEG, runouts={0: RUNOUT[0], 1: RUNOUT[1]},
                       pitch=PITCH)
    assert math.isclose(model.f_mesh, F_MESH, rel_tol=1e-14)
    x0 = T1 / R[0] / K_MEAN + model.geometry(0.0)[3] + model.pitch_at(0.0)
    return model.run(times, x0, 0.0)[0]


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
# with c_j = floor(p_j + δq_j) the stiffness cycle of mesh j at its contact phase. The idler's
# moving centre (issue 31 item 7) acts on both meshes, each with its own geometry
# (`runout_reference.RunoutPair.geometry`: mesh position δq_j and start of contact; the
# rectangular stiffness k_low on s ∈ [0, 1/2 + entry_j), s = frac(p_j + δq_j)).

import test_idler_reference as idler  # noqa: E402
from contact_ivp import integrate  # noqa: E402
from runout_reference import RunoutPair  # noqa: E402

IDLER_RUNOUT = (1.0e-6, 0.7)
IDLER_PITCH = [0.5e-6, -0.3e-6] + [0.0] * 50 + [0.2e-6, 0.0, 0.4e-6]
CENTRE = (0.0, 1.2)
PRESSURE = 0.35
IDLER_HUNT = 55          # mesh cycles per idler revolution (both meshes have f_m)
IDLER_PERIODS = 5        # hunting periods; the last one is analysed
IDLER_SAMPLES = 20       # per mesh cycle


def idler_meshes():
    """The two meshes' geometry: mesh 1 pinion → idler (the idler is its gear, ccw driver),
    mesh 2 idler → gear (the idler is its pinion and turns cw)."""
    common = dict(inertias=(1.0, 1.0), peak_to_peak=idler.EPS,
                  contact_ratio=idler.CONTACT_RATIO, backlash=None, damping=0.0, ste_cos1=0.0,
                  torque=0.0, pressure_deg=math.degrees(PRESSURE))
    idler_speed = idler.SPEED * idler.Z[0] / idler.Z[1]
    return [
        RunoutPair(teeth=(idler.Z[0], idler.Z[1]), base_radii=(idler.R[0], idler.R[1]),
                   k_mean=idler.K_MEAN[0], speed=idler.SPEED, runouts={1: IDLER_RUNOUT},
                   centre_angle=CENTRE[0], p0=0.0, senses=(1.0, -1.0), **common),
        RunoutPair(teeth=(idler.Z[1], idler.Z[2]), base_radii=(idler.R[1], idler.R[2]),
                   k_mean=idler.K_MEAN[1], speed=idler_speed, runouts={0: IDLER_RUNOUT},
                   centre_angle=CENTRE[1], p0=idler.PHASE2, senses=(-1.0, 1.0), **common),
    ]


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


def idler_errors(meshes, t, mid=None):
    """e_j at t: the runout at t, the pitch deviation of the tooth in mesh at `mid` (the
    segment's midpoint: constant between the breaks)."""
    mid = t if mid is None else mid
    k = round(-idler.Z[1] * (CENTRE[1] - (CENTRE[0] + math.pi)) / (2 * math.pi))
    out = []
    for j, mesh in enumerate(meshes):
        runout = mesh.geometry(mesh.phase(t))[3]
        p = mesh.phase(mid)
        cycle = math.floor(p + mesh.geometry(p)[0])
        out.append(runout + IDLER_PITCH[(cycle + (k if j == 1 else 0)) % 55])
    return np.array(out)


def idler_reference(times):
    mass, damping, _ = idler.model_matrices()
    minv = np.linalg.inv(mass)
    force = idler.T1 / idler.R[0]
    meshes = idler_meshes()
    assert all(math.isclose(m.f_mesh, idler.mesh_frequency(), rel_tol=1e-14) for m in meshes)
    t_end = times[-1]
    breaks = sorted(set(meshes[0].switch_times(t_end)) | set(meshes[1].switch_times(t_end)))
    breaks.append(t_end)
    k_mean = np.array(idler.K_MEAN)
    y = np.concatenate([force / k_mean + idler_errors(meshes, 0.0), [0.0, 0.0]])

    def rhs_for(mid, _contact):
        k = np.array([m.stiffness_at(mid) for m in meshes])

        def rhs(t, state):
            e = idler_errors(meshes, t, mid)
            x, v = state[:2], state[2:]
            return np.concatenate([v, minv @ (force - k * (x - e) - damping @ v)])
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
