"""Piecewise-linear hybrid integration of a lumped gear model with backlash whose back flanks
touch along their own line of action, for the independent scipy references of
`test_backflank_reference.py` (issue 33, "Back flanks"; docs/train.md).

A model gives, in physical coordinates q (dof of them): the diagonal mass `mass`, the base
stiffness `k` and damping `c` (bearings, supports), the generalised force `force`, and per mesh
j the drive-flank row `rows[j]` (mesh deflection δ_j = rows[j]·q, > 0 compresses the drive
flanks) and the back-flank row `back_rows[j]` (δ̃_j = back_rows[j]·q: the same rotational part,
the translations along the back flanks' line of action), the mesh stiffness `stiffness(j, t)`
(piecewise constant between the times `breaks(t_end)`), the mesh damping `c_mesh` and the total
backlash `clearance` (2b); optionally an STE `ste(j, t) = (e_j, ė_j)`, which every flank's
deflection has subtracted (δ_j = rows[j]·q − e_j, δ̃_j = back_rows[j]·q − e_j). Mesh j is in
one of four states:

- drive ('D'): force k_j δ_j + c_m δ'_j along rows[j]; leaves when δ_j falls through 0;
- separated ('S'): no force; drive contact when δ_j rises through 0, back contact when
  δ̃_j + 2b falls through 0;
- back ('B'): force k_j (δ̃_j + 2b) + c_m δ̃'_j along back_rows[j]; leaves when δ̃_j + 2b rises
  through 0;
- wedged ('W', both flanks pressed: the back flanks' row differs from the drive row, so the
  centres can approach by more than the backlash): both forces, each along its own row; the
  drive flanks open when δ_j falls through 0 (to 'B'), the back flanks when δ̃_j + 2b rises
  through 0 (to 'D'). 'D' enters it when δ̃_j + 2b falls through 0, 'B' when δ_j rises
  through 0.

Between stiffness switches and contact changes the equations are linear with constant
coefficients (and the STE's forcing); DOP853 at rtol 1e-12, every contact change a terminal event, and after an event
the state is put on the crossed surface (orthogonal projection along the row).
"""

import numpy as np
from scipy.integrate import solve_ivp


def first_dip(sol, t, t_stop, guards, dof, ste, per_step=16):
    """The first time in (t, t_stop) at which a guard crosses zero in its direction between
    two of `per_step` points of one of scipy's steps (a brief contact change that starts and
    ends within a step, which scipy's events do not see), located by Brent's method on the
    dense output, with the guard's index; `None` if there is none. A guard is
    `(mesh, row, offset, direction, kind)` with the value `row·q − e_mesh(t) + offset`."""
    from scipy.optimize import brentq

    def value(i, s, q):
        j, row, offset, _, _ = guards[i]
        return row @ q - ste(j, s)[0] + offset

    for a, b in zip(sol.t[:-1], sol.t[1:]):
        if a >= t_stop:
            break
        b = min(b, t_stop)
        grid = np.linspace(a, b, per_step + 1)
        q = sol.sol(grid)[:dof]
        # `ste` takes arrays of times.
        vals = [row @ q - ste(j, grid)[0] + offset for j, row, offset, _, _ in guards]
        for k in range(1, len(grid)):
            if grid[k] >= t_stop - 1e-9 * (t_stop - t):
                break
            found = [i for i, g in enumerate(guards)
                     if g[3] * vals[i][k] > 0.0 >= g[3] * vals[i][k - 1] and grid[k - 1] > t]
            if not found:
                continue
            hits = [(brentq(lambda s, i=i: value(i, s, sol.sol(s)[:dof]), grid[k - 1], grid[k],
                            xtol=1e-300, rtol=4 * np.finfo(float).eps, maxiter=200), i)
                    for i in found]
            return min(hits)
    return None


# The guards of each state: (flank, direction, kind); the kind's last letter is the new state.
# A flank's guard is `δ_j` (drive) or `δ̃_j + 2b` (back), a drive flank opens when its guard
# falls through 0, a back flank when its guard rises through 0. With the back flanks on their
# own row the flank not in contact closes whatever the other one does: both pressed ('W').
GUARDS = {
    "D": [("drive", -1.0, "D>S"), ("back", -1.0, "D>W")],
    "S": [("drive", 1.0, "S>D"), ("back", -1.0, "S>B")],
    "B": [("back", 1.0, "B>S"), ("drive", 1.0, "B>W")],
    "W": [("drive", -1.0, "W>B"), ("back", 1.0, "W>D")],
}


