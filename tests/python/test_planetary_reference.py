"""Independent time-series model of a planetary stage with contact loss (issue 33, acceptance 4).

The lumped model of Lin & Parker (1999) written here from the paper's equations in its own
notation (docs/planetary.md eq. P3-P8 with σ = +1, the sun turning and loaded ccw), not from
the Rust code: per central member h in {c, r, s} the coordinates (x_h, y_h, u_h = r_h θ_h), per
planet n (ζ_n, η_n, u_n); translations in the carrier frame, no gyroscopic terms,

    δ_sn = −x_s sin ψ_sn + y_s cos ψ_sn − ζ_n sin α − η_n cos α + u_s + u_n,  ψ_sn = ψ_n − α
    δ_rn = −x_r sin ψ_rn + y_r cos ψ_rn + ζ_n sin α − η_n cos α + u_r − u_n,  ψ_rn = ψ_n + α
    δ_ζn = x_c cos ψ_n + y_c sin ψ_n − ζ_n,   δ_ηn = −x_c sin ψ_n + y_c cos ψ_n + u_c − η_n,

central bearings k (x, y), the ring's torsional support, pin bearings; M q'' + C q' + K_b q +
Σ b_j F_j = F with the mesh force F_j = k_j(t) δ_j + c_m δ'_j while δ_j >= 0 (contact loss: 0
when δ_j < 0). The sun carries T on u_s (F = T/r_s), the carrier the balanced load (eq. P9:
−2 T cos α / r_s on u_c), the held ring reacts. Each mesh stiffness is a rectangular wave of
its mesh phase p_j = γ_j + f t, f = Z_s (ω_s − ω_c)/2π, with the mesh phasing of Parker & Lin
(2004) written out here (docs/planetary.md eq. PL1-PL3): sun meshes γ_sn = −Z_s ψ_n/2π, ring
meshes γ_rn = −(Z_p − 1)/2 + Z_r ψ_n/2π (mod 1). Integration: DOP853 at rtol 1e-12 between the
stiffness switches, contact changes as terminal events with the state put on the surface.

geardyn's side: `geardyn simulate` (exact propagator) on the same scene, its mesh DTE columns
and its per-mesh contact-loss fractions and event count.
"""

import math
import re
import subprocess
import sys

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from contact_ivp import switch_times

TEETH = {"s": 20, "p": 22, "r": 64}
N = 3
MODULE = 2e-3
ALPHA_DEG = 20.0
ALPHA = math.radians(ALPHA_DEG)
MASS = {"s": 0.4, "r": 2.35, "c": 5.43, "p": 0.66}
I_OVER_R2 = {"s": 0.39, "r": 3.0, "c": 6.29, "p": 0.61}
K_BEARING, C_BEARING = 1e8, 500.0
K_MESH, PP_RATIO, CONTACT_RATIO, C_MESH = 5e8, 0.4, 1.6, 400.0
K_RING_U, C_RING_U = 1e9, 1e3  # on u_r, N/m and N·s/m
SPEED, TORQUE = 700.0, 20.0
PERIODS = 25
SAMPLES_PER_PERIOD = 29


def base_radius(h):
    return MODULE * TEETH[h] / 2 * math.cos(ALPHA)


RADIUS = {h: base_radius(h) for h in "srp"}
RADIUS["c"] = MODULE * (TEETH["s"] + TEETH["p"]) / 2


