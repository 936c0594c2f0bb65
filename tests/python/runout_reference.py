"""Independent scipy model of a spur pair whose gears have runout, with every effect of the
moving gear centre (issue 31 item 7; `docs/errors.md`, "Runout as a moving centre").

Written from the involute geometry in `docs/errors.md`, not from the Rust code, and coded as
vector geometry (the Rust code sums components): the geometric centres are

    G_1 = w_1(p),   G_2 = a0 ĉ0 + w_2(p),   w_g = A_g (cos ψ_g, sin ψ_g),
    ψ_g = σ_g 2π (p − p0)/z_g + φ_g,

in the scene frame, with the line of action ℓ = (cos β, sin β), β = centre_angle + σ_1 α0, and
the centre line ĉ0 = ℓ turned by −σ_1(π/2 − α0) (the internal tangent of the base circles
seen from the pinion). From D = G_2 − G_1:

    a = |D|,  χ = arg D,  cos α = (r_1 + r_2)/a,
    δq = −z_1 (σ_1 (χ − χ0) − (α − α0)) / 2π        (mesh position, cycles)
    entry = (√(a² − R²) − √(a0² − R²)) / p_b         (later start of contact, cycles)
    Δj = 2R (inv α − inv α0),  inv α = tan α − α     (total normal backlash)
    e = e_ste(p + δq) − (w_1 − w_2)·ℓ                 (STE: tooth STE at the contact, runout)

and the DTE model of `docs/model.md` in x = r_1θ_1 − r_2θ_2 (rigid bearings):

    m_e x'' + F = T_1/r_1 (balanced load),  δ = x − e,
    F = k(δ) + c(ẋ − ė) in drive contact (δ > 0), k(δ + j_0 + Δj) + c(ẋ − ė) on the back
    side (δ < −j), 0 between,  k = k_low on s ∈ [0, 1 − f + entry), k_high after,
    s = frac(p + δq),  p = p0 + f_m t.

Integrated with DOP853 at rtol 1e-12 between the stiffness switches (found by brentq on the
nominal phase), with the contact changes as terminal events (state snapped onto the surface).
"""

import math

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

TWO_PI = 2.0 * math.pi


