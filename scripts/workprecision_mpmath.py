#!/usr/bin/env python3
"""Extended-precision reference of the work-precision benchmark (run by
scripts/bench-workprecision.sh) for the single-mesh problems whose stiffness is piecewise
constant (rectangular): the piecewise-LTI problems that geardyn's exact propagator covers.

Written from docs/model.md alone (the scene is parsed by tests/python/gear_reference.py, itself
written from the spec; nothing here calls or mirrors geardyn). Between two stiffness switches
and two contact changes the single-mesh equation (docs/model.md, "Coordinates and sign
convention", "Mesh force and contact law")

    m_e x'' = F_ext − F,   in contact F = k (δ + s) + c_m δ',  δ = x − e(p),  s ∈ {0, 2b},
    separated F = 0,

is linear with constant coefficients and a constant plus harmonic (STE) forcing. It is solved in
closed form with mpmath at ``mp.dps = 30``:

* in contact, the augmented state z = (x, x', 1, cos θ_1, sin θ_1, …, cos θ_H, sin θ_H),
  θ_h = 2πh p(t), obeys z' = A z with a constant A; with A = V diag(λ) V⁻¹ (mpmath ``eig``),
  z(t0 + τ) = Σ_j V_j w_j e^{λ_j τ}, w = V⁻¹ z(t0); every guard and its derivative is then a
  sum of complex exponentials. Each segment's end state is checked against mpmath's ``expm``
  of A τ (the run stops if they differ by more than 1e-24 of the state's scale);
* separated (F = 0), x is the quadratic x0 + x0' τ + F_ext τ²/(2 m_e); the guards subtract
  e(p(t)) evaluated directly.

Contact changes (δ = 0, δ = −2b, leaving the current state's side) are bracketed by sampling
each piece at 64 points per period of its fastest component, plus a check for an interior
maximum of the guard (two crossings inside one sample interval: the root of the guard's
derivative), then bisected to 1e-28 s. After an event the state is put on the switching surface
and the next piece starts there. Stiffness switches (rectangular jumps) are cut exactly from
the mesh phase. The DTE is written on the benchmark's grid with 17 significant digits.

Usage: workprecision_mpmath.py DIR   (reads DIR/problems.csv and DIR/scenes/, writes
DIR/mpmath.csv in the harness format of workprecision_scipy.py, method "mpmath reference").
"""
from __future__ import annotations

import csv
import sys
import time
from pathlib import Path

import mpmath as mp

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "python"))
import gear_reference as ref  # noqa: E402  (scene parsing only; written from docs/model.md)

mp.mp.dps = 30
ROOT_TOL = mp.mpf("1e-28")  # s; bisection width of a located contact change
SAMPLES_PER_PERIOD = 64
METHOD = "mpmath reference"


