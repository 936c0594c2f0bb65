"""Back flanks on their own line of action (issue 33, "Back flanks"; docs/train.md,
docs/planetary.md): independent scipy models with backlash where the back flanks touch,
against `geardyn simulate` (exact propagator and DOP853).

When the back flanks touch, the contact force acts along the other common tangent of the base
circles: the drive line of action mirrored about the line of centres. The rotational part of
the mesh deflection keeps its base radii; the translations see the mirrored line. Both models
below are written from the geometry in their own notation, not from the Rust code:

- a 3-planet stage (the model of `test_planetary_reference.py`, Lin & Parker 1999, σ = +1) with
  backlash. The back-flank deflections in the paper's notation (α → −α in the translations):

      δ̃_sn = −x_s sin(ψ_n + α) + y_s cos(ψ_n + α) + ζ_n sin α − η_n cos α + u_s + u_n
      δ̃_rn = −x_r sin(ψ_n − α) + y_r cos(ψ_n − α) − ζ_n sin α − η_n cos α + u_r − u_n

  (sun mesh: drive line at ψ_n + π/2 − α, the line of centres along e_r; its mirror image, in
  the drive deflection's sign, at ψ_n + π/2 + α; the ring mesh alike with α → −α);
- a free spur pair on compliant bearings (x, y on each gear): the pinion at the origin turning
  ccw, the drive line of action ℓ = (cos α, sin α) (the scene's `centre_angle = 0`,
  β = centre_angle + α), the line of centres ĉ at 90° − α from it on the side away from the
  pinion's rotation (ĉ = ℓ turned by −(90° − α)); the back line ℓ̃ = ℓ − 2(ℓ·ĉ)ĉ, at
  angle 3α here:

      δ = u_a − u_b + (w_a − w_b)·ℓ,   δ̃ = u_a − u_b + (w_a − w_b)·ℓ̃

  (rotations positive in each gear's own sense of rotation, docs/train.md).

Each mesh: drive force k(t)δ + c δ' for δ > 0, back force k(t)(δ̃ + 2b) + c δ̃' for δ̃ < −2b,
both at once where both hold (tooth wedging), none between (`backflank_reference.run_hybrid`).
The stage and the pair never wedge; a third model, the EV stage of `tests/hb_back_flanks.rs`
with an STE at 750 rad/s, is wedged again and again. Checked: every mesh's DTE to ≤ 1e-8 of
the static deflection, and the same number of contact changes of every kind, with back
contacts (and wedged intervals) among them.
"""

import math
import re
import subprocess

import numpy as np
import pytest

import test_planetary_reference as stage
from backflank_reference import run_hybrid
from contact_ivp import switch_times

STAGE_BACKLASH = 4e-7  # m, 2b: about 0.56 of the static deflection


class StageWithBackFlanks(stage.Reference):
    """The planetary reference with backlash and its back-flank rows (`p`: the stage's
    parameters, those of `test_planetary_reference` unless given; `ste`: the amplitude of a
    cosine STE `e_j = ste·cos 2πp_j` on every mesh at its mesh phase p_j)."""

    def __init__(self, p=None, clearance=STAGE_BACKLASH, ste=0.0):
        super().__init__(p)
        p = self.p
        col = {"r": 3, "s": 6}
        back = []
        sa, ca = math.sin(p.ALPHA), math.cos(p.ALPHA)
        for j in range(p.N):
            psi = 2 * math.pi * j / p.N
            z, e, u = 9 + 3 * j, 10 + 3 * j, 11 + 3 * j
            b = np.zeros(self.dof)  # sun mesh, back flanks
            b[col["s"]:col["s"] + 3] = -math.sin(psi + stage.ALPHA), math.cos(psi + stage.ALPHA), 1.0
            b[z], b[e], b[u] = sa, -ca, 1.0
            back.append(b)
            b = np.zeros(self.dof)  # ring mesh, back flanks
            b[col["r"]:col["r"] + 3] = -math.sin(psi - stage.ALPHA), math.cos(psi - stage.ALPHA), 1.0
            b[z], b[e], b[u] = -sa, -ca, -1.0
            back.append(b)
        self.back_rows = np.array(back)
        self.clearance = clearance
        self.c_mesh = p.C_MESH
        self.ste_amplitude = ste

    def ste(self, j, t):
        """`(e_j, de_j/dt)` at `t` (scalar or array)."""
        w = 2 * math.pi * self.frequency
        arg = 2 * math.pi * self.phases[j] + w * np.asarray(t)
        return self.ste_amplitude * np.cos(arg), -self.ste_amplitude * w * np.sin(arg)

    def start(self):
        """The static start with the STE at t = 0: the mean stiffness, `K̄ q = F + Σ k̄ e_j(0)
        rows[j]` (the start the scene's `initial.dte = "static"` states)."""
        k = self.k + self.p.K_MESH * self.rows.T @ self.rows
        f = self.force + self.p.K_MESH * sum(self.ste(j, 0.0)[0] * row
                                             for j, row in enumerate(self.rows))
        q = np.linalg.lstsq(k, f, rcond=1e-12)[0]
        return np.concatenate([self.elastic(q), np.zeros(self.dof)])

    def breaks(self, t_end):
        meshes = len(self.rows)
        return switch_times([self.frequency] * meshes, self.phases,
                            [[0.0, self.switch]] * meshes, t_end)


