"""Piecewise DOP853 integration of a gear model with unilateral contacts, for the independent
scipy references (`test_idler_reference.py`, `test_countershaft_reference.py`).

Between known stiffness switches (`breaks`) the right-hand side is smooth; the deflection
`y[j]` of each contact is a terminal event, and at a contact change the state is put on the
switching surface (`y[j] = 0`) before the integration restarts with the new contact set.
"""

import math

import numpy as np
from scipy.integrate import solve_ivp


def switch_times(frequencies, phases, offsets, t_end):
    """The known stiffness switches in (0, t_end), sorted: mesh j switches where its phase
    `phases[j] + frequencies[j]·t` reaches `n + s` for every integer n and every s in
    `offsets[j]` (a rectangular wave: s = 0 and s = 1 − f)."""
    times = set()
    for f, p, offs in zip(frequencies, phases, offsets):
        n = math.floor(p)
        while (n - p) / f <= t_end:
            for s in offs:
                t = (n + s - p) / f
                if 0 < t < t_end:
                    times.add(t)
            n += 1
    return sorted(times)


def dte_model_rhs(minv, force, damping, stiffness):
    """`rhs_for` of `integrate` for a model in the meshes' DTEs x (`M x'' + C x' + H K(t) x =
    force`, H the contact flags): `stiffness(j, t)` is mesh j's stiffness, frozen for a segment
    at its midpoint (segments end at every switch)."""
    meshes = len(force)

    def rhs_for(mid, contact):
        k = [stiffness(j, mid) for j in range(meshes)]

        def rhs(_t, state):
            x, v = state[:meshes], state[meshes:]
            f_mesh = np.array([k[j] * x[j] if contact[j] else 0.0 for j in range(meshes)])
            return np.concatenate([v, minv @ (force - f_mesh - damping @ v)])
        return rhs
    return rhs_for


def first_dip(sol, t, t_stop, contact, contacts, per_step=16):
    """The first time in (t, t_stop) at which a contact's deflection crosses to the wrong side
    between two of `per_step` points of one of scipy's steps (a dip that starts and ends
    within a step: scipy's events only see a sign change at a step's end), located on the
    dense output by Brent's method, with its contact; `None` if there is none."""
    from scipy.optimize import brentq
    wrong = [(lambda v: v < 0.0) if contact[j] else (lambda v: v > 0.0) for j in range(contacts)]
    for a, b in zip(sol.t[:-1], sol.t[1:]):
        if a >= t_stop:
            break
        b = min(b, t_stop)
        grid = np.linspace(a, b, per_step + 1)
        vals = sol.sol(grid)[:contacts]
        for i in range(1, len(grid)):
            found = [j for j in range(contacts)
                     if wrong[j](vals[j, i]) and not wrong[j](vals[j, i - 1])]
            if not found or grid[i] >= t_stop - 1e-9 * (t_stop - t):
                continue
            hits = [(brentq(lambda s, j=j: sol.sol(s)[j], grid[i - 1], grid[i], xtol=1e-300,
                            rtol=4 * np.finfo(float).eps, maxiter=200), j) for j in found]
            return min(hits)
    return None


def integrate(times, y, breaks, rhs_for, contacts, max_step=np.inf, segments=None):
    """The first `contacts` state components at `times` (from `y` at `times[0] = 0`), and
    whether each contact was ever lost. With a list `segments`, every smooth piece is appended
    to it as `(t_start, t_end, dense solution, contact flags)` (for statistics from the
    continuous solution, `test_statistics_reference.py`). `rhs_for(t_mid, contact)` returns the right-hand side
    of the segment around `t_mid` with the contact flags `contact` (a list, updated here).
    `max_step` bounds scipy's step: its events only see a sign change at a step's end, so each
    step's dense output is also scanned for a short dip of a deflection below zero within the
    step ([`first_dip`]), which ends the segment like an event."""
    contact = [True] * contacts
    lost = [False] * contacts
    out = np.empty((len(times), contacts))
    out[0] = y[:contacts]
    k_out = 1
    t = 0.0
    for t_break in breaks:
        while t < t_break:
            rhs = rhs_for(0.5 * (t + t_break), contact)
            events = []
            for j in range(contacts):
                def ev(_t, state, j=j):
                    return state[j]
                ev.terminal = True
                ev.direction = -1.0 if contact[j] else 1.0
                events.append(ev)
            sol = solve_ivp(rhs, (t, t_break), y, method="DOP853", rtol=1e-12, atol=1e-20,
                            events=events, dense_output=True, max_step=max_step)
            hit = [j for j in range(contacts)
                   if sol.t_events[j].size > 0 and sol.t_events[j][0] > t]
            t_stop = min((sol.t_events[j][0] for j in hit), default=t_break)
            if not hit and sol.status == 1:
                # A terminal event at the start itself: a contact that changed at t and crossed
                # back within scipy's first step. Skipping to t_break would lose the segment.
                raise RuntimeError(f"a contact crosses back within the first step after t = {t}")
            # A dip within one step (a brief contact loss) that scipy's events miss.
            dip = first_dip(sol, t, t_stop, contact, contacts)
            y_dip = None
            if dip is not None:
                t_stop, j_dip = dip
                hit = [j_dip]
                y_dip = sol.sol(t_stop).copy()
            while k_out < len(times) and times[k_out] <= t_stop:
                out[k_out] = sol.sol(times[k_out])[:contacts]
                k_out += 1
            if segments is not None:
                segments.append((t, t_stop, sol.sol, list(contact)))
            if y_dip is not None:
                j = hit[0]
                y = y_dip
                y[j] = 0.0
                contact[j] = not contact[j]
                lost[j] |= not contact[j]
                t = t_stop
            elif hit:
                j = min(hit, key=lambda i: sol.t_events[i][0])
                y = sol.y_events[j][0].copy()
                y[j] = 0.0
                contact[j] = not contact[j]
                lost[j] |= not contact[j]
                t = t_stop
            else:
                y = sol.y[:, -1].copy()
                t = t_break
    return out, lost
