#!/usr/bin/env python3
"""Independent scipy reference for a gear pair with torque ports and carried rotation
(docs/ports.md; issue 18 point 1). Nothing here is derived from the Rust model code.

The gear data (stiffness k(p), STE e(p), contact law, damping) are read by the single-pair
reference ``gear_reference.py`` (written from docs/model.md); this file adds the rigid-body
rotation and the port torques, in its own coordinates:

    J1 θ1'' = T_in − r1 F,     J2 θ2'' = T_out + r2 F,     S = r1 θ1 − r2 θ2,

θ positive in each gear's rotation sense, T_in / T_out the port torques (the neighbour's
torque on each shaft, positive along the rotation), and the mesh force of docs/model.md

    F = k(p)(S − e(p)) + c(Ṡ − ė)   (drive contact),   k(p)(S − e(p) + 2b) + c(Ṡ − ė)  (back),

with the mesh phase following the pinion angle, p = p0 + z1 θ1 / 2π, ṗ = z1 θ1' / 2π.

State: [S, Ṡ, φ, ψ] with φ = θ1 − Ω t, ψ = θ1' − Ω (Ω the start speed), so that the
deflection S (µm) is an integrated state of its own and not the difference of two large
angles. θ2 = (r1 θ1 − S)/r2.

Stiffness knots (jumps of the rectangular wave) and contact changes are terminal events of
``solve_ivp`` (DOP853, rtol 1e-12): the knots on the pinion angle, in both directions, the
contact changes on δ = S − e(p) and δ + 2b. The piece of the stiffness is frozen between
knot events, the contact state between contact events (numerics-notes §2.1).
"""
from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

import gear_reference as ref

TWO_PI = 2.0 * math.pi


@dataclass
class PortScene:
    base: ref.Scene
    t_in: float
    t_out: float
    omega: float
    # Port torque rates, N·m/s: T(t) = T + T'·t from t = 0 (a master's input derivatives).
    rate_in: float = 0.0
    rate_out: float = 0.0


def load(path) -> PortScene:
    """A pair scene with two torque ports ``input`` (pinion) and ``output`` (gear)."""
    with open(path, "rb") as fh:
        doc = tomllib.load(fh)
    ports = {p["gear"]: p for p in doc.pop("port")}
    if isinstance(doc["mesh"], list):  # [[mesh]] with one entry: the single-pair table
        (doc["mesh"],) = doc["mesh"]
    gears = [g["name"] for g in doc["gear"]]
    t_in = float(ports[doc["mesh"]["pinion"]].get("torque", 0.0))
    t_out = float(ports[doc["mesh"]["gear"]].get("torque", 0.0))
    doc["operating"]["input_torque"] = t_in
    doc["operating"]["load_torque"] = 0.0
    assert gears == [doc["mesh"]["pinion"], doc["mesh"]["gear"]]
    base = ref.scene_from_dict(doc)
    return PortScene(base, t_in, t_out, base.pinion_speed)


def f_ext(s: PortScene) -> float:
    """m_e S'' = F_ext − F: F_ext = m_e (r1 T_in/J1 − r2 T_out/J2)."""
    b = s.base
    return b.m_e * (b.r_b1 * s.t_in / b.inertia1 - b.r_b2 * s.t_out / b.inertia2)


def _pieces(s: PortScene):
    st = s.base.stiffness
    return st.pieces