def stage_scene():
    return stage.scene_text().replace(
        'contact = "contact_loss"', f'contact = "backlash"\nbacklash = {STAGE_BACKLASH!r}')


# The spur pair on bearings.
ALPHA_DEG = 20.0
ALPHA = math.radians(ALPHA_DEG)
R_A, R_B = 0.03, 0.0456
I_A, I_B = 3e-4, 9e-4  # kg m²
M_A, M_B = 1.2, 2.0
K_X, K_Y, C_B = 2e8, 1.5e8, 300.0
K_MESH, PP, CR, C_MESH = 4e8, 0.4, 1.6, 150.0
Z_A = 25
PAIR_TORQUE, PAIR_SPEED, PAIR_BACKLASH = 8.0, 2000.0, 2e-7
PAIR_PERIODS, PAIR_SAMPLES = 30, 31


class PairWithBackFlanks:
    """q = [x_a, y_a, u_a, x_b, y_b, u_b]."""

    def __init__(self):
        self.dof = 6
        self.mass = np.array([M_A, M_A, I_A / R_A**2, M_B, M_B, I_B / R_B**2])
        self.k = np.diag([K_X, K_Y, 0.0, K_X, K_Y, 0.0])
        self.c = np.diag([C_B, C_B, 0.0, C_B, C_B, 0.0])
        ell = np.array([math.cos(ALPHA), math.sin(ALPHA)])
        turn = -(math.pi / 2 - ALPHA)
        centre = np.array([math.cos(ALPHA + turn), math.sin(ALPHA + turn)])
        back = ell - 2 * (ell @ centre) * centre

        def row(line):
            return np.array([line[0], line[1], 1.0, -line[0], -line[1], -1.0])

        self.rows = np.array([row(ell)])
        self.back_rows = np.array([row(back)])
        self.dte = np.array([[0.0, 0.0, 1.0, 0.0, 0.0, -1.0]])
        force = PAIR_TORQUE / R_A
        self.force = np.array([0.0, 0.0, force, 0.0, 0.0, -force])
        self.static_deflection = force / K_MESH
        self.frequency = Z_A * PAIR_SPEED / (2 * math.pi)
        f = CR - math.floor(CR)
        self.low = K_MESH * (1 - f * PP)
        self.high = self.low + PP * K_MESH
        self.switch = 1.0 - f
        self.clearance = PAIR_BACKLASH
        self.c_mesh = C_MESH
        self.rigid = np.array([0.0, 0.0, 1.0, 0.0, 0.0, 1.0])

    def stiffness(self, _j, t):
        s = (self.frequency * t) % 1.0
        return self.low if s < self.switch else self.high

    def breaks(self, t_end):
        return switch_times([self.frequency], [0.0], [[0.0, self.switch]], t_end)

    def elastic(self, q):
        r, m = self.rigid, self.mass
        return q - r * (r @ (m * q)) / (r @ (m * r))

    def start(self):
        k = self.k + K_MESH * self.rows.T @ self.rows
        q = np.linalg.lstsq(k, self.force, rcond=1e-12)[0]
        return np.concatenate([self.elastic(q), np.zeros(self.dof)])