class Model:
    """The single-mesh parameters of a scene as mpmath numbers (the scene's binary64 values
    taken exactly)."""

    def __init__(self, scene: ref.Scene):
        if scene.stiffness.kind != "rectangular":
            raise ValueError(f"{scene.name}: stiffness kind {scene.stiffness.kind!r} is not "
                             "piecewise constant (only 'rectangular' is covered)")
        f = mp.mpf
        self.contact = scene.contact
        self.two_b = f(scene.backlash)
        r1, r2, i1, i2 = f(scene.r_b1), f(scene.r_b2), f(scene.inertia1), f(scene.inertia2)
        self.m_e = 1 / (r1**2 / i1 + r2**2 / i2)
        self.f_ext = self.m_e * (r1 * f(scene.input_torque) / i1 + r2 * f(scene.load_torque) / i2)
        self.f_m = scene.z1 * f(scene.pinion_speed) / (2 * mp.pi)
        self.p0 = f(scene.p0)
        self.q0 = self.p0 + f(scene.stiffness.phase)  # shifted phase at t = 0
        self.ste = [(f(scene.ste_cos[h] if h < len(scene.ste_cos) else 0.0),
                     f(scene.ste_sin[h] if h < len(scene.ste_sin) else 0.0))
                    for h in range(max(len(scene.ste_cos), len(scene.ste_sin)))]
        # Rectangular stiffness (docs/model.md): k_low on s ∈ [0, 1 − f), k_high on [1 − f, 1).
        table = scene.stiffness
        pieces = table.pieces  # [k_low on [0, 1 − f)] + [k_high on [1 − f, 1)] if f > 0
        self.k_low = f(pieces[0].k_a)
        self.k_high = f(pieces[1].k_a) if len(pieces) > 1 else self.k_low
        self.s_switch = f(pieces[1].s_a) if len(pieces) > 1 else None
        self.damping = f(scene.damping)
        self.x0 = f(scene.initial_dte)
        self.v0 = f(scene.initial_dte_rate)
        self.omega = [2 * mp.pi * (h + 1) * self.f_m for h in range(len(self.ste))]

    def phase(self, t):
        return self.p0 + self.f_m * t

    def e(self, t):
        p = self.phase(t)
        return mp.fsum(a * mp.cos(2 * mp.pi * (h + 1) * p) + b * mp.sin(2 * mp.pi * (h + 1) * p)
                       for h, (a, b) in enumerate(self.ste))

    def e_rate(self, t):
        p = self.phase(t)
        return mp.fsum(w * (-a * mp.sin(2 * mp.pi * (h + 1) * p)
                            + b * mp.cos(2 * mp.pi * (h + 1) * p))
                       for h, ((a, b), w) in enumerate(zip(self.ste, self.omega)))

    def stiffness_at(self, t_mid):
        """k of the rectangular wave at an instant strictly inside a segment."""
        q = self.q0 + self.f_m * t_mid
        s = q - mp.floor(q)
        if self.s_switch is not None and s >= self.s_switch:
            return self.k_high
        return self.k_low

    def switch_times(self, t_end):
        """Stiffness jumps in (0, t_end): q(t) = n or n + s_switch."""
        out = []
        starts = [mp.mpf(0)] + ([self.s_switch] if self.s_switch is not None else [])
        if self.f_m == 0:
            return out
        for n in range(int(mp.floor(self.q0)) - 1, int(mp.ceil(self.q0 + self.f_m * t_end)) + 2):
            for s in starts:
                t = (n + s - self.q0) / self.f_m
                if 0 < t < t_end:
                    out.append(t)
        return sorted(out)


class Contact:
    """Closed-form motion in contact (state 1 drive side, −1 back side) from (t0, x0, v0) with
    stiffness k: z(t0 + τ) = Σ_j V_j w_j e^{λ_j τ}."""

    def __init__(self, model: Model, state: int, k, t0, x0, v0):
        self.model, self.t0 = model, t0
        n_h = len(model.ste)
        n = 3 + 2 * n_h
        m, c = model.m_e, model.damping
        shift = model.two_b if state == -1 else 0
        a = mp.zeros(n, n)
        a[0, 1] = 1
        a[1, 0] = -k / m
        a[1, 1] = -c / m
        a[1, 2] = (model.f_ext - k * shift) / m
        z0 = mp.matrix(n, 1)
        z0[0], z0[1], z0[2] = x0, v0, 1
        p0 = model.phase(t0)
        for h, ((ca, sb), w) in enumerate(zip(model.ste, model.omega)):
            i = 3 + 2 * h
            a[i, i + 1] = -w  # (cos θ)' = −ω sin θ
            a[i + 1, i] = w  # (sin θ)' = ω cos θ
            a[1, i] = (k * ca + c * w * sb) / m  # k e + c ė, cos part
            a[1, i + 1] = (k * sb - c * w * ca) / m  # sin part
            z0[i] = mp.cos(2 * mp.pi * (h + 1) * p0)
            z0[i + 1] = mp.sin(2 * mp.pi * (h + 1) * p0)
        self.a, self.z0 = a, z0
        lam, vec = mp.eig(a)
        w = mp.lu_solve(vec, z0)
        self.lam = lam
        # Modal coefficients of x, x', e and ė (rows of V times w).
        self.cx = [vec[0, j] * w[j] for j in range(n)]
        self.cv = [vec[1, j] * w[j] for j in range(n)]
        self.ce = [mp.fsum(vec[3 + 2 * h, j] * ca + vec[4 + 2 * h, j] * sb
                           for h, (ca, sb) in enumerate(model.ste)) * w[j] for j in range(n)]
        self.frequency = max(abs(mp.im(v)) for v in lam)

    def _sum(self, coef, tau, power=0):
        return mp.re(mp.fsum(cf * (lj**power) * mp.exp(lj * tau)
                             for cf, lj in zip(coef, self.lam)))

    def x(self, t):
        return self._sum(self.cx, t - self.t0)

    def v(self, t):
        return self._sum(self.cv, t - self.t0)

    def delta(self, t):  # δ = x − e, from the modal sums (e is part of the state)
        return self._sum([a - b for a, b in zip(self.cx, self.ce)], t - self.t0)

    def delta_rate(self, t):
        return self._sum([a - b for a, b in zip(self.cx, self.ce)], t - self.t0, power=1)

    def check_against_expm(self, t):
        """The modal sum against mpmath's expm of A τ at the segment end."""
        z = mp.expm(self.a * (t - self.t0)) * self.z0
        scale = max(abs(z[0]), mp.mpf("1e-12"))
        err = max(abs(z[0] - self.x(t)) / scale, abs(z[1] - self.v(t)) / (scale * self.frequency))
        if err > mp.mpf("1e-24"):
            raise RuntimeError(f"modal solution and expm differ by {mp.nstr(err, 3)} at t={t}")


