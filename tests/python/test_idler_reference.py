"""Independent scipy reference for the 2-DOF idler (issue 5, acceptance 5).

The model is Liu (2007) Ch. 3, eq. (3.1)-(3.2) and (3.11), written here from the notes
(`models-liu-parker-2007.md` §2.1-2.3), not from the Rust code:

    M x'' + C x' + diag(H_1 k_1, H_2 k_2) x = [T, T],  x = DTEs of the two meshes,
    M = 1/Σm [[(m2+m3) m1, m1 m3], [m1 m3, (m1+m2) m3]],  m_i = I_i / r_i²,  T = T_1 / r_1,
    C = M S diag(2 ζ ω) Sᵀ M  (modal damping on the mean-stiffness modes, Sᵀ M S = I),
    H_j = 1 while x_j > 0, else 0 (contact loss, no back side),
    k_j rectangular (docs/model.md): k_low on s ∈ [0, 1 − f), k_high on [1 − f, 1),
    s = frac(p_j), p_1 = f_m t, p_2 = φ + f_m t.

Table 3.1 data with the gear inertia corrected to 0.119 kg m² and λ = k̄_2/k̄_1 = 1.08
(notes §2.9 [C], which gives c = ω_2/ω_1 = 2.762). Integrated with scipy's DOP853 at
rtol 1e-12 piece by piece: stiffness switches are known times, contact changes are located as
events and the state is put on the switching surface before restarting.
"""

import math
import subprocess

import numpy as np
import pytest
from scipy.linalg import eigh

from contact_ivp import dte_model_rhs, integrate, switch_times

I = [2.62e-3, 3.27e-3, 0.119]
R = [0.04535, 0.06564, 0.1122]
Z = [38, 55, 94]
K_MEAN = [2.98e8, 2.98e8 * 1.08]
EPS = 0.4
CONTACT_RATIO = 1.5
ZETA = 0.04
T1 = 100.0
SPEED = 260.0  # rad/s of the pinion: f_m = 38·260/2π ≈ 1572 Hz, below the 1784 Hz mode
PHASE2 = 0.25  # mesh phasing of mesh 2, mesh cycles
PERIODS = 100
SAMPLES_PER_PERIOD = 20

def scene_toml(name, peak_to_peak_ratio, speed, phase2=None):
    """The idler as a geardyn scene: Table 3.1 data, rectangular stiffness of the given
    peak-to-peak ratio, mesh 2 at phase `phase2` (mesh cycles; none: in phase)."""
    phase = "" if phase2 is None else f"phase = {phase2}\n"
    meshes = "".join(
        f"""[[mesh]]
pinion = "{pinion}"
gear = "{gear}"
contact = "contact_loss"
{phase if j == 1 else ""}[mesh.stiffness]
kind = "rectangular"
mean = {K_MEAN[j]!r}
peak_to_peak_ratio = {peak_to_peak_ratio!r}
contact_ratio = {CONTACT_RATIO}
"""
        for j, (pinion, gear) in enumerate([("pinion", "idler"), ("idler", "gear")])
    )
    gears = "".join(
        f"""[[gear]]
name = "{g}"
teeth = {Z[i]}
base_radius = {R[i]}
inertia = {I[i]}
"""
        for i, g in enumerate(["pinion", "idler", "gear"])
    )
    return f"""
name = "{name}"
[model]
bearings = "rigid"
modal_damping_ratio = {ZETA}
{gears}{meshes}[operating]
input_speed = {speed!r}
input_torque = {T1}
[solver]
method = "exact"
"""


def rectangular_stiffness(j, p, peak_to_peak_ratio):
    """k_j at mesh position p (docs/model.md): k_low on s ∈ [0, 1 − f), k_high after."""
    f = CONTACT_RATIO - math.floor(CONTACT_RATIO)
    low = K_MEAN[j] * (1 - f * peak_to_peak_ratio)
    s = p - math.floor(p)
    return low if s < 1 - f else low + peak_to_peak_ratio * K_MEAN[j]


SCENE = scene_toml("idler_2dof", EPS, SPEED, PHASE2)


def mesh_frequency():
    return Z[0] * SPEED / (2 * math.pi)


def model_matrices():
    m = [I[i] / R[i] ** 2 for i in range(3)]
    s = sum(m)
    mass = np.array([[(m[1] + m[2]) * m[0], m[0] * m[2]], [m[0] * m[2], (m[0] + m[1]) * m[2]]]) / s
    w2, vecs = eigh(np.diag(K_MEAN), mass)
    damping = mass @ vecs @ np.diag(2 * ZETA * np.sqrt(w2)) @ vecs.T @ mass
    return mass, damping, np.sqrt(w2) / (2 * math.pi)


def stiffness(j, p):
    return rectangular_stiffness(j, p, EPS)


def reference(times):
    """DTEs at `times` and the contact-loss flags seen."""
    mass, damping, _ = model_matrices()
    minv = np.linalg.inv(mass)
    force = T1 / R[0]
    fm = mesh_frequency()
    phases = [0.0, PHASE2]
    t_end = times[-1]
    # Known switching times of both rectangular waves (s = 0 and s = 1 − f).
    breaks = switch_times([fm, fm], phases, [(0.0, 0.5)] * 2, t_end) + [t_end]
    y = np.array([force / K_MEAN[0], force / K_MEAN[1], 0.0, 0.0])
    rhs_for = dte_model_rhs(minv, np.array([force, force]), damping,
                            lambda j, t: stiffness(j, phases[j] + fm * t))
    return integrate(times, y, breaks, rhs_for, 2)


def test_reference_modes_match_notes():
    """Notes §2.9 [C]: with these data c = ω_2/ω_1 = 2.762 and f_1 = 1784 Hz."""
    _, _, f = model_matrices()
    assert abs(f[1] / f[0] - 2.762) < 5e-4
    assert abs(f[0] - 1784.0) < 1.0


def test_geardyn_matches_scipy_reference(tmp_path, geardyn_bin):
    scene = tmp_path / "idler_2dof.toml"
    scene.write_text(SCENE)
    fm = mesh_frequency()
    h = 1.0 / (fm * SAMPLES_PER_PERIOD)
    stop = PERIODS / fm
    csv = tmp_path / "out.csv"
    subprocess.run([str(geardyn_bin), "simulate", str(scene), "--out", str(csv),
                    "--stop-time", repr(stop), "--output-interval", repr(h), "--quiet"],
                   check=True)
    data = np.genfromtxt(csv, delimiter=",", names=True, deletechars="")
    times = data["time"]
    assert len(times) == PERIODS * SAMPLES_PER_PERIOD + 1
    ours = np.column_stack([data["mesh1.dte"], data["mesh2.dte"]])
    ref, lost = reference(times)
    assert lost[0] and lost[1], "the case must lose contact on both meshes"
    assert (data["mesh1.contact_state"] == 0).any() and (data["mesh2.contact_state"] == 0).any()
    err = np.max(np.abs(ours - ref)) / np.max(np.abs(ref))
    print(f"geardyn vs scipy over {PERIODS} mesh periods: {err:.3e} relative")
    assert err <= 1e-7, err