def run_hybrid(model, times, log=None, max_step=np.inf, wedging=True):
    """DTE rows `model.dte` applied to `model.elastic(q)` at `times` (from the static start
    `model.start()`), and the contact changes counted by kind ('D>S', 'S>D', 'S>B', 'B>S',
    'D>W', 'B>W', 'W>B', 'W>D'), with the number of (output sample, mesh) at which the mesh is
    wedged ('wedged'). A model may have an STE `model.ste(j, t) = (e_j, de_j/dt)` (none: 0).
    `wedging=False` (the control): a flank is only watched while the other is open, the old
    model that never enters 'W'."""
    dof = model.dof
    rows, back_rows, b = model.rows, model.back_rows, model.clearance
    ste = getattr(model, "ste", lambda _j, _t: (0.0, 0.0))
    meshes = len(rows)
    minv = 1.0 / model.mass
    breaks = model.breaks(times[-1]) + [times[-1]]
    y = model.start()
    state = ["D"] * meshes
    counts = {kind: 0 for guards in GUARDS.values() for _, _, kind in guards}
    counts["wedged"] = 0
    out = np.empty((len(times), meshes))
    out[0] = model.dte @ model.elastic(y[:dof])
    k_out, t = 1, 0.0
    for t_break in breaks:
        while t < t_break:
            mid = 0.5 * (t + t_break)
            k_tot, c_tot = model.k.copy(), model.c.copy()
            force = model.force.copy()
            # Per pressed flank: its row, stiffness (the STE term `k e + c ė` along the row).
            pressed = []
            for j in range(meshes):
                kj = model.stiffness(j, mid)
                if state[j] in "DW":
                    pressed.append((j, rows[j], kj))
                if state[j] in "BW":
                    pressed.append((j, back_rows[j], kj))
                    force -= kj * b * back_rows[j]
            for j, row, kj in pressed:
                k_tot += kj * np.outer(row, row)
                c_tot += model.c_mesh * np.outer(row, row)
            a = np.block([[np.zeros((dof, dof)), np.eye(dof)],
                          [-minv[:, None] * k_tot, -minv[:, None] * c_tot]])
            rhs_b = np.concatenate([np.zeros(dof), minv * force])

            def rhs(s_t, s, a=a, rhs_b=rhs_b, pressed=pressed):
                g = np.zeros(dof)
                for j, row, kj in pressed:
                    e, e_dot = ste(j, s_t)
                    g += (kj * e + model.c_mesh * e_dot) * row
                return a @ s + rhs_b + np.concatenate([np.zeros(dof), minv * g])

            evs, kinds = [], []
            for j in range(meshes):
                for flank, direction, kind in GUARDS[state[j]]:
                    if not wedging and "W" in kind:
                        continue
                    row, offset = (rows[j], 0.0) if flank == "drive" else (back_rows[j], b)

                    def ev(s_t, s, j=j, row=row, offset=offset):
                        return row @ s[:dof] - ste(j, s_t)[0] + offset
                    ev.terminal = True
                    ev.direction = direction
                    evs.append(ev)
                    kinds.append((j, row, offset, direction, kind))
            sol = solve_ivp(rhs, (t, t_break), y, method="DOP853",
                            rtol=1e-12, atol=1e-22, events=evs, dense_output=True,
                            max_step=max_step)
            hit = [i for i in range(len(evs)) if sol.t_events[i].size and sol.t_events[i][0] > t]
            t_stop = min((sol.t_events[i][0] for i in hit), default=t_break)
            dip = first_dip(sol, t, t_stop, kinds, dof, ste)
            y_dip = None
            if dip is not None:
                t_stop, i_dip = dip
                hit = [i_dip]
                y_dip = sol.sol(t_stop).copy()
            while k_out < len(times) and times[k_out] <= t_stop:
                q = sol.sol(times[k_out])[:dof]
                out[k_out] = model.dte @ model.elastic(q)
                counts["wedged"] += state.count("W")
                k_out += 1
            if hit:
                i = min(hit, key=lambda i: sol.t_events[i][0] if y_dip is None else 0.0)
                j, row, offset, _, kind = kinds[i]
                y = sol.y_events[i][0].copy() if y_dip is None else y_dip
                q = y[:dof]
                y[:dof] = q - row * (row @ q - ste(j, t_stop)[0] + offset) / (row @ row)
                state[j] = kind[-1]
                counts[kind] += 1
                if log is not None:
                    log.append((t_stop, j, kind))
                t = t_stop
            else:
                y = sol.y[:, -1].copy()
                t = t_break
    return out, counts
