"""Piecewise-linear hybrid integration of a lumped gear model with backlash whose back flanks
touch along their own line of action, for the independent scipy references of
`test_backflank_reference.py` (issue 33, "Back flanks"; docs/train.md).

A model gives, in physical coordinates q (dof of them): the diagonal mass `mass`, the base
stiffness `k` and damping `c` (bearings, supports), the generalised force `force`, and per mesh
j the drive-flank row `rows[j]` (mesh deflection δ_j = rows[j]·q, > 0 compresses the drive
flanks) and the back-flank row `back_rows[j]` (δ̃_j = back_rows[j]·q: the same rotational part,
the translations along the back flanks' line of action), the mesh stiffness `stiffness(j, t)`
(piecewise constant between the times `breaks(t_end)`), the mesh damping `c_mesh` and the total
backlash `clearance` (2b). Mesh j is in one of three states:

- drive ('D'): force k_j δ_j + c_m δ'_j along rows[j]; leaves when δ_j falls through 0;
- separated ('S'): no force; drive contact when δ_j rises through 0, back contact when
  δ̃_j + 2b falls through 0;
- back ('B'): force k_j (δ̃_j + 2b) + c_m δ̃'_j along back_rows[j]; leaves when δ̃_j + 2b rises
  through 0.

Between stiffness switches and contact changes the equations are linear with constant
coefficients; DOP853 at rtol 1e-12, every contact change a terminal event, and after an event
the state is put on the crossed surface (orthogonal projection along the row).
"""

import numpy as np
from scipy.integrate import solve_ivp


def first_dip(sol, t, t_stop, guards, dof, per_step=16):
    """The first time in (t, t_stop) at which a guard crosses zero in its direction between
    two of `per_step` points of one of scipy's steps (a brief contact change that starts and
    ends within a step, which scipy's events do not see), located by Brent's method on the
    dense output, with the guard's index; `None` if there is none."""
    from scipy.optimize import brentq
    sign = {"D>S": -1.0, "S>D": 1.0, "S>B": -1.0, "B>S": 1.0}
    for a, b in zip(sol.t[:-1], sol.t[1:]):
        if a >= t_stop:
            break
        b = min(b, t_stop)
        grid = np.linspace(a, b, per_step + 1)
        q = sol.sol(grid)[:dof]
        vals = [row @ q + offset for _, row, offset, _ in guards]
        for k in range(1, len(grid)):
            if grid[k] >= t_stop - 1e-9 * (t_stop - t):
                break
            found = [i for i, (_, _, _, kind) in enumerate(guards)
                     if sign[kind] * vals[i][k] > 0.0 >= sign[kind] * vals[i][k - 1]
                     and grid[k - 1] > t]
            if not found:
                continue
            hits = [(brentq(lambda s, i=i: guards[i][1] @ sol.sol(s)[:dof] + guards[i][2],
                            grid[k - 1], grid[k], xtol=1e-300, rtol=4 * np.finfo(float).eps,
                            maxiter=200), i) for i in found]
            return min(hits)
    return None


def run_hybrid(model, times, log=None, max_step=np.inf):
    """DTE rows `model.dte` applied to `model.elastic(q)` at `times` (from the static start
    `model.start()`), and the contact changes counted by kind: 'D>S', 'S>D', 'S>B', 'B>S'."""
    dof = model.dof
    rows, back_rows, b = model.rows, model.back_rows, model.clearance
    meshes = len(rows)
    minv = 1.0 / model.mass
    breaks = model.breaks(times[-1]) + [times[-1]]
    y = model.start()
    state = ["D"] * meshes
    counts = {"D>S": 0, "S>D": 0, "S>B": 0, "B>S": 0, "wedged": 0}
    out = np.empty((len(times), meshes))
    out[0] = model.dte @ model.elastic(y[:dof])
    k_out, t = 1, 0.0
    for t_break in breaks:
        while t < t_break:
            mid = 0.5 * (t + t_break)
            k_tot, c_tot = model.k.copy(), model.c.copy()
            force = model.force.copy()
            for j in range(meshes):
                kj = model.stiffness(j, mid)
                if state[j] == "D":
                    k_tot += kj * np.outer(rows[j], rows[j])
                    c_tot += model.c_mesh * np.outer(rows[j], rows[j])
                elif state[j] == "B":
                    k_tot += kj * np.outer(back_rows[j], back_rows[j])
                    c_tot += model.c_mesh * np.outer(back_rows[j], back_rows[j])
                    force -= kj * b * back_rows[j]
            a = np.block([[np.zeros((dof, dof)), np.eye(dof)],
                          [-minv[:, None] * k_tot, -minv[:, None] * c_tot]])
            rhs_b = np.concatenate([np.zeros(dof), minv * force])
            evs, kinds = [], []
            for j in range(meshes):
                guards = {"D": [(rows[j], 0.0, -1.0, "D>S")],
                          "S": [(rows[j], 0.0, 1.0, "S>D"), (back_rows[j], b, -1.0, "S>B")],
                          "B": [(back_rows[j], b, 1.0, "B>S")]}[state[j]]
                for row, offset, direction, kind in guards:
                    ev = lambda _t, s, row=row, offset=offset: row @ s[:dof] + offset
                    ev.terminal = True
                    ev.direction = direction
                    evs.append(ev)
                    kinds.append((j, row, offset, kind))
            sol = solve_ivp(lambda _t, s: a @ s + rhs_b, (t, t_break), y, method="DOP853",
                            rtol=1e-12, atol=1e-22, events=evs, dense_output=True,
                            max_step=max_step)
            hit = [i for i in range(len(evs)) if sol.t_events[i].size and sol.t_events[i][0] > t]
            t_stop = min((sol.t_events[i][0] for i in hit), default=t_break)
            dip = first_dip(sol, t, t_stop, kinds, dof)
            y_dip = None
            if dip is not None:
                t_stop, i_dip = dip
                hit = [i_dip]
                y_dip = sol.sol(t_stop).copy()
            while k_out < len(times) and times[k_out] <= t_stop:
                q = sol.sol(times[k_out])[:dof]
                out[k_out] = model.dte @ model.elastic(q)
                counts["wedged"] += int(np.any((rows @ q > 0.0) & (back_rows @ q + b < 0.0)))
                k_out += 1
            if hit:
                i = min(hit, key=lambda i: sol.t_events[i][0] if y_dip is None else 0.0)
                j, row, offset, kind = kinds[i]
                y = sol.y_events[i][0].copy() if y_dip is None else y_dip
                q = y[:dof]
                y[:dof] = q - row * (row @ q + offset) / (row @ row)
                state[j] = kind[-1]
                counts[kind] += 1
                if log is not None:
                    log.append((t_stop, j, kind))
                t = t_stop
            else:
                y = sol.y[:, -1].copy()
                t = t_break
    return out, counts
