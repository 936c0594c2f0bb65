"""Independent scipy reference of the shipped `fmu/idler_gearset`: Liu (2007) Ch. 2's 8-DOF
translational-rotational idler with compliant bearings, Model-1 per-tooth-pair contact with
rectangular pair stiffness and linear tip relief, modal damping (issue 31, acceptances 1-2).

Written from the notes (`shared/reference/models-liu-parker-2007.md` §1.2-1.6, §8) and
`docs/train.md`, not from the Rust code; the scene file is read only for its data.

Coordinates (Liu's U of §1.2, with each rotation positive in its body's nominal sense as
`docs/train.md` defines it): q = [x_1, u_1, x_2, y_2, u_2, x_3, y_3, u_3], u_i = r_i θ_i.
The pinion's y_1 carries no mesh force (mesh 1's line of action is the x axis) and is left out.

- Mesh n, pinion a driving gear b, line of action ℓ_n = (cos β_n, sin β_n),
  β_n = centre_angle_n + σ_a α_n (σ_a = +1 for a ccw pinion): mesh deflection
  S_n = d_nᵀq = u_a − u_b + (w_a − w_b)·ℓ_n (eq. 2.3 with β_2 = χ + π, the energy-consistent
  y_2 sign of erratum §8.1), DTE_n = u_a − u_b (Liu's z_n).
- Eq. (2.6): M q'' + C q' + K_b q + Σ_n d_n F_n = F_T, M = diag(m_1, I_1/r_1², m_2, m_2,
  I_2/r_2², m_3, m_3, I_3/r_3²), K_b = diag(k_x1, k_s1/r_1², k_x2, k_y2, 0, k_x3, k_y3,
  k_s3/r_3²), F_T = T_1/r_1 on u_1 and −T_3/r_3 on u_3, T_3 = T_1 r_3/r_1 (moment balance).
- Model-1 force (2.2), contact loss without back side (2.4 with b → ∞):
  F_n = Σ_p h_p k_p(ξ_p)(S_n − g_p(ξ_p)), h_p = 1 while S_n > g_p, else 0; each pair's change
  of h_p is an event on the guard S_n − g_p(t) = 0.
- Pairs (docs/train.md "Mesh force models"): slot j = 0 … floor(c) holds the pair at window
  position ξ_j = s + c − 1 − j, s = frac(p_n), engaged while 0 ≤ ξ_j < c. Rectangular pair
  stiffness (§1.4, labels swapped back): K_d/2 on [0, c−1) and [1, c), K_s on [c−1, 1),
  K_s = k̂[1 + ε(1 − c)], K_d = k̂[1 + ε(2 − c)]. Linear tip relief gap (§1.5):
  g(ξ) = ρ_dr max(0, ξ − (c − ς_dr))/ς_dr + ρ_dn max(0, ς_dn − ξ)/ς_dn.
- Mesh phase p_n(t) = f t (Table 2.1's φ = 0, initial phase 0), f = z_1 ω/2π for both meshes.
- Modal damping (docs/train.md "Damping", eq. 2.14): C = M Φ diag(2ζω) Φᵀ M on the modes
  of the mean system K̄ = K_b + Σ_n k̂_n d_n d_nᵀ, ΦᵀMΦ = I (the train is grounded: every mode
  is elastic).

Between the knots of the pair stiffness and gaps the right-hand side is linear with an affine
forcing; it is integrated by scipy's DOP853 at rtol 1e-12, the contact changes located as
terminal events, and after an event the state is moved onto the switching surface by the
smallest mass-weighted change (docs/train.md "Numerics"). Periodic orbits are found by Newton
shooting on the period map with a finite-difference Jacobian, whose eigenvalues approximate
the Floquet multipliers.
"""

import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq
from scipy.linalg import eigh

from orbit_statistics import Piece

REPO = Path(__file__).resolve().parents[2]
SCENE = REPO / "fmu" / "idler_gearset" / "scene.toml"
N = 8  # degrees of freedom
RTOL = 1e-12