class Free:
    """Separated flight (F = 0): x = x0 + v0 τ + (F_ext/m_e) τ²/2."""

    def __init__(self, model: Model, t0, x0, v0):
        self.model, self.t0, self.x0, self.v0 = model, t0, x0, v0
        self.acc = model.f_ext / model.m_e
        self.frequency = max(model.omega) if model.omega else mp.mpf(0)

    def x(self, t):
        tau = t - self.t0
        return self.x0 + self.v0 * tau + self.acc * tau**2 / 2

    def v(self, t):
        return self.v0 + self.acc * (t - self.t0)

    def delta(self, t):
        return self.x(t) - self.model.e(t)

    def delta_rate(self, t):
        return self.v(t) - self.model.e_rate(t)


def bisect(fn, lo, hi):
    """Root of fn in [lo, hi] with fn(lo) ≤ 0 < fn(hi), to ROOT_TOL."""
    while hi - lo > ROOT_TOL:
        mid = (lo + hi) / 2
        if fn(mid) > 0:
            hi = mid
        else:
            lo = mid
    return hi


def first_exit(phi, dphi, t0, t1, frequency):
    """First t in (t0, t1] where φ (≤ 0 inside the state) becomes positive, or None."""
    span = t1 - t0
    period = 2 * mp.pi / frequency if frequency > 0 else span
    n = max(8, int(mp.ceil(span / period * SAMPLES_PER_PERIOD)))
    grid = [t0 + span * i / n for i in range(n)] + [t1]
    fa, da = mp.mpf(0), dphi(t0)  # t0 is on a surface or inside: treated as inside
    for a, b in zip(grid[:-1], grid[1:]):
        fb, db = phi(b), dphi(b)
        if fb > 0:
            return bisect(phi, a, b)
        if da > 0 and db < 0:  # an interior maximum: two crossings if it is outside
            t_max = bisect(lambda t: -dphi(t), a, b)
            if phi(t_max) > 0:
                return bisect(phi, a, t_max)
        fa, da = fb, db
    return None


