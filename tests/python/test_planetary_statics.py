"""Independent static model of a planetary stage (issue 33, acceptance 3).

The lumped model of Lin & Parker (1999) written here in numpy from the paper's equations in
the paper's own notation (docs/planetary.md eq. P3-P8 with σ = +1), not from the Rust code:
coordinates per member h in {c, r, s}: (x_h, y_h, u_h = r_h θ_h), per planet n:
(ζ_n, η_n, u_n), rotations counted counter-clockwise, translations in the carrier frame,

    δ_sn = −x_s sin ψ_sn + y_s cos ψ_sn − ζ_n sin α_s − η_n cos α_s + u_s + u_n,  ψ_sn = ψ_n − α_s
    δ_rn = −x_r sin ψ_rn + y_r cos ψ_rn + ζ_n sin α_r − η_n cos α_r + u_r − u_n,  ψ_rn = ψ_n + α_r
    δ_ζn = x_c cos ψ_n + y_c sin ψ_n − ζ_n + e_ζn          (planet bearing, radial)
    δ_ηn = −x_c sin ψ_n + y_c cos ψ_n + u_c − η_n + e_ηn    (planet bearing, tangential)

plus the central supports k_h (x_h² + y_h²) and k_hu u_h²; potential V = ½ Σ k δ². Statics
K q = F − Σ k b e with the sun torque T_s on u_s (F = T_s/r_s) and the carrier's rotation held
(u_c = 0, it reacts the load) instead of the balanced load geardyn applies: the mesh forces
are the same, since the pin errors and the balanced torques do no work on the rigid-body
motion. The same matrices give the natural frequencies of Table 2, which checks the oracle
itself.

geardyn's side: `geardyn modes` on a scene written by `scene_toml`, whose report prints every
planet's mesh forces in shortest round-trip form.
"""

import math
import re

import numpy as np
import pytest
from scipy.linalg import eigh

from conftest import run_geardyn

# Lin & Parker (1999) Table 1.
MASS = {"s": 0.4, "r": 2.35, "c": 5.43, "p": 0.66}
I_OVER_R2 = {"s": 0.39, "r": 3.0, "c": 6.29, "p": 0.61}
RADIUS = {"s": 0.0387, "r": 0.1375, "c": 0.0884, "p": 0.05015}
K_MESH = 5e8
K_BEARING = 1e8
K_RING_TORSION = 1e9
ALPHA = math.radians(24.6)
TORQUE = 100.0


def lin_parker(n, pin_errors):
    """M, K, the preload −Σ k b e, the mesh deflection rows and the DOF count of N planets."""
    dof = 9 + 3 * n
    col = {"c": 0, "r": 3, "s": 6}
    planet = lambda j: 9 + 3 * j
    m = np.zeros(dof)
    for h, i in col.items():
        m[i : i + 2] = MASS[h]
        m[i + 2] = I_OVER_R2[h]
    for j in range(n):
        m[planet(j) : planet(j) + 2] = MASS["p"]
        m[planet(j) + 2] = I_OVER_R2["p"]
    k = np.zeros((dof, dof))
    preload = np.zeros(dof)

    def spring(b, stiffness, error=0.0):
        nonlocal k, preload
        k += stiffness * np.outer(b, b)
        preload -= stiffness * b * error

    def unit(i):
        b = np.zeros(dof)
        b[i] = 1.0
        return b

    for h in "crs":
        spring(unit(col[h]), K_BEARING)
        spring(unit(col[h] + 1), K_BEARING)
    spring(unit(col["r"] + 2), K_RING_TORSION)
    sun_rows, ring_rows = [], []
    for j in range(n):
        psi = 2 * math.pi * j / n
        z, e, u = planet(j), planet(j) + 1, planet(j) + 2
        b = np.zeros(dof)  # sun mesh
        psi_s = psi - ALPHA
        b[col["s"]], b[col["s"] + 1], b[col["s"] + 2] = -math.sin(psi_s), math.cos(psi_s), 1.0
        b[z], b[e], b[u] = -math.sin(ALPHA), -math.cos(ALPHA), 1.0
        spring(b, K_MESH)
        sun_rows.append(b)
        b = np.zeros(dof)  # ring mesh
        psi_r = psi + ALPHA
        b[col["r"]], b[col["r"] + 1], b[col["r"] + 2] = -math.sin(psi_r), math.cos(psi_r), 1.0
        b[z], b[e], b[u] = math.sin(ALPHA), -math.cos(ALPHA), -1.0
        spring(b, K_MESH)
        ring_rows.append(b)
        b = np.zeros(dof)  # planet bearing, radial
        b[col["c"]], b[col["c"] + 1], b[z] = math.cos(psi), math.sin(psi), -1.0
        spring(b, K_BEARING, pin_errors[j][0])
        b = np.zeros(dof)  # planet bearing, tangential
        b[col["c"]], b[col["c"] + 1], b[col["c"] + 2], b[e] = -math.sin(psi), math.cos(psi), 1.0, -1.0
        spring(b, K_BEARING, pin_errors[j][1])
    return np.diag(m), k, preload, np.array(sun_rows), np.array(ring_rows), col


