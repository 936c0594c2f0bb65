"""Independent scipy reference of a free (ungrounded) compliant gear chain with lumped meshes
(issue 37, acceptance 2): `M + 1` spur gears in a row, each on compliant bearings (x, y and
the rotation u = r θ), joined by `M` lumped meshes with rectangular stiffness, an optional
first STE harmonic, the linear or the contact-loss law, modal damping, no ground coupling.

Written from `docs/train.md` and `docs/model.md`, not from the Rust code; the scene file is
read only for its data. Nothing here removes the rigid-body mode: the model is integrated in
the physical coordinates, where the free rotation of the whole train is a double zero
eigenvalue that the balanced torques never excite (the outputs, DTE and mesh deflection, do
not see it). geardyn instead integrates the elastic coordinates `ξ` of `q = Qξ + Rη`
(`docs/train.md`, "Rigid-body modes"), so the two agree only if that split is exact.

- Coordinates: per gear i `(x_i, y_i, u_i)`, `u_i = r_i θ_i` with θ positive in the gear's
  nominal sense (the input turns ccw, each external mesh reverses it).
- Mesh n, pinion a = gear n driving gear b = n + 1: line of action
  `ℓ_n = (cos β_n, sin β_n)`, `β_n = centre_angle_n + σ_a α_n` (σ_a = +1 for a ccw pinion);
  `S_n = d_nᵀq = u_a − u_b + (w_a − w_b)·ℓ_n`, `DTE_n = u_a − u_b`.
- `M q'' + C q' + K_b q + Σ_n d_n F_n = F_T`, `M = diag(m, m, I/r²)` per gear, `K_b` the
  bearings on x and y, `F_T = T/r_0` on u_0 and `−T_L/r_M` on u_M with the moment balance
  `T_L = T r_M / r_0`.
- Mesh phase `p_n(t) = φ_n + f t` (`f = z_0 Ω / 2π`, `φ_0 = initial_phase`); rectangular
  stiffness at `s = frac(p_n)`: `k_low = k̄(1 − f_c ε)` on `[0, 1 − f_c)`, `k_low + ε k̄` on
  `[1 − f_c, 1)`, `f_c = c − ⌊c⌋`; STE `e_n = a cos 2π p_n`.
- `F_n = k_n(p_n)(S_n − e_n)` (no mesh damper); with contact loss `F_n = 0` while
  `S_n − e_n ≤ 0`, each change an event on `S_n − e_n = 0`, after which the state is moved
  onto the surface by the smallest mass-weighted change of q.
- Modal damping (eq. 2.14): `C = M Φ diag(2ζω) Φᵀ M` over the elastic modes of the mean
  system `(K_b + Σ k̄_n d_n d_nᵀ, M)`, `ΦᵀMΦ = I`; the rigid mode (ω = 0) gets none.
- Start (`initial.dte = "static"`): at rest, `K̄ q = F_T + Σ k̄_n d_n e_n(p_n(0))` solved
  in the elastic subspace (the rigid component is zero; the outputs do not depend on it).

Two integrators: `Chain.run` (scipy DOP853 between the stiffness knots, contact changes
located on its dense output) for any law, and `Chain.linear_periods` (linear law only): the
state at whole mesh periods by the product of the segments' exponentials, computed in
extended precision (numpy long double, Taylor series with scaling and squaring), which
decides disagreements between double-precision integrators at the 1e-12 level.
"""

import math
import tomllib
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp
from scipy.linalg import eigh, matrix_balance
from scipy.optimize import brentq

RTOL = 1e-12