def pair_scene():
    gear = lambda name, teeth, r, inertia, mass: (
        f'[[gear]]\nname = "{name}"\nteeth = {teeth}\nbase_radius = {r!r}\ninertia = {inertia!r}\n'
        f"mass = {mass!r}\nbearing_stiffness = [{K_X!r}, {K_Y!r}]\n"
        f"bearing_damping = [{C_B!r}, {C_B!r}]\n")
    return ('name = "backflank_pair"\n[model]\nbearings = "compliant"\n'
            + gear("pinion", Z_A, R_A, I_A, M_A) + gear("wheel", 38, R_B, I_B, M_B)
            + f'[[mesh]]\nname = "m"\npinion = "pinion"\ngear = "wheel"\ncontact = "backlash"\n'
              f"backlash = {PAIR_BACKLASH!r}\npressure_angle = {ALPHA_DEG!r}\ncentre_angle = 0.0\n"
              f"damping = {C_MESH!r}\n"
              f'stiffness = {{ kind = "rectangular", mean = {K_MESH!r}, '
              f"peak_to_peak_ratio = {PP!r}, contact_ratio = {CR!r} }}\n"
            + f'[operating]\ninput_gear = "pinion"\noutput_gear = "wheel"\n'
              f"input_speed = {PAIR_SPEED!r}\ninput_torque = {PAIR_TORQUE!r}\n")


METHODS = [["--method", "exact"],
           ["--method", "rk", "--rk-method", "dop853", "--rtol", "1e-11", "--atol", "1e-18"]]


def compare(tmp_path, geardyn_bin, method, ref, text, names, periods, samples):
    scene = tmp_path / "scene.toml"
    scene.write_text(text)
    period = 1.0 / ref.frequency
    csv = tmp_path / "run.csv"
    done = subprocess.run(
        [str(geardyn_bin), "simulate", str(scene), "--out", str(csv), "--stop-time",
         repr(periods * period), "--output-interval", repr(period / samples), "--verbose",
         *method], check=True, capture_output=True, text=True)
    data = np.genfromtxt(csv, delimiter=",", names=True, deletechars="")
    ours, counts = run_hybrid(ref, data["time"], max_step=period / 200)
    worst = 0.0
    for j, name in enumerate(names):
        d = np.max(np.abs(data[f"{name}.dte"] - ours[:, j])) / ref.static_deflection
        worst = max(worst, d)
    counted = int(re.search(r"(\d+) events", done.stdout + done.stderr).group(1))
    back_rows = sum(int(np.sum(data[f"{name}.contact_state"] == -1)) for name in names)
    print(f"{method[1]}: events geardyn {counted}, reference {sum(counts.values())} {counts}; "
          f"rows in back contact {back_rows}; worst DTE {worst:.2e} of the static deflection")
    # Both flanks of a tooth pair pressed at once (tooth wedging: the centres approach by more
    # than the backlash): not in these runs (`test_wedged_stage_matches_geardyn` has it).
    assert counts.pop("wedged") == 0
    return worst, counted, counts, back_rows


@pytest.mark.parametrize("method", METHODS)
def test_stage_back_flanks_match_geardyn(tmp_path, geardyn_bin, method):
    """The 3-planet stage at 700 rad/s with 2b = 0.4 µm: the ring meshes separate and hit
    their back flanks every few periods (36 back contacts in 25 mesh periods)."""
    ref = StageWithBackFlanks()
    worst, counted, counts, back_rows = compare(
        tmp_path, geardyn_bin, method, ref, stage_scene(), stage.MESHES, stage.PERIODS,
        stage.SAMPLES_PER_PERIOD)
    assert counts["S>B"] >= 20 and back_rows > 0, counts
    assert counted == sum(counts.values())
    assert worst <= 1e-8, worst