def scene_text():
    def member(name, h, extra=""):
        return (
            f'[[gear]]\nname = "{name}"\nteeth = {TEETH[h]}\nbase_radius = {RADIUS[h]!r}\n'
            f"inertia = {I_OVER_R2[h] * RADIUS[h] ** 2!r}\nmass = {MASS[h]!r}\n"
            f"bearing_stiffness = [{K_BEARING!r}, {K_BEARING!r}]\n"
            f"bearing_damping = [{C_BEARING!r}, {C_BEARING!r}]\n{extra}"
        )

    r2 = RADIUS["r"] ** 2
    t = 'name = "planetary_reference"\n[model]\nbearings = "compliant"\n'
    t += member("sun", "s")
    t += member("ring", "r", f"internal = true\nground_stiffness = {K_RING_U * r2!r}\n"
                             f"ground_damping = {C_RING_U * r2!r}\n")
    for j in range(N):
        t += member(f"planet{j + 1}", "p",
                    f'carrier = "carrier"\nposition_angle = {360.0 * j / N!r}\n')
    rc = RADIUS["c"]
    t += (f'[[carrier]]\nname = "carrier"\nradius = {rc!r}\ninertia = {I_OVER_R2["c"] * rc * rc!r}\n'
          f'mass = {MASS["c"]!r}\nbearing_stiffness = [{K_BEARING!r}, {K_BEARING!r}]\n'
          f'bearing_damping = [{C_BEARING!r}, {C_BEARING!r}]\nfixed = "ring"\n')
    for j in range(1, N + 1):
        for pinion, gear, name in (("sun", f"planet{j}", f"sp{j}"), (f"planet{j}", "ring", f"rp{j}")):
            t += (f'[[mesh]]\nname = "{name}"\npinion = "{pinion}"\ngear = "{gear}"\n'
                  f'contact = "contact_loss"\npressure_angle = {ALPHA_DEG!r}\ndamping = {C_MESH!r}\n'
                  f'stiffness = {{ kind = "rectangular", mean = {K_MESH!r}, '
                  f"peak_to_peak_ratio = {PP_RATIO!r}, contact_ratio = {CONTACT_RATIO!r} }}\n")
    t += (f'[operating]\ninput_gear = "sun"\noutput_gear = "carrier"\ninput_speed = {SPEED!r}\n'
          f"input_torque = {TORQUE!r}\n")
    return t


