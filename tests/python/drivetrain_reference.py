#!/usr/bin/env python3
"""Independent scipy reference for the whole drivetrain of examples/systems/drivetrain
(issue 18 point 5): e-motor → input shaft → spur_stage → output shaft → vehicle load, as ONE
system of ordinary differential equations (monolithic, no co-simulation). Nothing here is
derived from the Rust model code.

The gear stage is the model of ``ports_reference.py`` (carried rotation, mesh phase from the
pinion angle, stiffness knots and contact changes as terminal events of ``solve_ivp``); the
elements are written from docs/elements.md:

    J_m ω_m' = T_e + T_r − τ_1 − d_m ω_m,      T_e = k_p (ω_ref − ω_m)   (P control, k_i = 0)
    T_r = Σ a_k cos(o_k θ_m + φ_k)
    τ_1 = k_1 (θ_m − θ_1) + c_1 (ω_m − ω_1)          (input shaft, on the pinion: +τ_1)
    τ_2 = k_2 (θ_2 − θ_L) + c_2 (ω_2 − ω_L)          (output shaft, on the wheel: −τ_2)
    J_L ω_L' = τ_2 − T_0 − c_v ω_L − c_d ω_L |ω_L|

and the gear stage's port torques are T_in = τ_1, T_out = −τ_2 (docs/ports.md).

State: [S, Ṡ, φ, ψ, μ, ν, λ, κ] with φ = θ_1 − Ω t, ψ = ω_1 − Ω (as in ports_reference),
μ = θ_m − Ω t, ν = ω_m − Ω, λ = θ_L − Ω_2 t, κ = ω_L − Ω_2, Ω_2 = Ω r_1/r_2: every angle is
carried relative to the reference rotation so the error control sees its deviation.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

import ports_reference as pr



@dataclass
class Elements:
    """The element values, as the system binds them (docs/elements.md symbols)."""
    j_m: float
    d_m: float
    kp: float
    omega_ref: float
    ripple: list  # (order, amplitude, phase)
    t_max: tuple  # (speeds, torques) of the full-load curve
    k1: float
    c1: float
    k2: float
    c2: float
    j_l: float
    t0: float
    c_v: float
    c_d: float
    theta_m0: float
    omega_m0: float
    theta_l0: float
    omega_l0: float


def simulate(s: pr.PortScene, el: Elements, stop_time: float, times, rtol=1e-12):
    """Returns the reference on ``times``: dte, pinion/gear/motor/load speeds, both shaft
    torques. The gear starts at its static deflection under its start port torques
    ``s.t_in``/``s.t_out`` (as the FMU does), the pinion at angle 0."""
    b = s.base
    j1, j2, r1, r2 = b.inertia1, b.inertia2, b.r_b1, b.r_b2
    om = s.omega
    om2 = om * r1 / r2
    y = np.array([0.0, 0.0, 0.0, 0.0,
                  el.theta_m0, el.omega_m0 - om, el.theta_l0, el.omega_l0 - om2])
    probe = pr.Stage(b, om, y)
    y[0] = pr.f_ext(s) / b.stiffness.mean + probe.ste_and_rate(probe.phase(0.0, 0.0), 0.0)[0]
    stage = pr.Stage(b, om, y)

    def kinematics(t, yy):
        th1, w1 = yy[2] + om * t, yy[3] + om
        th2, w2 = (r1 * th1 - yy[0]) / r2, (r1 * w1 - yy[1]) / r2
        thm, wm = yy[4] + om * t, yy[5] + om
        thl, wl = yy[6] + om2 * t, yy[7] + om2
        tau1 = el.k1 * (thm - th1) + el.c1 * (wm - w1)
        tau2 = el.k2 * (th2 - thl) + el.c2 * (w2 - wl)
        return th1, w1, th2, w2, thm, wm, thl, wl, tau1, tau2

    def t_max(w):
        return float(np.interp(w, *el.t_max))

    times = np.asarray(times, float)
    out = np.full((len(times), 8), np.nan)
    t = 0.0
    nxt = 0
    events = 0

    def rhs(tt, yy):
        _, _, _, _, thm, wm, _, wl, tau1, tau2 = kinematics(tt, yy)
        f = stage.force(tt, yy)
        a1 = (tau1 - r1 * f) / j1
        a2 = (-tau2 + r2 * f) / j2
        te = el.kp * (el.omega_ref - wm)
        tr = sum(a * math.cos(o * thm + ph) for o, a, ph in el.ripple)
        am = (te + tr - tau1 - el.d_m * wm) / el.j_m
        al = (tau2 - el.t0 - el.c_v * wl - el.c_d * wl * abs(wl)) / el.j_l
        return [yy[1], r1 * a1 - r2 * a2, yy[3], a1, yy[5], am, yy[7], al]

    scale = np.array([1e-5, 1e-1, 1e-5, 1e-1, 1e-5, 1e-1, 1e-5, 1e-1])
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
    cols = {k: [] for k in ("pinion.speed", "gear.speed", "motor.speed", "load.speed", "tau1", "tau2")}
    for tt, yy in zip(times, out):
        _, w1, _, w2, _, wm, _, wl, tau1, tau2 = kinematics(tt, yy)
        for k, v in zip(cols, (w1, w2, wm, wl, tau1, tau2)):
            cols[k].append(v)
    res = {k: np.array(v) for k, v in cols.items()}
    # The reference has no clamp: refuse a solution whose command leaves the full-load curve
    # (checked on the solution, not inside rhs, where the integrator's trial states of its
    # initial step selection can be far off).
    command = np.abs(el.kp * (el.omega_ref - res["motor.speed"]))
    over = np.nonzero(command > np.interp(res["motor.speed"], *el.t_max))[0]
    if len(over):
        raise ValueError(f"the motor command left the full-load curve at t = {times[over[0]]}: "
                         "this reference has no clamp")
    res["dte"] = out[:, 0]
    res["events"] = events
    return res


class SteadyPoint:
    """The steady start of the drivetrain at a pinion speed (rpm) with the load's constant
    torque ``t0`` (vehicle_load's ``torque``: rolling resistance plus any grade), computed
    from the shipped element scenes (fmu/emotor, shaft_in, shaft_out, vehicle_load) and the
    gear stage's static deflection (``ports_reference``), as the SSD's header describes it:
    every body at its nominal speed (the wheel and the load at z1/z2 of the pinion's), the
    load's resistance T_L = T_0 + c_v ω + c_d ω² carried by the output shaft, T_L·z1/z2 by
    the input shaft, each shaft pre-twisted by its torque, the pinion at angle 0 and the wheel
    at −S0/r_b2, and the motor's P controller (k_i = 0) with its reference raised by
    (T + d_m ω)/k_p so that it holds the speed."""

    def __init__(self, rpm: float, t0: float):
        import tomllib
        from pathlib import Path

        fmu = Path(__file__).resolve().parent.parent.parent / "fmu"

        def element(name):
            with open(fmu / name / "scene.toml", "rb") as fh:
                return tomllib.load(fh)["element"]

        motor, load = element("emotor"), element("vehicle_load")
        self.k1, self.k2 = element("shaft_in")["stiffness"], element("shaft_out")["stiffness"]
        s = pr.load(fmu / "spur_stage" / "scene.toml")
        b = s.base
        self.rpm, self.t0 = rpm, float(t0)
        self.omega = rpm * math.pi / 30
        self.omega2 = self.omega * b.r_b1 / b.r_b2
        self.t_wheel = t0 + load["viscous"] * self.omega2 + load["drag"] * self.omega2 ** 2
        self.t_pinion = self.t_wheel * b.r_b1 / b.r_b2
        self.motor_torque = self.t_pinion + motor["damping"] * self.omega
        self.omega_ref = self.omega + self.motor_torque / motor["controller"]["kp"]
        s.t_in, s.t_out, s.omega = self.t_pinion, -self.t_wheel, self.omega
        s0 = pr.f_ext(s) / b.stiffness.mean + pr.ref._fourier_sum(b.ste_cos, b.ste_sin, b.p0)
        self.theta_motor = self.t_pinion / self.k1
        self.theta_wheel = -s0 / b.r_b2
        self.theta_load = self.theta_wheel - self.t_wheel / self.k2
        self.t_mesh = 2 * math.pi / (b.z1 * self.omega)

    def bindings(self) -> dict:
        """The SSD's parameter bindings at this point, ``element.variable`` → value."""
        return {"motor.controller.ki": 0.0, "motor.controller.speed_reference": self.omega_ref,
                "motor.initial.speed": self.omega, "motor.initial.angle": self.theta_motor,
                "shaft1.flange_a.angle": self.theta_motor, "shaft1.flange_a.speed": self.omega,
                "shaft1.flange_b.angle": 0.0, "shaft1.flange_b.speed": self.omega,
                "gear.operating.input_speed": self.omega, "gear.input.torque": self.t_pinion,
                "gear.output.torque": -self.t_wheel,
                "shaft2.flange_a.angle": self.theta_wheel, "shaft2.flange_a.speed": self.omega2,
                "shaft2.flange_b.angle": self.theta_load, "shaft2.flange_b.speed": self.omega2,
                "load.initial.speed": self.omega2, "load.initial.angle": self.theta_load, "load.torque": self.t0}

    def monolithic_scene(self, text: str) -> str:
        """examples/drivetrain_monolithic.toml's text moved to this point: the operating speed
        and torques, the motor's speed reference and the load's constant torque."""
        import re

        subs = [(r"^pinion_speed = \S+", f"pinion_speed = {self.omega!r}"),
                (r"^input_torque = \S+", f"input_torque = {self.t_pinion!r}"),
                (r"^load_torque = \S+", f"load_torque = {self.t_wheel!r}"),
                (r"speed_reference = [0-9.e+-]+", f"speed_reference = {self.omega_ref!r}"),
                (r"(\[\[load\]\]\nname = \"load\"\ninertia = \S+\n)torque = \S+", rf"\g<1>torque = {self.t0!r}")]
        for pat, rep in subs:
            text, n = re.subn(pat, rep, text, count=1, flags=re.M)
            if n != 1:
                raise ValueError(f"monolithic scene: no line matches {pat!r}")
        return text