def free_chain_text(meshes, contact):
    """A free compliant chain as a user writes it (the data of `ChainSpec::free`,
    `docs/chains.md`): 38/55-tooth gears alternating with Liu (2007) Table 2.1's pinion and
    idler data, bearings 1.27e8 N/m, lumped rectangular meshes (2.9831e8 N/m, ε 0.35,
    c 1.504) at 2000 Hz, golden-ratio phases, zigzag centre lines, modal damping 2 %, no
    ground coupling, 100 N·m; with contact loss a 15 µm first STE harmonic on every mesh."""
    golden = 0.5 * (5 ** 0.5 - 1)
    gears = [(38, 0.04535, 0.002621, 2.2325), (55, 0.06564, 0.01091, 4.438)]
    s = ('name = "free_chain"\n\n[model]\nbearings = "compliant"\ninput_rotation = "ccw"\n'
         'modal_damping_ratio = 0.02\n\n')
    for i in range(meshes + 1):
        t, r, j, m = gears[i % 2]
        s += (f'[[gear]]\nname = "g{i}"\nteeth = {t}\nbase_radius = {r}\ninertia = {j}\n'
              f'mass = {m}\nbearing_stiffness = [1.27e8, 1.27e8]\n\n')
    for n in range(meshes):
        centre = math.pi / 6 * (1 if n % 2 == 0 else -1)
        s += (f'[[mesh]]\nname = "mesh{n + 1}"\npinion = "g{n}"\ngear = "g{n + 1}"\n'
              f'contact = "{contact}"\nmodel = "lumped"\npressure_angle = 21.22\n'
              f'centre_angle = {centre!r}\n')
        s += ('initial_phase = 0.0\n' if n == 0
              else f'phase = {round((n * golden) % 1.0 * 1e6) / 1e6}\n')
        s += ('stiffness = { kind = "rectangular", mean = 2.9831e8, peak_to_peak_ratio = 0.35, '
              'contact_ratio = 1.504 }\n')
        if contact == "contact_loss":
            s += 'ste = { cos = [1.5e-5] }\n'
        s += '\n'
    s += (f'[operating]\ninput_speed = {2 * math.pi * 2000 / 38!r}\ninput_torque = 100.0\n\n'
          '[solver]\nmethod = "auto"\nstop_time = 0.01\noutput_interval = 5e-4\n')
    return s


