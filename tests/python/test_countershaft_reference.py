"""Independent scipy reference for the counter-shaft drivetrain (issue 16, acceptance 1).

The shipped `fmu/countershaft_gearset` (Liu 2007 Ch. 4, Table 4.1; notes
`models-liu-parker-2007.md` §3.1-3.2), written here from the equations, not from the Rust
code. Three rotating bodies (pinion A; the counter-shaft B = middle1 + middle2 on one rigid
shaft; output C), rotations positive in each body's nominal sense, the two DTEs as
coordinates:

    x1 = r_p θ_A − r_m1 θ_B,   x2 = r_m2 θ_B − r_o θ_C,
    J_A θ_A'' = T1 − r_p F1,   J_B θ_B'' = r_m1 F1 − r_m2 F2,   J_C θ_C'' = r_o F2 − T2,

so x'' = g − W F with W = [[r_p²/J_A + r_m1²/J_B, −r_m1 r_m2/J_B],
[−r_m1 r_m2/J_B, r_m2²/J_B + r_o²/J_C]], g = [r_p T1/J_A, r_o T2/J_C]; M = W⁻¹ and
M x'' + C x' + F = M g with modal damping C = M S diag(2ζω) Sᵀ M on the mean-stiffness modes
(Sᵀ M S = I). F_j = H(x_j) k_j(p_j) x_j (contact loss, no back side), k_j rectangular
(`docs/model.md`), p_1 = f_1 t, p_2 = φ_2 + f_2 t, f_2 = f_1 z_m2/z_m1. The load T2 is the
balanced value T1 (r_m1/r_p)(r_o/r_m2). Integrated with scipy's DOP853 at rtol 1e-12, piece by
piece between the known stiffness switches, contact changes located as events.
"""

import math
import subprocess
from pathlib import Path

import numpy as np
from scipy.linalg import eigh

from contact_ivp import dte_model_rhs, integrate, switch_times

REPO = Path(__file__).resolve().parents[2]
Z = {"pinion": 51, "middle1": 72, "middle2": 19, "output": 73}
R = {"pinion": 0.03366683737120713, "middle1": 0.04752965275935125,
     "middle2": 0.01979579967263114, "output": 0.07605754611063544}
J_A, J_B, J_C = 0.01837, 0.03531 + 0.00071, 0.1740
K_MEAN = [4.24e9, 3.45e9]
EPS = [0.3, 0.3]
CONTACT_RATIO = [1.60, 1.70]
PHASE2 = 0.257
ZETA = 0.04
T1 = 100.0
PERIODS = 144  # two response periods of 72 mesh-1 periods
SAMPLES_PER_PERIOD = 16


def scene(speed):
    text = (REPO / "fmu" / "countershaft_gearset" / "scene.toml").read_text()
    return text.replace("input_speed = 246.39942381096415", f"input_speed = {speed!r}")


def model_matrices():
    rp, rm1, rm2, ro = R["pinion"], R["middle1"], R["middle2"], R["output"]
    w = np.array([[rp**2 / J_A + rm1**2 / J_B, -rm1 * rm2 / J_B],
                  [-rm1 * rm2 / J_B, rm2**2 / J_B + ro**2 / J_C]])
    mass = np.linalg.inv(w)
    w2, vecs = eigh(np.diag(K_MEAN), mass)
    damping = mass @ vecs @ np.diag(2 * ZETA * np.sqrt(w2)) @ vecs.T @ mass
    t2 = T1 * (rm1 / rp) * (ro / rm2)
    g = np.array([rp * T1 / J_A, ro * t2 / J_C])
    return mass, damping, mass @ g, np.sqrt(w2) / (2 * math.pi)


def stiffness(j, p):
    f = CONTACT_RATIO[j] - math.floor(CONTACT_RATIO[j])
    low = K_MEAN[j] * (1 - f * EPS[j])
    s = p - math.floor(p)
    return low if s < 1 - f else low + EPS[j] * K_MEAN[j]


def reference(times, speed):
    """DTEs of both meshes at `times`, and whether each mesh lost contact."""
    mass, damping, force, _ = model_matrices()
    minv = np.linalg.inv(mass)
    f1 = Z["pinion"] * speed / (2 * math.pi)
    freq = [f1, f1 * Z["middle2"] / Z["middle1"]]
    phases = [0.0, PHASE2]
    t_end = times[-1]
    breaks = switch_times(freq, phases, [(0.0, 1 - (c - math.floor(c))) for c in CONTACT_RATIO],
                          t_end) + [t_end]
    # The static start of the scene: each mesh at its mean-stiffness static deflection.
    x0 = np.linalg.solve(np.diag(K_MEAN), force)
    y = np.concatenate([x0, [0.0, 0.0]])
    rhs_for = dte_model_rhs(minv, force, damping,
                            lambda j, t: stiffness(j, phases[j] + freq[j] * t))

    # At most 1/100 mesh period per step: a brief contact loss must not hide inside a step.
    return integrate(times, y, breaks, rhs_for, 2, max_step=0.01 / freq[0])


def run(tmp_path, geardyn_bin, speed):
    path = tmp_path / "countershaft.toml"
    path.write_text(scene(speed))
    f1 = Z["pinion"] * speed / (2 * math.pi)
    h = 1.0 / (f1 * SAMPLES_PER_PERIOD)
    csv = tmp_path / "out.csv"
    subprocess.run([str(geardyn_bin), "simulate", str(path), "--out", str(csv),
                    "--stop-time", repr(PERIODS / f1), "--output-interval", repr(h), "--quiet"],
                   check=True)
    data = np.genfromtxt(csv, delimiter=",", names=True, deletechars="")
    ours = np.column_stack([data["mesh1.dte"], data["mesh2.dte"]])
    ref, lost = reference(data["time"], speed)
    err = np.max(np.abs(ours - ref)) / np.max(np.abs(ref))
    return err, lost, data


def test_reference_modes_match_geardyn_modes(geardyn_bin):
    """The mean-stiffness natural frequencies of the reference equal `geardyn modes`."""
    _, _, _, f = model_matrices()
    out = subprocess.run([str(geardyn_bin), "modes", str(REPO / "fmu" / "countershaft_gearset")],
                         check=True, capture_output=True, text=True).stdout
    ours = sorted(float(line.split()[1]) for line in out.splitlines()[2:5]
                  if line.split() and line.split()[0].isdigit() and float(line.split()[1]) > 0)
    print(f"reference {f} Hz, geardyn {ours} Hz")
    assert np.allclose(sorted(f), ours, rtol=1e-5)


def test_geardyn_matches_scipy_reference(tmp_path, geardyn_bin):
    # At the shipped speed (mesh 1 at 2000 Hz) and at 232 rad/s, where mesh 1 loses contact.
    for speed in (246.39942381096415, 232.0):
        err, lost, data = run(tmp_path, geardyn_bin, speed)
        print(f"speed {speed} rad/s: geardyn vs scipy over {PERIODS} mesh-1 periods: "
              f"{err:.3e} relative; contact lost {lost}")
        assert err <= 1e-7, err
        assert lost[0] == bool((data["mesh1.contact_state"] == 0).any())
        assert lost[1] == bool((data["mesh2.contact_state"] == 0).any())
