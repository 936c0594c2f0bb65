"""The carrier frame's gyroscopic and centripetal terms (issue 33 item 1, `[[carrier]]
gyroscopic = true`) against an independent model.

Lin & Parker (1999) eq. (1): `M q'' + Ω_c G q' + (K_b + K_m − Ω_c² K_Ω) q = T`, with G and K_Ω
block-diagonal per member j in the paper's coordinates (x_j, y_j, u_j) for a central member and
(ζ_n, η_n, u_n) for a planet: `G_j = [[0, −2 m_j, 0], [2 m_j, 0, 0], [0, 0, 0]]`,
`K_Ω,j = diag(m_j, m_j, 0)`, Ω_c the carrier's speed. They are written here into the contact-loss
reference of `test_planetary_reference.py` (the paper's model in its own notation, DOP853 at
rtol 1e-12 between stiffness switches, contact changes as events), with the sun and the carrier
held torsionally (k_su, k_cu on u_s, u_c: the papers' gyroscopic analyses hold every central
member; a free rotation is refused with the option, docs/planetary.md). geardyn: `simulate` of
the same scene with `gyroscopic = true`.

Closed-form checks: a conserved energy and the frequency split of an isolated member (below).
"""

import math
import re
import subprocess

import numpy as np
import pytest

import test_planetary_reference as ref_model
from test_planetary_reference import MASS, N, RADIUS, SPEED, TEETH, TORQUE

K_SUN_U, K_CARRIER_U = 2e8, 5e8  # torsional supports on u_s, u_c, N/m
OMEGA_C = SPEED * TEETH["s"] / (TEETH["s"] + TEETH["r"])  # sun ccw, ring held (eq. P1)


def scene_text(gyroscopic=True):
    t = ref_model.scene_text()
    sun_support = f'ground_stiffness = {K_SUN_U * RADIUS["s"] ** 2!r}\n'
    t = t.replace('[[gear]]\nname = "ring"', sun_support + '[[gear]]\nname = "ring"', 1)
    carrier = f'ground_stiffness = {K_CARRIER_U * RADIUS["c"] ** 2!r}\n'
    if gyroscopic:
        carrier += "gyroscopic = true\n"
    t = t.replace('fixed = "ring"\n', 'fixed = "ring"\n' + carrier, 1)
    return t


class GyroscopicReference(ref_model.Reference):
    """The reference model with the supports and Lin & Parker's eq. (1) terms at Ω_c."""

    def __init__(self, gyroscopic=True):
        super().__init__()
        col = {"c": 0, "r": 3, "s": 6}
        self.k[col["s"] + 2, col["s"] + 2] += K_SUN_U
        self.k[col["c"] + 2, col["c"] + 2] += K_CARRIER_U
        if gyroscopic:
            g = np.zeros((self.dof, self.dof))
            k_omega = np.zeros((self.dof, self.dof))
            members = [(col[h], MASS[h]) for h in "crs"]
            members += [(9 + 3 * j, MASS["p"]) for j in range(N)]
            for i, m in members:
                g[i:i + 3, i:i + 3] = [[0.0, -2.0 * m, 0.0], [2.0 * m, 0.0, 0.0], [0.0, 0.0, 0.0]]
                k_omega[i:i + 3, i:i + 3] = np.diag([m, m, 0.0])
            self.c = self.c + OMEGA_C * g
            self.k = self.k - OMEGA_C ** 2 * k_omega
            self.g, self.k_omega = g, k_omega

    def elastic(self, q):
        return q  # held torsionally: no rigid-body mode


def run_geardyn(tmp_path, geardyn_bin, text, period, method):
    scene = tmp_path / "scene.toml"
    scene.write_text(text)
    csv = tmp_path / "run.csv"
    done = subprocess.run(
        [str(geardyn_bin), "simulate", str(scene), "--out", str(csv), "--stop-time",
         repr(ref_model.PERIODS * period), "--output-interval",
         repr(period / ref_model.SAMPLES_PER_PERIOD), "--verbose", *method],
        check=True, capture_output=True, text=True)
    data = np.genfromtxt(csv, delimiter=",", names=True, deletechars="")
    counted = int(re.search(r"(\d+) events", done.stdout + done.stderr).group(1))
    return data, counted


@pytest.mark.parametrize("method", [["--method", "exact"],
                                    ["--method", "rk", "--rk-method", "dop853", "--rtol", "1e-11",
                                     "--atol", "1e-18"]])