class Reference:
    """The model of the module docstring; meshes ordered sp1, rp1, sp2, rp2, ..."""

    def __init__(self, p=None):
        # `p`: the stage's parameters (this module's constants unless given).
        p = p or sys.modules[__name__]
        self.p = p
        dof = 9 + 3 * p.N
        col = {"c": 0, "r": 3, "s": 6}
        planet = lambda j: 9 + 3 * j
        m = np.zeros(dof)
        for h, i in col.items():
            m[i:i + 2] = p.MASS[h]
            m[i + 2] = p.I_OVER_R2[h]
        for j in range(p.N):
            m[planet(j):planet(j) + 2] = p.MASS["p"]
            m[planet(j) + 2] = p.I_OVER_R2["p"]
        k = np.zeros((dof, dof))
        c = np.zeros((dof, dof))

        def spring(b, stiffness, damping):
            k[:] += stiffness * np.outer(b, b)
            c[:] += damping * np.outer(b, b)

        def unit(i):
            b = np.zeros(dof)
            b[i] = 1.0
            return b

        for h in "crs":
            spring(unit(col[h]), p.K_BEARING, p.C_BEARING)
            spring(unit(col[h] + 1), p.K_BEARING, p.C_BEARING)
        spring(unit(col["r"] + 2), p.K_RING_U, p.C_RING_U)
        rows, dte, phases = [], [], []
        zs, zp, zr = p.TEETH["s"], p.TEETH["p"], p.TEETH["r"]
        for j in range(p.N):
            psi = 2 * math.pi * j / p.N
            z, e, u = planet(j), planet(j) + 1, planet(j) + 2
            b = np.zeros(dof)  # sun mesh
            ps = psi - p.ALPHA
            b[col["s"]:col["s"] + 3] = -math.sin(ps), math.cos(ps), 1.0
            b[z], b[e], b[u] = -math.sin(p.ALPHA), -math.cos(p.ALPHA), 1.0
            rows.append(b)
            d = np.zeros(dof)
            d[col["s"] + 2], d[u] = 1.0, 1.0
            dte.append(d)
            phases.append((-zs * psi / (2 * math.pi)) % 1.0)  # PL1
            b = np.zeros(dof)  # ring mesh
            pr = psi + p.ALPHA
            b[col["r"]:col["r"] + 3] = -math.sin(pr), math.cos(pr), 1.0
            b[z], b[e], b[u] = math.sin(p.ALPHA), -math.cos(p.ALPHA), -1.0
            rows.append(b)
            d = np.zeros(dof)
            d[col["r"] + 2], d[u] = 1.0, -1.0
            dte.append(d)
            phases.append((-(zp - 1) / 2 + zr * psi / (2 * math.pi)) % 1.0)  # PL3 + PL2
            b = np.zeros(dof)  # pin, radial
            b[col["c"]], b[col["c"] + 1], b[z] = math.cos(psi), math.sin(psi), -1.0
            spring(b, p.K_BEARING, p.C_BEARING)
            b = np.zeros(dof)  # pin, tangential
            b[col["c"]:col["c"] + 3] = -math.sin(psi), math.cos(psi), 1.0
            b[e] = -1.0
            spring(b, p.K_BEARING, p.C_BEARING)
        self.minv = 1.0 / m
        self.mass = m
        # The stage turns freely with the ring held (sun, planets and carrier rolling): one
        # rigid-body mode, the null vector of the mean stiffness. The DTE is the rotational
        # part of the elastic motion, mass-orthogonal to it (Liu 2007 eq. 3.2's split, which
        # geardyn's elastic coordinates use).
        w, v = np.linalg.eigh(k + p.K_MESH * np.array(rows).T @ np.array(rows))
        assert w[0] < 1e-6 * w[1], w[:2]
        self.rigid = v[:, 0]
        self.k, self.c = k, c
        self.rows, self.dte = np.array(rows), np.array(dte)
        self.phases = np.array(phases)
        self.force = np.zeros(dof)
        self.force[col["s"] + 2] = p.TORQUE / p.RADIUS["s"]
        self.force[col["c"] + 2] = -2 * p.TORQUE * math.cos(p.ALPHA) / p.RADIUS["s"]  # eq. P9
        w_s = p.SPEED
        w_c = p.SPEED * zs / (zs + zr)
        self.frequency = zs * (w_s - w_c) / (2 * math.pi)
        self.dof = dof
        self.static_deflection = p.TORQUE / p.RADIUS["s"] / p.N / p.K_MESH
        f = p.CONTACT_RATIO - math.floor(p.CONTACT_RATIO)
        self.low = p.K_MESH * (1 - f * p.PP_RATIO)
        self.high = self.low + p.PP_RATIO * p.K_MESH
        self.switch = 1.0 - f

    def stiffness(self, j, t):
        s = (self.phases[j] + self.frequency * t) % 1.0
        return self.low if s < self.switch else self.high

    def elastic(self, q):
        r, m = self.rigid, self.mass
        return q - r * (r @ (m * q)) / (r @ (m * r))

    def start(self):
        k = self.k + self.p.K_MESH * self.rows.T @ self.rows
        q = np.linalg.lstsq(k, self.force, rcond=1e-12)[0]
        return np.concatenate([self.elastic(q), np.zeros(self.dof)])

    def run(self, times):
        """DTE of every mesh at `times`, the time each mesh spent out of contact, the number
        of contact changes."""
        dof, rows = self.dof, self.rows
        meshes = len(rows)
        breaks = switch_times([self.frequency] * meshes, self.phases,
                              [[0.0, self.switch]] * meshes, times[-1]) + [times[-1]]
        y = self.start()
        contact = [True] * meshes
        lost_since = [None] * meshes
        lost_time = np.zeros(meshes)
        events = 0
        out = np.empty((len(times), meshes))
        out[0] = self.dte @ self.elastic(y[:dof])
        k_out, t = 1, 0.0
        for t_break in breaks:
            while t < t_break:
                mid = 0.5 * (t + t_break)
                kk = np.array([self.stiffness(j, mid) if contact[j] else 0.0 for j in range(meshes)])
                cc = np.array([self.p.C_MESH if contact[j] else 0.0 for j in range(meshes)])
                k_tot = self.k + rows.T @ (kk[:, None] * rows)
                c_tot = self.c + rows.T @ (cc[:, None] * rows)
                a = np.block([[np.zeros((dof, dof)), np.eye(dof)],
                              [-self.minv[:, None] * k_tot, -self.minv[:, None] * c_tot]])
                b = np.concatenate([np.zeros(dof), self.minv * self.force])
                rhs = lambda _t, s: a @ s + b
                evs = []
                for j in range(meshes):
                    ev = lambda _t, s, j=j: rows[j] @ s[:dof]
                    ev.terminal = True
                    ev.direction = -1.0 if contact[j] else 1.0
                    evs.append(ev)
                sol = solve_ivp(rhs, (t, t_break), y, method="DOP853", rtol=1e-12, atol=1e-22,
                                events=evs, dense_output=True)
                hit = [j for j in range(meshes) if sol.t_events[j].size and sol.t_events[j][0] > t]
                t_stop = min((sol.t_events[j][0] for j in hit), default=t_break)
                while k_out < len(times) and times[k_out] <= t_stop:
                    out[k_out] = self.dte @ self.elastic(sol.sol(times[k_out])[:dof])
                    k_out += 1
                if hit:
                    j = min(hit, key=lambda i: sol.t_events[i][0])
                    y = sol.y_events[j][0].copy()
                    q = y[:dof]
                    y[:dof] = q - rows[j] * (rows[j] @ q) / (rows[j] @ rows[j])
                    contact[j] = not contact[j]
                    events += 1
                    if contact[j]:
                        lost_time[j] += t_stop - lost_since[j]
                    else:
                        lost_since[j] = t_stop
                    t = t_stop
                else:
                    y = sol.y[:, -1].copy()
                    t = t_break
        for j in range(meshes):
            if not contact[j]:
                lost_time[j] += times[-1] - lost_since[j]
        return out, lost_time, events


