"""Direct time integration of the dimensionless Ch. 3 idler (eqs. 3.10-3.11), for checking the
perturbation oracle `liu_ch3` (issue 16, item 4).  Written from the thesis equations, not from
geardyn; only the model's constant matrices (M̂, Ĉ, F̂) and the rectangular stiffness of
`liu_ch3.IdlerCh3` are reused (they are the model, not the perturbation results under test).

    M̂ ÿ + Ĉ ẏ + diag(H_1 k_1(p)/k̄_1, H_2 k_2(p)/k̄_1) y = [1, 1]ᵀ,   p = ωτ/2π (mesh cycles),
    H_j = 1 in contact, 0 separated; contact changes at y_j = 0 (no back side).

scipy's DOP853 (rtol 1e-10 by default) piece by piece: the rectangular stiffness switches are
known times (restarts), the contact changes are terminal events after which the state is put
exactly on the surface y_j = 0 and the flag flipped.
"""

import math

import numpy as np
from scipy.integrate import solve_ivp


class Integrator:
    """Time integration of an `IdlerCh3` at mesh frequency ω (dimensionless)."""

    def __init__(self, oracle, omega, rtol=1e-10, atol=1e-12):
        self.o = oracle
        self.omega = float(omega)
        self.rtol = rtol
        self.atol = atol
        M, C, F = oracle.rhs_matrices()
        Mi = np.linalg.inv(M)
        self.Mi = [[float(Mi[i, j]) for j in range(2)] for i in range(2)]
        self.Cm = [[float(C[i, j]) for j in range(2)] for i in range(2)]
        self.Fv = [float(F[0]), float(F[1])]
        self.period = 2 * math.pi / self.omega
        # Switch instants within one mesh period (fraction of the period, mesh-1 phase).
        sw = set()
        for j in range(2):
            f = oracle.contact_ratio[j] - math.floor(oracle.contact_ratio[j])
            off = 0.0 if j == 0 else oracle.phi / (2 * math.pi)
            for s in (0.0, 1.0 - f):
                sw.add(round((s - off) % 1.0, 15))
        self.switches = sorted(x for x in sw if x > 0.0) + [1.0]
        self.contact = [True, True]
        self.tau = 0.0
        self.state = np.array([oracle.C[0], oracle.C[1], 0.0, 0.0])
        self.separated_time = [0.0, 0.0]
        self.events = 0

    def set_state(self, y, tau=0.0):
        self.state = np.array(y, dtype=float)
        self.tau = float(tau)
        self.contact = [self.state[0] > 0.0, self.state[1] > 0.0]

    def _rhs(self, k):
        Mi, Cm, Fv = self.Mi, self.Cm, self.Fv
        k1 = k[0] if self.contact[0] else 0.0
        k2 = k[1] if self.contact[1] else 0.0

        def rhs(_t, s):
            y1, y2, v1, v2 = s
            f1 = Fv[0] - k1 * y1 - Cm[0][0] * v1 - Cm[0][1] * v2
            f2 = Fv[1] - k2 * y2 - Cm[1][0] * v1 - Cm[1][1] * v2
            return [v1, v2, Mi[0][0] * f1 + Mi[0][1] * f2, Mi[1][0] * f1 + Mi[1][1] * f2]

        return rhs

    def _events(self):
        evs = []
        for j in range(2):
            def ev(_t, s, j=j):
                return s[j]
            ev.terminal = True
            ev.direction = -1.0 if self.contact[j] else 1.0
            evs.append(ev)
        return evs

    def advance_period(self, samples=None):
        """Integrates one mesh period from the current τ (assumed a whole number of periods).
        With `samples` (points per period), returns the DTE samples at τ_0 + iT/samples,
        i = 0..samples−1."""
        T = self.period
        t0 = self.tau
        out = None
        grid = None
        if samples:
            grid = t0 + T * np.arange(samples) / samples
            out = np.empty((samples, 2))
            k_out = 0
        start = 0.0
        for frac in self.switches:
            t_end = t0 + frac * T
            mid_p = (t0 + 0.5 * (start + frac) * T) * self.omega / (2 * math.pi)
            k = [self.o.stiffness(0, mid_p), self.o.stiffness(1, mid_p)]
            t = t0 + start * T
            while t < t_end:
                sol = solve_ivp(self._rhs(k), (t, t_end), self.state, method="DOP853", rtol=self.rtol,
                                atol=self.atol, events=self._events(), dense_output=samples is not None)
                hits = [j for j in range(2) if sol.t_events[j].size and sol.t_events[j][0] > t]
                t_stop = min((sol.t_events[j][0] for j in hits), default=t_end)
                if samples:
                    while k_out < samples and grid[k_out] <= t_stop:
                        out[k_out] = sol.sol(grid[k_out])[:2] if grid[k_out] > t else self.state[:2]
                        k_out += 1
                for j in range(2):
                    if not self.contact[j]:
                        self.separated_time[j] += t_stop - t
                if hits:
                    j = min(hits, key=lambda i: sol.t_events[i][0])
                    self.state = sol.y_events[j][0].copy()
                    self.state[j] = 0.0
                    self.contact[j] = not self.contact[j]
                    self.events += 1
                    t = t_stop
                else:
                    self.state = sol.y[:, -1].copy()
                    t = t_end
            start = frac
        self.tau = t0 + T
        return out

    def settle(self, max_periods, tol=1e-7, min_periods=10, response_periods=1):
        """Runs until the Poincaré state repeats after `response_periods` mesh periods to `tol`
        (relative to the state's scale), at most `max_periods`.  Returns (periods, residual)."""
        hist = [self.state.copy()]
        scale = max(1.0, float(np.abs(self.state[:2]).max()))
        res = float("inf")
        for n in range(1, max_periods + 1):
            self.advance_period()
            hist.append(self.state.copy())
            if n >= max(min_periods, response_periods):
                res = float(np.abs(hist[-1] - hist[-1 - response_periods]).max()) / scale
                if res < tol:
                    return n, res
            if len(hist) > response_periods + 1:
                hist.pop(0)
        return max_periods, res

    def record(self, periods, samples=64):
        """DTE statistics over `periods` mesh periods: dict(mean, rms, a1 (amplitude of the
        harmonic at ω), a_half (at ω/2), loss (separated time fraction per mesh), y)."""
        sep0 = list(self.separated_time)
        ys = np.concatenate([self.advance_period(samples) for _ in range(periods)])
        n = len(ys)
        mean = ys.mean(axis=0)
        rms = np.sqrt(((ys - mean) ** 2).mean(axis=0))
        spec = np.fft.rfft(ys - mean, axis=0) / n * 2
        a1 = np.abs(spec[periods])
        a_half = np.abs(spec[periods // 2]) if periods % 2 == 0 else np.full(2, np.nan)
        loss = [(self.separated_time[j] - sep0[j]) / (periods * self.period) for j in range(2)]
        return dict(mean=mean, rms=rms, a1=a1, a_half=a_half, loss=np.array(loss), y=ys)


def initial_state_on_branch(oracle, omega, alpha, r=0):
    """State at τ = 0 on the perturbation solution of amplitude α: q_r = F_r + B e^{iωτ} + c.c.,
    B = R_3/(2c_r(ω − c_r) − R_1 − R_2/α − 2iΓc_r²) scaled to |B| = α (notes §2.5 [R]), the other
    mode at rest at its static value; y = S q."""
    cr = oracle.c[r]
    d = 2 * cr * (omega - cr) - 2j * oracle.gamma * cr ** 2
    if alpha > 0:
        d -= oracle.R1(alpha, r) + oracle.R2(alpha, r) / alpha
    B = oracle.R3(r) / d
    B = B / abs(B) * alpha if alpha > 0 else 0.0
    s = oracle.S[:, r]
    y = oracle.C + 2 * s * np.real(B)
    v = 2 * s * np.real(1j * omega * B)
    return np.concatenate([y, v])