@dataclass
class Mesh:
    d: np.ndarray  # S_n = d·q
    e: np.ndarray  # DTE_n = e·q
    mean: float
    k_single: float
    k_double_pair: float  # K_d/2, one pair's share in double contact
    c: float  # contact ratio
    relief: tuple  # (ρ_dr, ς_dr, ρ_dn, ς_dn)

    def pair_stiffness(self, xi):
        if xi < 0 or xi >= self.c:
            return 0.0
        return self.k_single if self.c - 1 <= xi < 1 else self.k_double_pair

    def gap(self, xi):
        rho_dr, len_dr, rho_dn, len_dn = self.relief
        g = 0.0
        if len_dr > 0:
            g += rho_dr * max(0.0, xi - (self.c - len_dr)) / len_dr
        if len_dn > 0:
            g += rho_dn * max(0.0, len_dn - xi) / len_dn
        return g

    def gap_slope(self, xi):
        """dg/dξ at ξ (a segment's mid point, never on a knot)."""
        rho_dr, len_dr, rho_dn, len_dn = self.relief
        s = 0.0
        if len_dr > 0 and xi > self.c - len_dr:
            s += rho_dr / len_dr
        if len_dn > 0 and xi < len_dn:
            s -= rho_dn / len_dn
        return s

    def knots(self):
        """Window positions ξ where stiffness or gap slope change."""
        rho_dr, len_dr, rho_dn, len_dn = self.relief
        return {0.0, self.c - 1, 1.0, self.c, self.c - len_dr, len_dn}

    @property
    def slots(self):
        return int(math.floor(self.c)) + 1


def scene_text(speed, torque=None):
    """The shipped scene at another input speed (rad/s) and input torque (N·m)."""
    text = SCENE.read_text()
    operating = tomllib.loads(text)["operating"]
    for key, value in (("input_speed", speed), ("input_torque", torque)):
        if value is not None:
            old = f"{key} = {operating[key]!r}"
            assert text.count(old) == 1, old
            text = text.replace(old, f"{key} = {value!r}")
    return text