@pytest.mark.parametrize("method", METHODS)
def test_pair_on_bearings_back_flanks_match_geardyn(tmp_path, geardyn_bin, method):
    """A free spur pair on compliant bearings at 2000 rad/s with 2b = 0.2 µm (0.3 of the
    static deflection): the teeth separate every period and hit the back flanks (10 back
    contacts in 30 mesh periods)."""
    ref = PairWithBackFlanks()
    worst, counted, counts, back_rows = compare(
        tmp_path, geardyn_bin, method, ref, pair_scene(), ["m"], PAIR_PERIODS, PAIR_SAMPLES)
    assert counts["S>B"] >= 5 and back_rows > 0, counts
    assert counted == sum(counts.values())
    assert worst <= 1e-8, worst


def test_back_line_changes_the_answer(tmp_path, geardyn_bin):
    """The control: the same stage with the back flanks on the drive rows (the old model)
    differs from geardyn by far more than the tolerance, so the test above can fail."""
    ref = StageWithBackFlanks()
    ref.back_rows = ref.rows.copy()
    worst, counted, counts, _ = compare(
        tmp_path, geardyn_bin, METHODS[0], ref, stage_scene(), stage.MESHES, stage.PERIODS,
        stage.SAMPLES_PER_PERIOD)
    assert worst > 1e-3 or counted != sum(counts.values()), (worst, counted, counts)


# Tooth wedging: the EV stage of `tests/hb_back_flanks.rs` (`examples/planetary/ev_reducer_3p`
# at 10 N·m, a 1 µm cosine STE on every mesh, 2b = 1 µm) at 750 rad/s, where `simulate`
# stopped with "65 state events without progress" before both flanks pressed at once were
# modelled: the planets swing radially by more than b / sin α, so the ring meshes are
# wedged from the first mesh period on.
EV_SPEED, EV_TORQUE, EV_STE, EV_BACKLASH = 750.0, 10.0, 1e-6, 1e-6
EV_PERIODS, EV_SAMPLES = 26, 23


def ev_stage(repo_root):
    """The EV stage's scene text and its parameters for the reference, read from the shipped
    scene (`p` in the notation of `test_planetary_reference`)."""
    import tomllib
    from types import SimpleNamespace

    path = repo_root / "examples" / "planetary" / "ev_reducer_3p.toml"
    text = path.read_text()
    scene = tomllib.loads(text)
    gears = {g["name"]: g for g in scene["gear"]}
    carrier = scene["carrier"][0]
    mesh = scene["mesh"][0]
    sun, ring, planet = gears["sun"], gears["ring"], gears["planet1"]
    members = {"s": sun, "r": ring, "p": planet}
    radius = {h: g["base_radius"] for h, g in members.items()}
    radius["c"] = carrier["radius"]
    stiffness = mesh["stiffness"]
    bearings = {tuple(g["bearing_stiffness"]) + tuple(g["bearing_damping"])
                for g in [*gears.values(), carrier]}
    assert len(bearings) == 1, bearings  # the reference has one bearing stiffness
    k_bearing, _, c_bearing, _ = bearings.pop()
    assert all(g["position_angle"] == 120.0 * j for j, g in
               enumerate(gears[f"planet{i}"] for i in (1, 2, 3)))
    p = SimpleNamespace(
        TEETH={h: g["teeth"] for h, g in members.items()}, N=3,
        ALPHA=math.radians(mesh["pressure_angle"]),
        MASS={**{h: g["mass"] for h, g in members.items()}, "c": carrier["mass"]},
        I_OVER_R2={**{h: g["inertia"] / radius[h] ** 2 for h, g in members.items()},
                   "c": carrier["inertia"] / radius["c"] ** 2},
        RADIUS=radius, K_BEARING=k_bearing, C_BEARING=c_bearing,
        K_RING_U=ring["ground_stiffness"] / radius["r"] ** 2,
        C_RING_U=ring["ground_damping"] / radius["r"] ** 2,
        K_MESH=stiffness["mean"], PP_RATIO=stiffness["peak_to_peak_ratio"],
        CONTACT_RATIO=stiffness["contact_ratio"], C_MESH=mesh["damping"],
        SPEED=EV_SPEED, TORQUE=EV_TORQUE)
    assert all(m["damping"] == p.C_MESH and m["stiffness"] == stiffness for m in scene["mesh"])
    line = ('stiffness = { kind = "rectangular", mean = 4e8, peak_to_peak_ratio = 0.25, '
            'contact_ratio = 1.55 }')
    assert text.count(line) == 6
    text = (text.replace("input_torque = 150.0", f"input_torque = {EV_TORQUE!r}")
            .replace(line, f"{line}\nste = {{ cos = [{EV_STE!r}] }}")
            .replace('contact = "contact_loss"',
                     f'contact = "backlash"\nbacklash = {EV_BACKLASH!r}'))
    text = re.sub(r"(?m)^input_speed = .*$", f"input_speed = {EV_SPEED!r}", text)
    return text, p