def test_gyroscopic_time_series_match_the_reference(tmp_path, geardyn_bin, method):
    """Every mesh's DTE over 25 mesh periods at 700 rad/s with contact loss, gyroscopic = true:
    to 1e-8 of the static deflection, the same contact changes; and the terms matter (the run
    without them differs by far more)."""
    ref = GyroscopicReference()
    period = 1.0 / ref.frequency
    data, counted = run_geardyn(tmp_path, geardyn_bin, scene_text(), period, method)
    times = data["time"]
    ours, lost_time, events = ref.run(times)
    plain, _, _ = GyroscopicReference(gyroscopic=False).run(times)
    worst = effect = 0.0
    for j, name in enumerate(ref_model.MESHES):
        d = np.max(np.abs(data[f"{name}.dte"] - ours[:, j])) / ref.static_deflection
        e = np.max(np.abs(plain[:, j] - ours[:, j])) / ref.static_deflection
        frac = data[f"{name}.contact_loss_fraction"][-1]
        print(f"{name}: DTE {d:.2e} of the static deflection (gyroscopic terms change it by "
              f"{e:.2e}); contact loss {frac:.9f} (reference {lost_time[j] / times[-1]:.9f})")
        worst, effect = max(worst, d), max(effect, e)
        assert abs(frac - lost_time[j] / times[-1]) <= 1e-8, name
    print(f"{method[1]}: events geardyn {counted}, reference {events}; worst {worst:.2e}, "
          f"effect of the terms {effect:.2e}")
    assert events > 50
    assert counted == events
    assert worst <= 1e-8, worst
    assert effect >= 1e-3, effect


def test_modes_report_the_gyroscopic_eigenvalues(tmp_path, geardyn_bin):
    """`geardyn modes` with gyroscopic = true: the roots of det(λ²M + λΩ_c G + K − Ω_c²K_Ω) of
    the reference's mean system (numpy's eigenvalues of the first-order form), every frequency
    to 1e-9 relative; without the option, the undamped frequencies."""
    for gyro in (True, False):
        ref = GyroscopicReference(gyroscopic=gyro)
        k = ref.k + ref_model.K_MESH * ref.rows.T @ ref.rows
        n = ref.dof
        minv = np.diag(ref.minv)
        g = OMEGA_C * ref.g if gyro else np.zeros((n, n))
        a = np.block([[np.zeros((n, n)), np.eye(n)], [-minv @ k, -minv @ g]])
        lam = np.linalg.eigvals(a)
        expected = np.sort(lam.imag[lam.imag > 0]) / (2 * math.pi)
        scene = tmp_path / "scene.toml"
        scene.write_text(scene_text(gyro))
        out = subprocess.run([str(geardyn_bin), "modes", str(scene)], check=True,
                             capture_output=True, text=True).stdout
        got = np.array([float(m.group(1)) for m in
                        re.finditer(r"^\s+\d+\s+([0-9.]+)", out, re.MULTILINE)])
        assert len(got) == n, out
        rel = np.max(np.abs(got - expected) / expected)
        print(f"gyroscopic={gyro}: largest relative difference {rel:.2e}")
        assert rel <= 1e-6  # the report prints 3 decimals of Hz


def test_mirrored_stage_gives_the_same_time_series(tmp_path, geardyn_bin):
    """The same stage turning clockwise (`model.input_rotation = "cw"`: Ω_c < 0 and the stage's
    sense σ = −1, whose planets' (ζ, η) are left-handed) is the mirror image of the ccw run,
    with planet n at ψ_n mirrored to the planet at −ψ_n (planet 2 ↔ planet 3): every mesh's DTE
    the same to 1e-9 of the static deflection, with the gyroscopic terms on
    (a sign slip in σ's block of G would change them by the size of the terms' effect)."""
    ref = GyroscopicReference()
    period = 1.0 / ref.frequency
    method = ["--method", "exact"]
    ccw, n_ccw = run_geardyn(tmp_path, geardyn_bin, scene_text(), period, method)
    text = scene_text().replace('bearings = "compliant"\n',
                                'bearings = "compliant"\ninput_rotation = "cw"\n', 1)
    cw, n_cw = run_geardyn(tmp_path, geardyn_bin, text, period, method)
    mirror = {1: 1, 2: 3, 3: 2}
    worst = max(np.max(np.abs(cw[f"{kind}{j}.dte"] - ccw[f"{kind}{mirror[j]}.dte"]))
                for kind in ("sp", "rp") for j in mirror)
    print(f"cw against ccw: {worst / ref.static_deflection:.2e} of the static deflection; "
          f"events {n_cw} / {n_ccw}")
    assert n_cw == n_ccw
    assert worst <= 1e-9 * ref.static_deflection