class Idler8:
    """The model of the module docstring, for the scene's data at `speed` (rad/s of the
    input gear) and `torque` (input torque, N·m; the load balances it)."""

    def __init__(self, scene=SCENE, speed=None, torque=None):
        spec = tomllib.loads(Path(scene).read_text())
        gears = {g["name"]: g for g in spec["gear"]}
        names = ["pinion", "idler", "follower"]
        assert [m["pinion"] for m in spec["mesh"]] == names[:2]
        assert [m["gear"] for m in spec["mesh"]] == names[1:]
        g1, g2, g3 = (gears[n] for n in names)
        r = [g["base_radius"] for g in (g1, g2, g3)]
        self.r = r
        self.M = np.diag([g1["mass"], g1["inertia"] / r[0] ** 2,
                          g2["mass"], g2["mass"], g2["inertia"] / r[1] ** 2,
                          g3["mass"], g3["mass"], g3["inertia"] / r[2] ** 2])
        self.Kb = np.diag([g1["bearing_stiffness"][0], g1.get("ground_stiffness", 0.0) / r[0] ** 2,
                           g2["bearing_stiffness"][0], g2["bearing_stiffness"][1],
                           g2.get("ground_stiffness", 0.0) / r[1] ** 2,
                           g3["bearing_stiffness"][0], g3["bearing_stiffness"][1],
                           g3.get("ground_stiffness", 0.0) / r[2] ** 2])
        # index of (x, y, u) per gear; the pinion's y is omitted (None)
        dof = {"pinion": (0, None, 1), "idler": (2, 3, 4), "follower": (5, 6, 7)}
        sense = {"pinion": 1.0, "idler": -1.0, "follower": 1.0}  # ccw input, external meshes
        assert spec["model"]["input_rotation"] == "ccw"
        self.meshes = []
        for m in spec["mesh"]:
            alpha = math.radians(m["pressure_angle"])
            beta = m["centre_angle"] + sense[m["pinion"]] * alpha
            loa = (math.cos(beta), math.sin(beta))
            d = np.zeros(N)
            e = np.zeros(N)
            for gear, sign in ((m["pinion"], 1.0), (m["gear"], -1.0)):
                ix, iy, iu = dof[gear]
                d[iu] += sign
                e[iu] += sign
                d[ix] += sign * loa[0]
                if iy is None:
                    assert abs(loa[1]) < 1e-15, f"{gear}'s y carries mesh force: {loa}"
                else:
                    d[iy] += sign * loa[1]
            p = m["pairs"]
            assert p["kind"] == "rectangular" and m["model"] == "pairs"
            assert m["contact"] == "contact_loss"
            assert m.get("phase", 0.0) == 0.0 and m.get("initial_phase", 0.0) == 0.0
            k, eps, c = p["mean"], p["peak_to_peak_ratio"], p["contact_ratio"]
            tr = m.get("tip_relief", {})
            relief = (tr.get("driver_magnitude", 0.0), tr.get("driver_length", 0.0),
                      tr.get("driven_magnitude", 0.0), tr.get("driven_length", 0.0))
            self.meshes.append(Mesh(d, e, k, k * (1 + eps * (1 - c)),
                                    k * (1 + eps * (2 - c)) / 2, c, relief))
        op = spec["operating"]
        self.speed = op["input_speed"] if speed is None else speed
        self.torque = op["input_torque"] if torque is None else torque
        load = self.torque * r[2] / r[0]  # moment balance T_1 r_3 / r_1
        self.FT = np.zeros(N)
        self.FT[1] = self.torque / r[0]
        self.FT[7] = -load / r[2]
        self.f = g1["teeth"] * self.speed / (2 * math.pi)  # both meshes (idler)
        self.period = 1.0 / self.f
        zeta = spec["model"].get("modal_damping_ratio", 0.0)
        self.Kmean = self.Kb + sum(m.mean * np.outer(m.d, m.d) for m in self.meshes)
        w2, phi = eigh(self.Kmean, self.M)
        self.natural_frequencies = np.sqrt(w2) / (2 * math.pi)
        self.mode_shapes = phi
        self.C = self.M @ phi @ np.diag(2 * zeta * np.sqrt(w2)) @ phi.T @ self.M
        self.Minv = np.linalg.inv(self.M)
        self.static_force = self.torque / r[0]

    # --- pairs -------------------------------------------------------------------------------

    def phase(self, t):
        return self.f * t

    def knot_times(self, t0, t1):
        """The times in (t0, t1) where a pair's stiffness or gap slope changes."""
        out = set()
        for m in self.meshes:
            for j in range(m.slots):
                for xi in m.knots():
                    s = (xi - (m.c - 1 - j)) % 1.0  # ξ_j = s + c − 1 − j
                    n = math.floor(self.phase(t0) - s)
                    while True:
                        t = (n + s) / self.f
                        if t >= t1:
                            break
                        if t > t0:
                            out.add(t)
                        n += 1
        return sorted(out)

    def engaged(self, t_mid):
        """Per mesh, the engaged pairs around t_mid: (pair id, k, gap(t) = g0 + g1 t)."""
        p = self.phase(t_mid)
        cycle = math.floor(p)
        s = p - cycle
        out = []
        for m in self.meshes:
            pairs = []
            for j in range(m.slots):
                xi = s + m.c - 1 - j
                k = m.pair_stiffness(xi)
                if k > 0:
                    slope = m.gap_slope(xi) * self.f
                    pairs.append((cycle + j, k, m.gap(xi) - slope * t_mid, slope))
            out.append(pairs)
        return out

    # --- integration -------------------------------------------------------------------------

    def _linear(self, pairs, flags):
        """y' = A y + b0 + b1 t for the pairs and contact flags of a segment."""
        K = self.Kb.copy()
        f0 = self.FT.copy()
        f1 = np.zeros(N)
        for m, mesh_pairs in zip(self.meshes, pairs):
            for pid, k, g0, g1 in mesh_pairs:
                if flags[(id(m), pid)]:
                    K += k * np.outer(m.d, m.d)
                    f0 += k * g0 * m.d
                    f1 += k * g1 * m.d
        A = np.zeros((2 * N, 2 * N))
        A[:N, N:] = np.eye(N)
        A[N:, :N] = -self.Minv @ K
        A[N:, N:] = -self.Minv @ self.C
        b0 = np.concatenate([np.zeros(N), self.Minv @ f0])
        b1 = np.concatenate([np.zeros(N), self.Minv @ f1])
        return A, b0, b1

    def classify(self, flags, pairs, y, t):
        """Contact flags of pairs entering the window at t (S_n > g_p); leaving pairs dropped."""
        keep = set()
        for m, mesh_pairs in zip(self.meshes, pairs):
            for pid, k, g0, g1 in mesh_pairs:
                key = (id(m), pid)
                keep.add(key)
                if key not in flags:
                    flags[key] = bool(m.d @ y[:N] - (g0 + g1 * t) > 0)
        for key in list(flags):
            if key not in keep:
                del flags[key]

    @staticmethod
    def _first_crossings(sol, extrema, guards, t0, t1):
        """The first crossing of each guard in (t0, t1] out of its side, as (time, index).
        scipy's event check only compares the signs at the steps' ends (a guard that dips
        through zero and back within one step goes unseen) and, started on the surface after
        an event, reports the start itself. So every extremum of every guard is located (a
        sign change of its rate, a scipy event); between consecutive extrema a guard is
        monotone, and the first point of [extrema…, t1] on the wrong side brackets the
        crossing, found by brentq on the dense output. `extrema[i]`: guard i's extrema."""
        out = []
        for i, (ev, m, pid, in_contact) in enumerate(guards):
            def g(tt, ev=ev):
                return ev(tt, sol(tt))
            points = [tx for tx in extrema[i] if t0 < tx < t1] + [t1]
            lo = t0
            for tx in points:
                v = g(tx)
                if (v < 0) if in_contact else (v > 0):
                    if lo == t0 and g(lo) * v >= 0:
                        raise RuntimeError(f"pair {pid} leaves its side at the start, t = {t0}")
                    out.append((brentq(g, lo, tx, xtol=1e-20, rtol=4 * np.finfo(float).eps), i))
                    break
                lo = tx
        return out

    def integrate(self, y0, t0, t1, segments=None):
        """The state at t1 from y0 at t0 (each pair's contact classified at t0 by the sign of
        S_n − g_p), and the contact flags at t1. With a list `segments`, each smooth piece is
        appended as (a, b, dense solution, pairs, flags)."""
        y = np.array(y0, dtype=float)
        flags = {}
        max_step = self.period / 40
        t = t0
        for t_break in self.knot_times(t0, t1) + [t1]:
            while t < t_break:
                pairs = self.engaged(0.5 * (t + t_break))
                self.classify(flags, pairs, y, t)
                A, b0, b1 = self._linear(pairs, flags)
                guards, slopes = [], []
                for m, mesh_pairs in zip(self.meshes, pairs):
                    for pid, k, g0, g1 in mesh_pairs:
                        def ev(tt, state, d=m.d, g0=g0, g1=g1):
                            return d @ state[:N] - g0 - g1 * tt

                        def rate(tt, state, d=m.d, g1=g1):
                            return d @ state[N:] - g1
                        guards.append((ev, m, pid, flags[(id(m), pid)]))
                        slopes.append(rate)
                sol = solve_ivp(lambda tt, s: A @ s + b0 + b1 * tt, (t, t_break), y,
                                method="DOP853", rtol=RTOL, atol=1e-30,
                                events=slopes, dense_output=True,
                                max_step=max_step)
                assert sol.status == 0, sol.message
                hits = self._first_crossings(sol.sol, sol.t_events, guards, t, t_break)
                t_stop = min(hits)[0] if hits else t_break
                if segments is not None:
                    segments.append((t, t_stop, sol.sol, pairs, dict(flags)))
                if hits:
                    ev, m, pid, _ = guards[min(hits)[1]]
                    y = sol.sol(t_stop).copy()
                    # onto the surface d·q = g by the smallest mass-weighted change of q
                    w = self.Minv @ m.d
                    y[:N] -= w * ev(t_stop, y) / (m.d @ w)
                    flags[(id(m), pid)] = not flags[(id(m), pid)]
                    t = t_stop
                else:
                    y = sol.y[:, -1].copy()
                    t = t_break
        return y, flags

    def pair_loss_fractions(self, segments, duration):
        """Per mesh, per tooth-pair slot j (the pair at ξ_j = s + c − 1 − j), the fraction of
        `duration` the pair is engaged but out of contact, from the smooth pieces of
        `integrate` (each pair's contact is constant on a piece: its ends are the events)."""
        out = []
        for mi, m in enumerate(self.meshes):
            lost = [0.0] * m.slots
            for a, b, _, pairs, fl in segments:
                if b <= a:
                    continue
                cycle = math.floor(self.phase(0.5 * (a + b)))
                for pid, *_ in pairs[mi]:
                    if not fl[(id(m), pid)]:
                        lost[pid - cycle] += b - a
            out.append([x / duration for x in lost])
        return out

    # --- statics, orbits, pieces -------------------------------------------------------------

    @staticmethod
    def loaded_ste(force, pairs):
        """Eq. (2.8) by active set (notes §1.6): a mesh's static deflection at `force` with the
        engaged pairs [(k, g)]."""
        active = list(pairs)
        while True:
            delta = (force + sum(k * g for k, g in active)) / sum(k for k, g in active)
            keep = [(k, g) for k, g in active if delta > g]
            if len(keep) == len(active):
                return delta
            active = keep

    def start_state(self):
        """`geardyn simulate`'s start (`initial.dte = "static"`, not specified in the docs
        beyond "the mean system"; taken from `GearTrain::initial_state` to start from the same
        state, checked against the t = 0 row): K̄ q = F_T + Σ_n k̂_n d_n e_n with
        e_n = δ̃_n(p_n(0)) − F/k̂_n, δ̃_n the loaded STE (2.8) at the nominal force F = T_1/r_1;
        at rest."""
        rhs = self.FT.copy()
        for m, pairs in zip(self.meshes, self.engaged(0.0)):
            gaps = [(k, g0) for _, k, g0, _ in pairs]
            e = self.loaded_ste(self.static_force, gaps) - self.static_force / m.mean
            rhs += m.mean * e * m.d
        return np.concatenate([np.linalg.solve(self.Kmean, rhs), np.zeros(N)])

    def sample(self, y0, times):
        """The state at `times` (ascending, from t = 0 with y0), and per mesh whether it was
        ever in total contact loss."""
        segments = []
        self.integrate(y0, 0.0, times[-1], segments=segments)
        out = np.empty((len(times), 2 * N))
        i = 0
        for a, b, sol, _, _ in segments:
            while i < len(times) and times[i] <= b:
                out[i] = sol(times[i])
                i += 1
        lost = [any(not any(fl[(id(m), pid)] for pid, *_ in pairs[mi])
                    for a, b, sol, pairs, fl in segments if b > a)
                for mi, m in enumerate(self.meshes)]
        return out, lost

    def period_map(self, y0):
        return self.integrate(y0, 0.0, self.period)

    def periodic_orbit(self, y_guess, tol=1e-13, iterations=12):
        """Newton shooting on the period map: the orbit's start state, its finite-difference
        monodromy eigenvalues (Floquet multipliers), and the scaled residual."""
        scale = self.state_scale()
        y = np.array(y_guess, dtype=float)
        for _ in range(iterations):
            y1, _ = self.period_map(y)
            r = (y1 - y) / scale
            residual = float(np.max(np.abs(r)))
            J = np.empty((2 * N, 2 * N))
            for i in range(2 * N):
                h = 1e-7 * scale[i]
                yp = y.copy()
                yp[i] += h
                J[:, i] = (self.period_map(yp)[0] - y1) / h * scale[i] / scale
            if residual < tol:
                return y, np.linalg.eigvals(J), residual
            y = y - scale * np.linalg.solve(J - np.eye(2 * N), r)
        raise RuntimeError(f"shooting did not converge: residual {residual:.2e}")

    def state_scale(self):
        x = self.static_force / self.meshes[0].mean
        w = 2 * math.pi * self.natural_frequencies[-1]
        return np.array([x] * N + [w * x] * N)

    def orbit_pieces(self, y0, duration=None, segments=None):
        """Per mesh, the `Piece`s of one period (or of `duration`) from y0 (t ∈ [0, T]), the
        contact flags at its end, and the state at its end; the smooth pieces of `integrate`
        are appended to `segments` when given."""
        segments = [] if segments is None else segments
        y1, flags = self.integrate(y0, 0.0, duration or self.period, segments=segments)
        out = []
        for mi, m in enumerate(self.meshes):
            pieces = []
            for a, b, sol, pairs, fl in segments:
                active = [(k, g0, g1) for pid, k, g0, g1 in pairs[mi] if fl[(id(m), pid)]]

                def force(t, sol=sol, active=active, d=m.d):
                    s = d @ sol(t)[:N]
                    return sum(k * (s - g0 - g1 * t) for k, g0, g1 in active)
                pieces.append(Piece(a, b, lambda t, sol=sol, e=m.e: e @ sol(t)[:N], force,
                                    not active))
            out.append(pieces)
        lost_at_end = [not any(v for key, v in flags.items() if key[0] == id(m))
                       for m in self.meshes]
        return out, lost_at_end, y1