@pytest.mark.parametrize("method", METHODS)
def test_wedged_stage_matches_geardyn(tmp_path, geardyn_bin, repo_root, method):
    """Both flanks of a mesh pressed at once (docs/planetary.md, "Tooth wedging"): the EV
    stage at 750 rad/s over 26 mesh periods (past the instant where the old model stopped,
    11.9 ms), the ring meshes wedged again and again. Every mesh's DTE to ≤ 1e-8 of the static
    deflection, the same contact changes, and rows in the wedged state (`contact_state` 2)."""
    text, p = ev_stage(repo_root)
    ref = StageWithBackFlanks(p, clearance=EV_BACKLASH, ste=EV_STE)
    scene = tmp_path / "scene.toml"
    scene.write_text(text)
    period = 1.0 / ref.frequency
    assert EV_PERIODS * period > 11.9e-3
    csv = tmp_path / "run.csv"
    done = subprocess.run(
        [str(geardyn_bin), "simulate", str(scene), "--out", str(csv), "--stop-time",
         repr(EV_PERIODS * period), "--output-interval", repr(period / EV_SAMPLES), "--verbose",
         *method], check=True, capture_output=True, text=True)
    data = np.genfromtxt(csv, delimiter=",", names=True, deletechars="")
    ours, counts = run_hybrid(ref, data["time"], max_step=period / 200)
    worst = max(np.max(np.abs(data[f"{name}.dte"] - ours[:, j])) / ref.static_deflection
                for j, name in enumerate(stage.MESHES))
    counted = int(re.search(r"(\d+) events", done.stdout + done.stderr).group(1))
    wedged_rows = sum(int(np.sum(data[f"{name}.contact_state"] == 2)) for name in stage.MESHES)
    wedged_samples = counts.pop("wedged")
    print(f"{method[1]}: events geardyn {counted}, reference {sum(counts.values())} {counts}; "
          f"mesh rows wedged {wedged_rows} (reference {wedged_samples}); "
          f"worst DTE {worst:.2e} of the static deflection")
    assert counts["D>W"] >= 10 and counts["W>D"] >= 10 and wedged_rows >= 100, counts
    assert wedged_rows == wedged_samples
    assert counted == sum(counts.values())
    assert worst <= 1e-8, worst


def test_wedging_changes_the_answer(tmp_path, geardyn_bin, repo_root):
    """The control: the reference without the wedged state (a flank watched only while the
    other is open, the old model) differs from geardyn by far more than the tolerance over
    the same run, so the test above can fail."""
    text, p = ev_stage(repo_root)
    ref = StageWithBackFlanks(p, clearance=EV_BACKLASH, ste=EV_STE)
    scene = tmp_path / "scene.toml"
    scene.write_text(text)
    period = 1.0 / ref.frequency
    csv = tmp_path / "run.csv"
    subprocess.run(
        [str(geardyn_bin), "simulate", str(scene), "--out", str(csv), "--stop-time",
         repr(EV_PERIODS * period), "--output-interval", repr(period / EV_SAMPLES),
         *METHODS[0]], check=True, capture_output=True, text=True)
    data = np.genfromtxt(csv, delimiter=",", names=True, deletechars="")
    ours, counts = run_hybrid(ref, data["time"], max_step=period / 200, wedging=False)
    worst = max(np.max(np.abs(data[f"{name}.dte"] - ours[:, j])) / ref.static_deflection
                for j, name in enumerate(stage.MESHES))
    print(f"without wedging: worst DTE {worst:.2e} of the static deflection, {counts}")
    assert worst > 1e-2, worst