class Chain:
    """The model of the module docstring for a scene file (or its text)."""

    def __init__(self, scene):
        text = Path(scene).read_text() if isinstance(scene, Path) else scene
        spec = tomllib.loads(text)
        assert spec["model"]["bearings"] == "compliant"
        assert spec["model"].get("input_rotation", "ccw") == "ccw"
        gears = spec["gear"]
        names = [g["name"] for g in gears]
        assert not any("ground_stiffness" in g for g in gears), "a free chain"
        n_g = len(gears)
        self.n = 3 * n_g
        n = self.n
        self.r = [g["base_radius"] for g in gears]
        self.M = np.diag([v for g in gears
                          for v in (g["mass"], g["mass"], g["inertia"] / g["base_radius"] ** 2)])
        self.Kb = np.diag([v for g in gears for v in (*g["bearing_stiffness"], 0.0)])
        sense = [1.0 if i % 2 == 0 else -1.0 for i in range(n_g)]  # external meshes in a row
        self.meshes = []
        f = None
        for i, m in enumerate(spec["mesh"]):
            a, b = names.index(m["pinion"]), names.index(m["gear"])
            assert (a, b) == (i, i + 1) and m.get("model", "lumped") == "lumped"
            beta = m["centre_angle"] + sense[a] * math.radians(m["pressure_angle"])
            d, e = np.zeros(n), np.zeros(n)
            for g, sign in ((a, 1.0), (b, -1.0)):
                d[3 * g:3 * g + 3] += sign * np.array([math.cos(beta), math.sin(beta), 1.0])
                e[3 * g + 2] += sign
            st = m["stiffness"]
            assert st["kind"] == "rectangular" and st.get("phase", 0.0) == 0.0
            k, eps, c = st["mean"], st["peak_to_peak_ratio"], st["contact_ratio"]
            fc = c - math.floor(c)
            k_low = k * (1 - fc * eps)
            ste = m.get("ste", {}).get("cos", [0.0])
            assert len(ste) == 1 and not m.get("ste", {}).get("sin")
            phase = m["initial_phase"] if i == 0 else m["phase"]
            self.meshes.append(dict(d=d, e=e, mean=k, low=k_low, high=k_low + eps * k,
                                    switch=1 - fc, phase=phase, ste=ste[0],
                                    loss=m["contact"] == "contact_loss"))
            assert m["contact"] in ("linear", "contact_loss")
            if f is None:
                f = gears[a]["teeth"] * spec["operating"]["input_speed"] / (2 * math.pi)
        self.f = f
        self.period = 1.0 / f
        torque = spec["operating"]["input_torque"]
        self.FT = np.zeros(n)
        self.FT[2] = torque / self.r[0]
        self.FT[-1] = -torque * self.r[-1] / self.r[0] / self.r[-1]
        self.static_deflection = torque / self.r[0] / self.meshes[0]["mean"]
        self.Kmean = self.Kb + sum(m["mean"] * np.outer(m["d"], m["d"]) for m in self.meshes)
        w2, phi = eigh(self.Kmean, self.M)
        top = np.max(np.abs(w2))
        elastic = w2 > 1e-10 * top
        assert np.count_nonzero(~elastic) == 1, "one rigid-body mode"
        zeta = spec["model"].get("modal_damping_ratio", 0.0)
        pe = phi[:, elastic]
        self.C = self.M @ pe @ np.diag(2 * zeta * np.sqrt(w2[elastic])) @ pe.T @ self.M
        self.rigid = phi[:, ~elastic][:, 0]
        self.Minv = np.diag(1.0 / np.diag(self.M))

    # --- mesh functions of time ---------------------------------------------------------------

    def phase(self, m, t):
        return m["phase"] + self.f * t

    def stiffness(self, m, t_mid):
        s = self.phase(m, t_mid) % 1.0
        return m["low"] if s < m["switch"] else m["high"]

    def ste(self, m, t):
        return m["ste"] * math.cos(2 * math.pi * self.phase(m, t))

    def ste_rate(self, m, t):
        return -m["ste"] * 2 * math.pi * self.f * math.sin(2 * math.pi * self.phase(m, t))

    def knot_times(self, t0, t1):
        """The stiffness switches of every mesh in (t0, t1)."""
        out = set()
        for m in self.meshes:
            for s in (0.0, m["switch"]):
                k = math.floor(self.phase(m, t0) - s)
                while True:
                    t = (k + s - m["phase"]) / self.f
                    if t >= t1:
                        break
                    if t > t0:
                        out.add(t)
                    k += 1
        return sorted(out)

    # --- start ---------------------------------------------------------------------------------

    def start_state(self, dtype=float):
        """At rest in the mean system loaded at the start phases, without a rigid component:
        `(K̄ + s·MrrᵀM) q = F` (r the rigid mode; the added term is zero on the answer, since
        rᵀF = 0, and makes the matrix regular), solved in double and refined with residuals
        in long double."""
        ld = np.longdouble
        rhs = (self.FT.astype(ld)
               + sum(ld(m["mean"]) * ld(self.ste(m, 0.0)) * m["d"].astype(ld)
                     for m in self.meshes))
        mr = self.M @ self.rigid
        s = np.max(np.abs(self.Kmean)) / np.max(np.abs(mr)) ** 2
        regular = self.Kmean + s * np.outer(mr, mr)
        regular_ld = regular.astype(ld)
        q = np.linalg.solve(regular, rhs.astype(float)).astype(ld)
        for _ in range(4):
            q = q + np.linalg.solve(regular, (rhs - regular_ld @ q).astype(float)).astype(ld)
        return np.concatenate([q, np.zeros(self.n, dtype=ld)]).astype(dtype)

    # --- DOP853 with events -------------------------------------------------------------------

    def _rhs(self, in_contact, t_mid):
        n = self.n
        K = self.Kb.copy()
        active = []
        for m, on in zip(self.meshes, in_contact):
            if on:
                k = self.stiffness(m, t_mid)
                K += k * np.outer(m["d"], m["d"])
                active.append((k, m))
        Minv = self.Minv

        def rhs(t, y):
            q, v = y[:n], y[n:]
            force = self.FT - K @ q - self.C @ v
            for k, m in active:
                force += k * self.ste(m, t) * m["d"]
            return np.concatenate([v, Minv @ force])
        return rhs

    def gap(self, m, t, y):
        return m["d"] @ y[:self.n] - self.ste(m, t)

    def gap_rate(self, m, t, y):
        return m["d"] @ y[self.n:] - self.ste_rate(m, t)

    def run(self, y0, times):
        """The states at `times` (ascending, from t = 0 with y0) and the contact events
        `(t, mesh, in contact after)`."""
        n = self.n
        y = np.array(y0, dtype=float)
        in_contact = [True] * len(self.meshes)
        events = []
        out = np.empty((len(times), 2 * n))
        i = 0
        t = 0.0
        while i < len(times) and times[i] <= 0.0:
            out[i] = y
            i += 1
        t_end = times[-1]
        for t_break in self.knot_times(0.0, t_end) + [t_end]:
            while t < t_break:
                mid = 0.5 * (t + t_break)
                rhs = self._rhs(in_contact, mid)
                lossy = [j for j, m in enumerate(self.meshes) if m["loss"]]
                rates = [lambda tt, s, m=self.meshes[j]: self.gap_rate(m, tt, s) for j in lossy]
                sol = solve_ivp(rhs, (t, t_break), y, method="DOP853", rtol=RTOL, atol=1e-30,
                                events=rates or None, dense_output=True,
                                max_step=self.period / 40)
                assert sol.status == 0, sol.message
                hits = []
                for k, j in enumerate(lossy):
                    hit = self._first_crossing(sol.sol, sol.t_events[k], self.meshes[j],
                                               in_contact[j], t, t_break)
                    if hit is not None:
                        hits.append((hit, j))
                t_stop = min(hits)[0] if hits else t_break
                while i < len(times) and times[i] <= t_stop:
                    out[i] = sol.sol(times[i])
                    i += 1
                y = sol.sol(t_stop).copy() if hits else sol.y[:, -1].copy()
                if hits:
                    j = min(hits)[1]
                    m = self.meshes[j]
                    w = self.Minv @ m["d"]
                    y[:n] -= w * self.gap(m, t_stop, y) / (m["d"] @ w)
                    in_contact[j] = not in_contact[j]
                    events.append((t_stop, j, in_contact[j]))
                t = t_stop
        return out, events

    def _first_crossing(self, sol, extrema, m, on, t0, t1):
        """The first crossing of mesh m's gap out of its side in (t0, t1]: between extrema (sign
        changes of its rate, scipy events) the gap is monotone, so the first such point on the
        wrong side brackets it (a dip through zero within one step is not missed)."""
        def g(tt):
            return self.gap(m, tt, sol(tt))
        lo = t0
        for tx in [x for x in extrema if t0 < x < t1] + [t1]:
            v = g(tx)
            if (v < 0) if on else (v > 0):
                return brentq(g, lo, tx, xtol=1e-22, rtol=4 * np.finfo(float).eps)
            lo = tx
        return None

    # --- linear law: exact period map in extended precision --------------------------------

    def linear_periods(self, periods):
        """The states at t = k·T, k = 0 … periods (linear law, no STE), by the monodromy
        `Φ_T = Π e^{A_i τ_i}` of the lifted system `z = [q, q', 1]`, each exponential in
        numpy long double."""
        assert all(not m["loss"] and m["ste"] == 0.0 for m in self.meshes)
        ld = np.longdouble
        n = self.n
        knots = [0.0] + self.knot_times(0.0, self.period) + [self.period]
        phi = np.eye(2 * n + 1, dtype=ld)
        for a, b in zip(knots[:-1], knots[1:]):
            K = self.Kb.copy()
            for m in self.meshes:
                K += self.stiffness(m, 0.5 * (a + b)) * np.outer(m["d"], m["d"])
            A = np.zeros((2 * n + 1, 2 * n + 1))
            A[:n, n:2 * n] = np.eye(n)
            A[n:2 * n, :n] = -self.Minv @ K
            A[n:2 * n, n:2 * n] = -self.Minv @ self.C
            A[n:2 * n, -1] = self.Minv @ self.FT
            phi = expm_long(A, ld(b) - ld(a)) @ phi
        z = np.concatenate([self.start_state(ld), [ld(1)]])
        out = [z]
        for _ in range(periods):
            z = phi @ z
            out.append(z)
        return np.array(out)[:, :2 * n]

    def linear_periods_by_vectors(self, periods):
        """`linear_periods` by products with the state only (for large chains, where a long
        double matrix exponential is too slow): each segment's `e^{Aτ} z` by sub-steps of the
        Taylor series of the balanced matrix, summed to below the long double's unit
        roundoff."""
        assert all(not m["loss"] and m["ste"] == 0.0 for m in self.meshes)
        ld = np.longdouble
        n = self.n
        knots = [0.0] + self.knot_times(0.0, self.period) + [self.period]
        ops = []
        for a, b in zip(knots[:-1], knots[1:]):
            K = self.Kb.copy()
            for m in self.meshes:
                K += self.stiffness(m, 0.5 * (a + b)) * np.outer(m["d"], m["d"])
            A = np.zeros((2 * n + 1, 2 * n + 1))
            A[:n, n:2 * n] = np.eye(n)
            A[n:2 * n, :n] = -self.Minv @ K
            A[n:2 * n, n:2 * n] = -self.Minv @ self.C
            A[n:2 * n, -1] = self.Minv @ self.FT
            ops.append(_balanced_step(A, ld(b) - ld(a)))
        z = np.concatenate([self.start_state(ld), [ld(1)]])
        out = [z]
        for _ in range(periods):
            for op in ops:
                z = op(z)
            out.append(z)
        return np.array(out)[:, :2 * n]


