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



class Stage:
    """The gear stage's hybrid parts for every reference that carries its rotation (this file's
    pair and ``drivetrain_reference``'s whole drivetrain). State ``y[0:4]``: the DTE, its rate,
    the pinion angle relative to ``omega·t`` and its rate. Holds the current stiffness piece
    (``cycle``, ``piece``) and contact state (1 drive, 0 open, −1 back side)."""

    def __init__(self, b: ref.Scene, omega: float, y0):
        self.b, self.omega = b, omega
        self.pieces = b.stiffness.pieces
        self.shift = b.stiffness.phase
        self.two_b = b.backlash
        self.law = b.contact
        self.cycle, self.piece = self.locate(self.phase(y0[2], 0.0))
        self.state = self.classify(0.0, y0)

    def phase(self, phi, t):
        return self.b.p0 + self.b.z1 * (phi + self.omega * t) / TWO_PI

    def phase_rate(self, yy):
        return self.b.z1 * (self.omega + yy[3]) / TWO_PI

    def ste_and_rate(self, p, pdot):
        b = self.b
        e = ref._fourier_sum(b.ste_cos, b.ste_sin, p)
        de = 0.0
        for h in range(1, max(len(b.ste_cos), len(b.ste_sin)) + 1):
            a = b.ste_cos[h - 1] if h <= len(b.ste_cos) else 0.0
            bb = b.ste_sin[h - 1] if h <= len(b.ste_sin) else 0.0
            w = TWO_PI * h
            de += w * (-a * math.sin(w * p) + bb * math.cos(w * p))
        return e, de * pdot

    def locate(self, p):
        q = p + self.shift
        cyc = math.floor(q)
        frac = q - cyc
        for i, pc in enumerate(self.pieces):
            if pc.s_a <= frac < pc.s_b:
                return cyc, i
        return cyc, len(self.pieces) - 1

    def classify(self, t, yy):
        e, edot = self.ste_and_rate(self.phase(yy[2], t), self.phase_rate(yy))
        d = yy[0] - e
        if self.law == "linear":
            return 1
        if d > 0 or (d == 0 and yy[1] - edot > 0):
            return 1
        if self.law == "backlash" and (d + self.two_b < 0 or (d + self.two_b == 0 and yy[1] - edot < 0)):
            return -1
        return 0

    def force(self, tt, yy):
        """Mesh force in the current piece and contact state."""
        if self.state == 0:
            return 0.0
        p = self.phase(yy[2], tt)
        e, edot = self.ste_and_rate(p, self.phase_rate(yy))
        k = self.pieces[self.piece].value(p + self.shift - self.cycle)
        off = self.two_b if self.state == -1 else 0.0
        return k * (yy[0] - e + off) + self.b.damping * (yy[1] - edot)

    def guards(self):
        """Terminal events of the current segment: the piece's two ends on the pinion angle,
        and the contact surfaces the current state can cross."""
        pc = self.pieces[self.piece]
        lo, hi = self.cycle + pc.s_a - self.shift, self.cycle + pc.s_b - self.shift

        def g_end(tt, yy):
            return hi - self.phase(yy[2], tt)

        def g_start(tt, yy):
            return self.phase(yy[2], tt) - lo

        def g_drive(tt, yy):
            return yy[0] - self.ste_and_rate(self.phase(yy[2], tt), 0.0)[0]

        def g_back(tt, yy):
            return g_drive(tt, yy) + self.two_b

        g_end.direction = g_start.direction = -1
        g_end.kind, g_start.kind, g_drive.kind, g_back.kind = 1, -1, "drive", "back"
        guards = [g_end, g_start]
        if self.law != "linear":
            if self.state == 1:
                g_drive.direction = -1
                guards.append(g_drive)
            elif self.state == -1:
                g_back.direction = 1
                guards.append(g_back)
            else:
                g_drive.direction = 1
                guards.append(g_drive)
                if self.law == "backlash":
                    g_back.direction = -1
                    guards.append(g_back)
        for g in guards:
            g.terminal = True
        return guards

    def on_event(self, g, t, y):
        """Crossing of guard ``g`` at ``t``: next piece, or contact switch with ``y`` snapped
        onto the surface."""
        if g.kind in (1, -1):
            self.piece += g.kind
            if self.piece == len(self.pieces):
                self.piece, self.cycle = 0, self.cycle + 1
            elif self.piece < 0:
                self.piece, self.cycle = len(self.pieces) - 1, self.cycle - 1
        else:
            e, _ = self.ste_and_rate(self.phase(y[2], t), 0.0)
            if g.kind == "drive":
                y[0] = e
                self.state = 0 if self.state == 1 else 1
            else:
                y[0] = e - self.two_b
                self.state = 0 if self.state == -1 else -1


def simulate(s: PortScene, stop_time: float, times, rtol=1e-12):
    b = s.base
    j1, j2, r1, r2 = b.inertia1, b.inertia2, b.r_b1, b.r_b2
    # Initial state: static deflection under the port torques at the start phase, every body at
    # its nominal speed, the pinion at angle 0.
    y = np.array([0.0, 0.0, 0.0, 0.0])
    probe = Stage(b, s.omega, y)
    y[0] = f_ext(s) / b.stiffness.mean + probe.ste_and_rate(probe.phase(0.0, 0.0), 0.0)[0]
    stage = Stage(b, s.omega, y)

    def rhs(tt, yy):
        f = stage.force(tt, yy)
        a1 = (s.t_in + s.rate_in * tt - r1 * f) / j1
        a2 = (s.t_out + s.rate_out * tt + r2 * f) / j2
        return [yy[1], r1 * a1 - r2 * a2, yy[3], a1]

    times = np.asarray(times, float)
    out = np.full((len(times), 4), np.nan)
    t = 0.0
    nxt = 0
    events = 0
    scale = np.array([1e-5, 1e-1, 1e-5, 1e-1])
    while t < stop_time:
        guards = stage.guards()
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
        stage.on_event(guards[hit], t, y)
    theta1 = out[:, 2] + s.omega * times
    speed1 = out[:, 3] + s.omega
    theta2 = (r1 * theta1 - out[:, 0]) / r2
    speed2 = (r1 * speed1 - out[:, 1]) / r2
    return {
        "dte": out[:, 0],
        "dte_rate": out[:, 1],
        "pinion.angle": theta1,
        "pinion.speed": speed1,
        "gear.angle": theta2,
        "gear.speed": speed2,
        "events": events,
    }