def simulate(model: Model, grid: list[float], stop_time: float):
    """x on the grid and the contact-change times, from t = 0 to stop_time."""
    t_end = mp.mpf(stop_time)
    bounds = [mp.mpf(0)] + model.switch_times(t_end) + [t_end]
    out_t = [mp.mpf(t) for t in grid]
    x_out = [None] * len(out_t)
    events = []
    x, v = model.x0, model.v0
    delta0 = x - model.e(0)
    state = 1 if delta0 > 0 or model.contact == "linear" else (
        -1 if model.contact == "backlash" and delta0 < -model.two_b else 0)
    nxt = 0
    for seg_a, seg_b in zip(bounds[:-1], bounds[1:]):
        k = model.stiffness_at((seg_a + seg_b) / 2)
        t = seg_a
        while True:
            if state == 0:
                motion = Free(model, t, x, v)
            else:
                motion = Contact(model, state, k, t, x, v)
            # Guards of the state: (φ, φ', new state, surface offset); φ ≤ 0 inside.
            guards = []
            if model.contact != "linear":
                if state == 1:
                    guards = [(lambda s: -motion.delta(s), lambda s: -motion.delta_rate(s), 0, 0)]
                elif state == 0:
                    guards = [(lambda s: motion.delta(s), lambda s: motion.delta_rate(s), 1, 0)]
                    if model.contact == "backlash":
                        guards.append((lambda s: -(motion.delta(s) + model.two_b),
                                       lambda s: -motion.delta_rate(s), -1, -model.two_b))
                else:
                    guards = [(lambda s: motion.delta(s) + model.two_b,
                               lambda s: motion.delta_rate(s), 0, -model.two_b)]
            hit = None
            for phi, dphi, new_state, offset in guards:
                t_hit = first_exit(phi, dphi, t, seg_b, motion.frequency)
                if t_hit is not None and (hit is None or t_hit < hit[0]):
                    hit = (t_hit, new_state, offset)
            t_stop = hit[0] if hit else seg_b
            last = seg_b == t_end and hit is None
            while nxt < len(out_t) and (out_t[nxt] < t_stop or (last and out_t[nxt] <= t_stop)):
                x_out[nxt] = motion.x(out_t[nxt])
                nxt += 1
            if isinstance(motion, Contact):
                motion.check_against_expm(t_stop)
            x_new, v = motion.x(t_stop), motion.v(t_stop)
            if hit is None:
                x = x_new
                break
            t, state = hit[0], hit[1]
            x = model.e(t) + hit[2]  # on the switching surface (the change is < 1e-28 s · x')
            events.append(t)
            if t >= seg_b:
                break
    while nxt < len(out_t):  # an event exactly at the end time
        x_out[nxt] = x
        nxt += 1
    return x_out, events


def join(values) -> str:
    return ";".join(f"{float(v):.17e}" for v in values)


def main() -> int:
    bench_dir = Path(sys.argv[1] if len(sys.argv) > 1 else "target/workprecision")
    problems = [dict(r) for r in csv.DictReader(open(bench_dir / "problems.csv"))]
    header = ["problem", "method", "tol", "rtol", "atol", "status", "wall_s", "timed_runs", "rhs",
              "steps", "rejected", "events", "final_x", "final_v", "dte", "event_times"]
    rows = []
    for p in problems:
        if p["kind"] != "pair" or p["exact_eligible"] != "true":
            continue
        name = p["problem"]
        scene = ref.load_scene(bench_dir / "scenes" / f"{name}.toml")
        if scene.stiffness.kind != "rectangular":
            continue
        stop, samples = float(p["stop_time"]), int(p["samples"])
        grid = [k * stop / samples for k in range(samples)] + [stop]
        t0 = time.perf_counter()
        try:
            x, events = simulate(Model(scene), grid, stop)
            status = "ok"
        except Exception as exc:  # recorded as a failed row, never dropped
            x, events, status = [], [], "failed: " + str(exc).replace(",", ";").replace("\n", " ")
        wall = time.perf_counter() - t0
        rows.append([name, METHOD, "0", "", "", status, f"{wall:e}", "0", "", "", "",
                     str(len(events)), f"{float(x[-1]):.17e}" if x else "", "", join(x),
                     join(events)])
        print(f"mpmath {name:16} {status[:60]:8} {len(events)} contact changes, {wall:7.1f} s",
              flush=True)
    with open(bench_dir / "mpmath.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        w.writerows(rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