def oracle_mesh_forces(n, pin_errors):
    """Sun- and ring-mesh forces, N, with the carrier's rotation held."""
    _, k, preload, sun_rows, ring_rows, col = lin_parker(n, pin_errors)
    f = preload.copy()
    f[col["s"] + 2] += TORQUE / RADIUS["s"]
    free = [i for i in range(k.shape[0]) if i != col["c"] + 2]
    q = np.zeros(k.shape[0])
    q[free] = np.linalg.solve(k[np.ix_(free, free)], f[free])
    return K_MESH * sun_rows @ q, K_MESH * ring_rows @ q


def scene_toml(n, pin_errors):
    inertia = lambda h: I_OVER_R2[h] * RADIUS[h] ** 2
    gear = lambda name, h, extra: (
        f'[[gear]]\nname = "{name}"\nbase_radius = {RADIUS[h]!r}\ninertia = {inertia(h)!r}\n'
        f"mass = {MASS[h]!r}\nbearing_stiffness = [{K_BEARING!r}, {K_BEARING!r}]\n{extra}"
    )
    text = 'name = "planetary_oracle"\n[model]\nbearings = "compliant"\n'
    text += gear("sun", "s", "teeth = 27\n")
    text += gear(
        "ring", "r", f"teeth = 96\ninternal = true\nground_stiffness = {K_RING_TORSION * RADIUS['r'] ** 2!r}\n"
    )
    for j in range(n):
        text += gear(
            f"planet{j + 1}",
            "p",
            f'teeth = 35\ncarrier = "carrier"\nposition_angle = {360.0 * j / n!r}\n'
            f"pin_error = [{pin_errors[j][0]!r}, {pin_errors[j][1]!r}]\n",
        )
    text += (
        f'[[carrier]]\nname = "carrier"\nradius = {RADIUS["c"]!r}\ninertia = {inertia("c")!r}\n'
        f'mass = {MASS["c"]!r}\nbearing_stiffness = [{K_BEARING!r}, {K_BEARING!r}]\nfixed = "ring"\n'
    )
    for j in range(1, n + 1):
        for pinion, gear_name in [("sun", f"planet{j}"), (f"planet{j}", "ring")]:
            text += (
                f'[[mesh]]\npinion = "{pinion}"\ngear = "{gear_name}"\ncontact = "linear"\n'
                f"pressure_angle = 24.6\nstiffness = {{ kind = \"constant\", value = {K_MESH!r} }}\n"
            )
    text += (
        '[operating]\ninput_gear = "sun"\noutput_gear = "carrier"\ninput_speed = 100.0\n'
        f"input_torque = {TORQUE!r}\n"
    )
    return text


LINE = re.compile(
    r"^\s+(planet\d+)\s+share (\S+)\s+sun mesh force (\S+) N\s+ring mesh force (\S+) N$", re.M
)


def geardyn_mesh_forces(tmp_path, n, pin_errors):
    path = tmp_path / f"planetary_{n}.toml"
    path.write_text(scene_toml(n, pin_errors))
    report = run_geardyn("modes", path).stdout
    rows = LINE.findall(report)
    assert [r[0] for r in rows] == [f"planet{j + 1}" for j in range(n)], report
    return np.array([float(r[2]) for r in rows]), np.array([float(r[3]) for r in rows])


def test_oracle_reproduces_table_2():
    """The oracle's own check: Lin & Parker (1999) Table 2, N = 4, to 0.5 %."""
    m, k, *_ = lin_parker(4, [(0.0, 0.0)] * 4)
    omega2 = eigh(k, m, eigvals_only=True)
    f = np.sqrt(np.clip(omega2, 0.0, None)) / (2 * math.pi)
    printed = sorted(
        [0.0, 1536.6, 1970.6, 2625.7, 7773.6, 13071.1]
        + 2 * [727.0, 1091.0, 1892.8, 2342.5, 7189.9, 10437.6]
        + [1808.2, 5963.8, 6981.7]
    )
    assert f[0] < 1e-3
    np.testing.assert_allclose(f[1:], printed[1:], rtol=5e-3)


@pytest.mark.parametrize(
    "n, pin_errors",
    [
        (3, [(0.0, 0.0)] * 3),
        (4, [(0.0, 2e-6), (0.0, 0.0), (0.0, 0.0), (0.0, 0.0)]),
        (4, [(1e-6, -1.5e-6), (0.0, 0.0), (-5e-7, 0.0), (0.0, 7e-7)]),
        (5, [(0.0, 0.0), (3e-6, 1e-6), (0.0, 0.0), (0.0, -2e-6), (0.0, 0.0)]),
    ],
)
def test_load_sharing_matches_the_oracle(tmp_path, n, pin_errors):
    sun, ring = geardyn_mesh_forces(tmp_path, n, pin_errors)
    sun_ref, ring_ref = oracle_mesh_forces(n, pin_errors)
    scale = TORQUE / RADIUS["s"] / n  # the equal-sharing mesh force
    np.testing.assert_allclose(sun, sun_ref, rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(ring, ring_ref, rtol=0, atol=1e-9 * scale)
    share, share_ref = sun / sun.sum(), sun_ref / sun_ref.sum()
    np.testing.assert_allclose(share, share_ref, rtol=0, atol=1e-9)
    if any(e != (0.0, 0.0) for e in pin_errors):
        # The errors matter: the check above can fail.
        assert np.abs(share_ref - 1.0 / n).max() > 1e-3