class RunoutPair:
    def __init__(self, *, teeth, base_radii, inertias, k_mean, peak_to_peak, contact_ratio,
                 backlash, damping, ste_cos1, speed, torque, pressure_deg, runouts,
                 pitch=None, centre_angle=0.0, p0=0.0, moving_centre=True,
                 senses=(1.0, -1.0)):
        """`backlash` None: the linear contact law; `damping` c in N·s/m; `pitch` the
        pinion's cumulative pitch deviations (added to e while the tooth is in mesh: cycle
        c = floor(p + δq) holds tooth c mod z_1)."""
        self.z = teeth
        self.r = base_radii
        self.m_e = 1.0 / (base_radii[0] ** 2 / inertias[0] + base_radii[1] ** 2 / inertias[1])
        f = contact_ratio - math.floor(contact_ratio)
        self.f = f
        self.k_low = k_mean * (1.0 - f * peak_to_peak)
        self.k_high = self.k_low + peak_to_peak * k_mean
        self.c = damping
        self.pitch = pitch
        self.backlash = backlash
        self.ste1 = ste_cos1
        self.f_mesh = teeth[0] * speed / TWO_PI
        self.force = torque / base_radii[0]
        self.p0 = p0
        self.senses = senses                 # rotation senses of the pinion and the gear
        self.alpha0 = math.radians(pressure_deg)
        self.R = base_radii[0] + base_radii[1]
        self.a0 = self.R / math.cos(self.alpha0)
        self.beta = centre_angle + self.senses[0] * self.alpha0
        self.ell = (math.cos(self.beta), math.sin(self.beta))
        self.chi0 = self.beta - self.senses[0] * (math.pi / 2 - self.alpha0)
        self.c0 = (self.a0 * math.cos(self.chi0), self.a0 * math.sin(self.chi0))
        self.path0 = math.sqrt(self.a0 ** 2 - self.R ** 2)
        self.base_pitch = TWO_PI * base_radii[0] / teeth[0]
        self.runouts = runouts               # {gear index: (A, φ)}
        # False: the displacement along the line of action only (the model before issue 31
        # item 7), to show what the moving centre adds.
        self.moving_centre = moving_centre

    # --- geometry -----------------------------------------------------------------------
    def centre(self, g, p):
        """w_g: the geometric centre of gear g from its axis (plain tuples: this runs in
        every right-hand side)."""
        if g not in self.runouts:
            return (0.0, 0.0)
        amplitude, phi = self.runouts[g]
        psi = self.senses[g] * TWO_PI * (p - self.p0) / self.z[g] + phi
        return (amplitude * math.cos(psi), amplitude * math.sin(psi))

    def geometry(self, p):
        """(δq, entry, Δj, runout STE) at nominal phase p."""
        w1, w2 = self.centre(0, p), self.centre(1, p)
        d = (self.c0[0] + w2[0] - w1[0], self.c0[1] + w2[1] - w1[1])
        a = math.hypot(d[0], d[1])
        chi = math.atan2(d[1], d[0])
        dchi = math.remainder(chi - self.chi0, TWO_PI)
        alpha = math.acos(self.R / a)
        dq = -self.z[0] * (self.senses[0] * dchi - (alpha - self.alpha0)) / TWO_PI
        entry = (math.sqrt(a * a - self.R ** 2) - self.path0) / self.base_pitch
        inv = lambda x: math.tan(x) - x
        dj = 2.0 * self.R * (inv(alpha) - inv(self.alpha0))
        e_runout = -((w1[0] - w2[0]) * self.ell[0] + (w1[1] - w2[1]) * self.ell[1])
        if not self.moving_centre:
            return 0.0, 0.0, 0.0, e_runout
        return dq, entry, dj, e_runout

    def phase(self, t):
        return self.p0 + self.f_mesh * t

    def ste(self, t):
        """e and de/dt (central difference of the geometry: it is smooth; h = 1e-5 cycle
        leaves a truncation of (2πh/z)² ~ 1e-11 relative)."""
        def e_of(p):
            dq, _, _, e_run = self.geometry(p)
            return self.ste1 * math.cos(TWO_PI * (p + dq)) + e_run
        p = self.phase(t)
        h = 1e-5
        de = (e_of(p + h) - e_of(p - h)) / (2 * h)
        return e_of(p), de * self.f_mesh

    def clearance(self, t):
        return self.backlash + self.geometry(self.phase(t))[2]

    def pitch_at(self, t):
        """The pinion's pitch deviation in mesh at t (constant between the exit knots)."""
        if self.pitch is None:
            return 0.0
        p = self.phase(t)
        return self.pitch[math.floor(p + self.geometry(p)[0]) % self.z[0]]

    # --- stiffness switches ---------------------------------------------------------------
    def switch_times(self, t_end):
        """Nominal-time instants where s = frac(p + δq) crosses 0 (a pair leaves) and where
        it crosses 1 − f + entry (a pair enters), in (0, t_end)."""
        times = []
        p_end = self.phase(t_end)
        n = math.floor(self.p0) - 1
        while n <= p_end + 1:
            for target, with_entry in ((n, False), (n + 1.0 - self.f, True)):
                def g(p):
                    dq, entry, _, _ = self.geometry(p)
                    return p + dq - (entry if with_entry else 0.0) - target
                p = brentq(g, target - 0.05, target + 0.05, xtol=1e-15, rtol=1e-15)
                t = (p - self.p0) / self.f_mesh
                if 0.0 < t < t_end:
                    times.append(t)
            n += 1
        return sorted(times)

    def stiffness_at(self, t):
        p = self.phase(t)
        dq, entry, _, _ = self.geometry(p)
        s = (p + dq) - math.floor(p + dq)
        return self.k_low if s < 1.0 - self.f + entry else self.k_high

    # --- integration ----------------------------------------------------------------------
    def run(self, times, x0, v0, samples_out=None):
        """DTE at `times` (times[0] = 0) from (x0, v0)."""
        breaks = self.switch_times(times[-1]) + [times[-1]]
        state = 1  # 1 drive, 0 separated, -1 back
        y = np.array([x0, v0])
        linear = self.backlash is None
        if linear:
            state = 1
        else:
            delta = x0 - self.ste(0.0)[0] - self.pitch_at(0.0)
            state = 1 if delta > 0 else (-1 if delta < -self.clearance(0.0) else 0)
        out = np.empty(len(times))
        out[0] = x0
        k_out = 1
        t = 0.0
        lost = 0.0
        for t_break in breaks:
            while t < t_break:
                k = self.stiffness_at(0.5 * (t + t_break))
                step = self.pitch_at(0.5 * (t + t_break))

                def rhs(tt, yy, k=k, state=state, step=step):
                    e, de = self.ste(tt)
                    e += step
                    d = yy[0] - e
                    if state == 1:
                        force = k * d + self.c * (yy[1] - de)
                    elif state == -1:
                        force = k * (d + self.clearance(tt)) + self.c * (yy[1] - de)
                    else:
                        force = 0.0
                    return [yy[1], (self.force - force) / self.m_e]

                def drive(tt, yy, step=step):
                    return yy[0] - self.ste(tt)[0] - step

                def back(tt, yy, step=step):
                    return yy[0] - self.ste(tt)[0] - step + self.clearance(tt)

                drive.terminal = back.terminal = True
                if linear:
                    events = []
                elif state == 1:
                    drive.direction, events = -1.0, [drive]
                elif state == -1:
                    back.direction, events = 1.0, [back]
                else:
                    drive.direction, back.direction = 1.0, -1.0
                    events = [drive, back]
                sol = solve_ivp(rhs, (t, t_break), y, method="DOP853", rtol=1e-12, atol=1e-20,
                                events=events, dense_output=True,
                                max_step=0.05 / self.f_mesh)
                hits = [(ev[0], i) for i, ev in enumerate(sol.t_events) if ev.size and ev[0] > t]
                if not hits and sol.status == 1:
                    raise RuntimeError(f"a contact crosses back within the first step at {t}")
                t_stop = min(hits)[0] if hits else t_break
                k_end = np.searchsorted(times, t_stop, side="right")
                if k_end > k_out:
                    out[k_out:k_end] = sol.sol(times[k_out:k_end])[0]
                    k_out = k_end
                if state == 0:
                    lost += t_stop - t
                if hits:
                    _, i = min(hits)
                    y = sol.sol(t_stop).copy()
                    surface = events[i]
                    e = self.ste(t_stop)[0] + step
                    if surface is drive:
                        y[0] = e
                        state = 0 if state == 1 else 1
                    else:
                        y[0] = e - self.clearance(t_stop)
                        state = 0 if state == -1 else -1
                    t = t_stop
                else:
                    y = sol.y[:, -1].copy()
                    t = t_break
        assert k_out == len(times)
        return out, lost / times[-1], y