def simulate(s: PortScene, stop_time: float, times, rtol=1e-12):
    b = s.base
    j1, j2, r1, r2 = b.inertia1, b.inertia2, b.r_b1, b.r_b2
    z1, two_b, c = b.z1, b.backlash, b.damping
    k_mean = b.stiffness.mean
    pieces = _pieces(s)
    shift = b.stiffness.phase
    law = b.contact

    def phase(phi, t):
        return b.p0 + z1 * (phi + s.omega * t) / TWO_PI

    def ste_and_rate(p, pdot):
        e = ref._fourier_sum(b.ste_cos, b.ste_sin, p)
        de = 0.0
        for h in range(1, max(len(b.ste_cos), len(b.ste_sin)) + 1):
            a = b.ste_cos[h - 1] if h <= len(b.ste_cos) else 0.0
            bb = b.ste_sin[h - 1] if h <= len(b.ste_sin) else 0.0
            w = TWO_PI * h
            de += w * (-a * math.sin(w * p) + bb * math.cos(w * p))
        return e, de * pdot

    # Initial state: static deflection under the port torques at the start phase, every body at
    # its nominal speed, the pinion at angle 0.
    p0 = phase(0.0, 0.0)
    e0, _ = ste_and_rate(p0, 0.0)
    y = np.array([f_ext(s) / k_mean + e0, 0.0, 0.0, 0.0])

    def locate(p):
        q = p + shift
        cyc = math.floor(q)
        frac = q - cyc
        for i, pc in enumerate(pieces):
            if pc.s_a <= frac < pc.s_b:
                return cyc, i
        return cyc, len(pieces) - 1

    cycle, piece = locate(p0)

    def classify(t, yy):
        p = phase(yy[2], t)
        e, edot = ste_and_rate(p, z1 * (s.omega + yy[3]) / TWO_PI)
        d = yy[0] - e
        if law == "linear":
            return 1
        if d > 0 or (d == 0 and yy[1] - edot > 0):
            return 1
        if law == "backlash" and (d + two_b < 0 or (d + two_b == 0 and yy[1] - edot < 0)):
            return -1
        return 0

    state = classify(0.0, y)
    times = np.asarray(times, float)
    out = np.full((len(times), 4), np.nan)
    t = 0.0
    nxt = 0
    events = 0
    while t < stop_time:
        pc = pieces[piece]

        def force(tt, yy):
            p = phase(yy[2], tt)
            pdot = z1 * (s.omega + yy[3]) / TWO_PI
            e, edot = ste_and_rate(p, pdot)
            if state == 0:
                return 0.0
            k = pc.value(p + shift - cycle)
            off = two_b if state == -1 else 0.0
            return k * (yy[0] - e + off) + c * (yy[1] - edot)

        def rhs(tt, yy):
            f = force(tt, yy)
            a1 = (s.t_in + s.rate_in * tt - r1 * f) / j1
            a2 = (s.t_out + s.rate_out * tt + r2 * f) / j2
            return [yy[1], r1 * a1 - r2 * a2, yy[3], a1]

        def g_end(tt, yy):
            return (cycle + pc.s_b - shift) - phase(yy[2], tt)

        def g_start(tt, yy):
            return phase(yy[2], tt) - (cycle + pc.s_a - shift)

        def g_drive(tt, yy):
            e, _ = ste_and_rate(phase(yy[2], tt), 0.0)
            return yy[0] - e

        def g_back(tt, yy):
            e, _ = ste_and_rate(phase(yy[2], tt), 0.0)
            return yy[0] - e + two_b

        guards = [g_end, g_start]
        if law != "linear":
            if state == 1:
                g_drive.direction = -1
                guards.append(g_drive)
            elif state == -1:
                g_back.direction = 1
                guards.append(g_back)
            else:
                g_drive.direction = 1
                guards.append(g_drive)
                if law == "backlash":
                    g_back.direction = -1
                    guards.append(g_back)
        g_end.direction = -1
        g_start.direction = -1
        for g in guards:
            g.terminal = True
        scale = np.array([1e-5, 1e-1, 1e-5, 1e-1])
        sol = solve_ivp(rhs, (t, stop_time), y, method="DOP853", rtol=rtol, atol=rtol * scale,
                        events=guards, dense_output=True)
        t_end = sol.t[-1]
        while nxt < len(times) and times[nxt] <= t_end:
            out[nxt] = sol.sol(times[nxt])
            nxt += 1
        y = sol.y[:, -1].copy()
        t = t_end
        if sol.status != 1:
            break
        events += 1
        hit = next(i for i, te in enumerate(sol.t_events) if len(te))
        g = guards[hit]
        if g is g_end or g is g_start:
            step = 1 if g is g_end else -1
            piece += step
            if piece == len(pieces):
                piece, cycle = 0, cycle + 1
            elif piece < 0:
                piece, cycle = len(pieces) - 1, cycle - 1
        else:
            # Snap onto the surface and switch the contact state.
            e, _ = ste_and_rate(phase(y[2], t), 0.0)
            if g is g_drive:
                y[0] = e
                state = 0 if state == 1 else 1
            else:
                y[0] = e - two_b
                state = 0 if state == -1 else -1
    theta1 = out[:, 2] + s.omega * times
    speed1 = out[:, 3] + s.omega
    theta2 = (r1 * theta1 - out[:, 0]) / r2
    speed2 = (r1 * speed1 - out[:, 1]) / r2
    return {
        "dte": out[:, 0],
        "dte_rate": out[:, 1],
        "pinion_angle": theta1,
        "pinion_speed": speed1,
        "gear_angle": theta2,
        "gear_speed": speed2,
        "events": events,
    }