MESHES = [f"{kind}{j + 1}" for j in range(N) for kind in ("sp", "rp")]


@pytest.mark.parametrize("method", [["--method", "exact"],
                                    ["--method", "rk", "--rk-method", "dop853", "--rtol", "1e-11",
                                     "--atol", "1e-18"]])
def test_planetary_time_series_match_geardyn_simulate(tmp_path, geardyn_bin, method):
    """Every mesh's DTE over 25 mesh periods from the static start at 700 rad/s, where the
    ring meshes lose contact every period, to 1e-8 of the static deflection; the same number
    of contact changes and the same contact-loss time per mesh; by the exact propagator and by
    DOP853 at tight tolerance."""
    ref = Reference()
    scene = tmp_path / "scene.toml"
    scene.write_text(scene_text())
    period = 1.0 / ref.frequency
    csv = tmp_path / "run.csv"
    done = subprocess.run(
        [str(geardyn_bin), "simulate", str(scene), "--out", str(csv), "--stop-time",
         repr(PERIODS * period), "--output-interval", repr(period / SAMPLES_PER_PERIOD),
         "--verbose", *method], check=True, capture_output=True, text=True)
    data = np.genfromtxt(csv, delimiter=",", names=True, deletechars="")
    times = data["time"]
    ours, lost_time, events = ref.run(times)
    worst = 0.0
    for j, name in enumerate(MESHES):
        d = np.max(np.abs(data[f"{name}.dte"] - ours[:, j])) / ref.static_deflection
        frac_geardyn = data[f"{name}.contact_loss_fraction"][-1]
        frac_ref = lost_time[j] / times[-1]
        print(f"{name}: DTE {d:.2e} of the static deflection; contact loss {frac_geardyn:.9f} "
              f"(reference {frac_ref:.9f})")
        worst = max(worst, d)
        assert abs(frac_geardyn - frac_ref) <= 1e-8, name
    counted = int(re.search(r"(\d+) events", done.stdout + done.stderr).group(1))
    print(f"{method[1]}: events: geardyn {counted}, reference {events}; worst DTE {worst:.2e}")
    assert events > 50 and lost_time[1] > 0.0
    assert counted == events
    assert worst <= 1e-8, worst