def _balanced_step(a, tau):
    """`z ↦ e^{aτ} z` in long double: `D e^{Bτ} D⁻¹ z`, `B` balanced, in sub-steps with
    `‖Bτ_sub‖₁ ≤ 1/2`, each a Taylor series summed until its terms vanish in long double."""
    ld = np.longdouble
    _, (scale, _perm) = matrix_balance(a, permute=False, separate=True)
    s = scale.astype(ld)
    b = a.astype(ld) / s[:, None] * s[None, :]
    norm = float(np.max(np.sum(np.abs(b), axis=0))) * float(tau)
    steps = max(1, int(math.ceil(norm / 0.5)))
    h = tau / ld(steps)

    def apply(z):
        u = z / s
        for _ in range(steps):
            term = u.copy()
            total = u.copy()
            for k in range(1, 60):
                term = (b @ term) * (h / ld(k))
                total = total + term
                if np.max(np.abs(term)) <= ld(1e-24) * np.max(np.abs(total)):
                    break
            u = total
        return u * s
    return apply


def expm_long(a, tau):
    """`e^{a τ}` in long double: balanced (powers of two, exact), scaled to ‖B‖₁ ≤ 1/2, Taylor
    series to below the long double's unit roundoff, squared back."""
    ld = np.longdouble
    _, (scale, _perm) = matrix_balance(a, permute=False, separate=True)
    s = scale.astype(ld)
    b = (a.astype(ld) / s[:, None] * s[None, :]) * tau
    norm = np.max(np.sum(np.abs(b), axis=0))
    squarings = max(0, int(math.ceil(math.log2(float(norm) / 0.5)))) if norm > 0 else 0
    b = b / ld(2) ** squarings
    e = np.eye(len(a), dtype=ld)
    term = np.eye(len(a), dtype=ld)
    for k in range(1, 40):
        term = term @ b / ld(k)
        e = e + term
        if np.max(np.abs(term)) < ld(1e-22):
            break
    for _ in range(squarings):
        e = e @ e
    return e * s[:, None] / s[None, :]


def dte_and_deflection(chain, states):
    """Per mesh, the DTE and deflection rows of `states` (columns: meshes)."""
    n = chain.n
    dte = np.array([states[:, :n] @ m["e"] for m in chain.meshes]).T
    defl = np.array([states[:, :n] @ m["d"] for m in chain.meshes]).T
    return dte, defl