def test_isolated_member_splits_to_omega_plus_minus_carrier_speed(tmp_path, geardyn_bin):
    """Closed form: a member translating on an isotropic support k in the frame turning at
    Ω_c, `m w'' + 2 m Ω_c ẑ × w' + (k − m Ω_c²) w = 0`, has (with z = x + iy, z = e^{iωt})
    `(ω + Ω_c)² = k/m`: the pair ω_n = √(k/m) splits to ω_n − Ω_c and ω_n + Ω_c. The sun's
    meshes made soft (1 N/m against its 1e8 N/m bearing, a coupling of relative size ~1e-8)
    leave its translation isolated: `geardyn modes` lists both roots to 1e-6."""
    blocks = scene_text().split("[[mesh]]")
    for i, b in enumerate(blocks):
        if re.search(r'name = "sp\d"', b):
            b = re.sub(r"stiffness = \{[^\n]*\}", 'stiffness = { kind = "constant", value = 1.0 }', b)
            blocks[i] = re.sub(r"damping = [^\n]*", "damping = 0.0", b)
    text = "[[mesh]]".join(blocks)
    assert text.count("value = 1.0 }") == N
    scene = tmp_path / "scene.toml"
    scene.write_text(text)
    out = subprocess.run([str(geardyn_bin), "modes", str(scene)], check=True,
                         capture_output=True, text=True).stdout
    got = np.array([float(m.group(1)) for m in re.finditer(r"^\s+\d+\s+([0-9.]+)", out,
                                                          re.MULTILINE)])
    omega_n = math.sqrt(ref_model.K_BEARING / MASS["s"])
    for root in (omega_n - OMEGA_C, omega_n + OMEGA_C):
        f = root / (2 * math.pi)
        nearest = got[np.argmin(np.abs(got - f))]
        print(f"closed form {f:.6f} Hz, geardyn {nearest:.3f} Hz")
        assert abs(nearest - f) <= 1e-6 * f
    # Without the frame terms the pair is double at ω_n.
    f0 = omega_n / (2 * math.pi)
    assert np.min(np.abs(got - f0)) > 0.1 * OMEGA_C / (2 * math.pi)


def test_fmu_with_gyroscopic_terms_matches_simulate(tmp_path, geardyn_bin):
    """`fmu build` of the contact-loss stage with gyroscopic = true: fmpy validation finds no
    problem, and under fmpy every mesh's DTE and contact state equal `geardyn simulate` on the
    same grid (1e-5 s over 10 ms) to 1e-12 of the largest DTE."""
    import fmpy
    import fmpy.validation

    from conftest import native_run

    scene = tmp_path / "gyro_stage.toml"
    scene.write_text(scene_text().replace('name = "planetary_reference"', 'name = "gyro_stage"'))
    subprocess.run([str(geardyn_bin), "fmu", "build", str(scene), "--out", str(tmp_path)],
                   check=True, capture_output=True, text=True)
    fmu = tmp_path / "gyro_stage.fmu"
    assert fmpy.validation.validate_fmu(str(fmu)) == []
    h, stop = 1e-5, 0.01
    native = native_run(scene, tmp_path / "native.csv", h, stop)
    cont = [f"{m}.dte" for m in ref_model.MESHES]
    discrete = [f"{m}.contact_state" for m in ref_model.MESHES]
    r = fmpy.simulate_fmu(str(fmu), fmi_type="CoSimulation", output_interval=h, stop_time=stop,
                          output=cont + discrete)
    assert len(r) == len(native)
    amp = max(np.abs(native[c]).max() for c in cont)
    err = max(np.abs(r[c] - native[c]).max() for c in cont)
    lost = sum(int((native[c] != 1).sum()) for c in discrete)
    print(f"fmpy vs simulate: {err / amp:.2e} of the largest DTE; {lost} rows out of contact")
    assert err <= 1e-12 * amp
    assert lost > 0
    for c in discrete:
        assert np.array_equal(r[c], native[c]), c


def test_refusals_name_the_option(tmp_path, geardyn_bin):
    """A free train, a sweep and harmonic balance are refused with the reason."""
    free = ref_model.scene_text().replace('fixed = "ring"\n', 'fixed = "ring"\ngyroscopic = true\n')
    cases = [(free, ["simulate", "--out", str(tmp_path / "x.csv")], "turns freely"),
             (free, ["modes"], "turns freely"),
             (scene_text(), ["sweep", "--speed", "500:700:3", "--out",
                             str(tmp_path / "s.csv"), "--plot", str(tmp_path / "s.svg")],
              "a speed sweep changes the input speed"),
             (scene_text(), ["hb", "--speed", "500:700", "--out", str(tmp_path / "h.csv")],
              "harmonic balance changes the input speed")]
    for text, args, why in cases:
        scene = tmp_path / "scene.toml"
        scene.write_text(text)
        done = subprocess.run([str(geardyn_bin), args[0], str(scene), *args[1:]],
                              capture_output=True, text=True)
        assert done.returncode != 0, args
        assert why in done.stderr and "gyroscopic = true" in done.stderr, done.stderr
