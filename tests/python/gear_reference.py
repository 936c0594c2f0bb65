#!/usr/bin/env python3
"""Independent Python reference (oracle) for the geardyn single-mesh gear pair.

Written only from the specification ``docs/model.md`` (section names below refer to it) and
the integration discipline of ``shared/reference/numerics-notes.md`` §2.1. Nothing here is
derived from the Rust model code.

Model (docs/model.md, "Coordinates and sign convention"):

    m_e x'' + F = F_ext,   m_e = 1 / (r_b1²/I1 + r_b2²/I2),
    F_ext = m_e (r_b1 T1/I1 + r_b2 T2/I2),

with the mesh force F of "Mesh force and contact law", the stiffness k(p) of "Mesh stiffness"
and the static transmission error e(p) of "Static transmission error", all functions of the
mesh phase p(t) = p0 + f_m t, f_m = z1 Ω / (2π) ("Mesh phase").

Integration discipline (numerics-notes §2.1, lessons 3 and 4):

* The time axis is cut at every known stiffness switch (rectangular jumps, trapezoid corners,
  table knots), computed from the mesh phase. Inside a segment the stiffness *piece* is
  frozen: k is evaluated from that piece's own linear formula, never through ``frac``, so an
  RK stage that touches the segment end cannot pick the next piece.
* The contact state is frozen between state events. Contact changes are terminal events of
  ``solve_ivp`` on δ = 0 and δ = −2b, each with a crossing direction fixed by the current
  state. After an event the state is snapped onto the switching surface (x set so that the
  guard evaluates to exactly 0) and the integration restarts.
* ``solve_ivp(method="DOP853", rtol=1e-12)`` with an absolute tolerance of rtol × (natural
  scale of each state), i.e. ~1e-17 m and ~1e-13 m/s for the project's scenes.

Readings of the specification where it leaves room (also listed in the report):

* ``contact = "linear"``: ``contact_state`` is reported as 1 throughout (the table has only
  the drive-side column for that law).
* A state exactly on a switching surface belongs to the state the motion is entering
  (the direction of the crossing decides); at t = 0 the table of "Mesh force and contact law"
  is applied literally (δ > 0 → 1, −2b ≤ δ ≤ 0 → 0, δ < −2b → −1), except that a start
  exactly on a surface moving into the neighbouring state starts in that state.
* Outputs at an instant of a switch (stiffness jump or contact event) are right-continuous:
  they use the stiffness of the spec's half-open intervals and the contact state after the
  event.
* ``ste.cos`` / ``ste.sin`` (and the Fourier stiffness ``cos``/``sin``) may have different
  lengths; missing harmonics are zero. A missing ``[mesh.ste]`` means e ≡ 0.
* Output grid of the CLI: t_k = k·H for k = 0 … floor(T/H), the last point snapped to T when
  it is within rounding of it (plus T itself if T is not a multiple of H).
"""
from __future__ import annotations

import argparse
import math
import re
import sys
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

TWO_PI = 2.0 * math.pi

#: Output columns of the CSV in order (docs/model.md, "Outputs"; `time` comes first), each with
#: the attribute of `ReferenceResult` that holds it.
OUTPUT_NAMES = {
    "mesh.dte": "dte",
    "mesh.dte_rate": "dte_rate",
    "mesh.force": "mesh_force",
    "mesh.contact_state": "contact_state",
    "mesh.phase": "mesh_phase",
    "mesh.stiffness": "mesh_stiffness",
    "mesh.static_deflection": "static_deflection",
}


class SceneError(ValueError):
    """A scene file that the specification does not allow."""


# ---------------------------------------------------------------------------------------------
# Scene parsing (docs/model.md, "Scene file")
# ---------------------------------------------------------------------------------------------

_NAME_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")

_ALLOWED_TOP = {"name", "description", "gear", "mesh", "operating", "initial", "solver"}
_ALLOWED_GEAR = {"name", "teeth", "base_radius", "inertia"}
_ALLOWED_MESH = {
    "pinion", "gear", "contact", "backlash", "damping_ratio", "damping", "initial_phase",
    "stiffness", "ste",
}
_ALLOWED_STIFFNESS = {
    "constant": {"kind", "value"},
    "rectangular": {"kind", "mean", "peak_to_peak_ratio", "contact_ratio", "phase"},
    "trapezoidal": {"kind", "mean", "peak_to_peak_ratio", "contact_ratio", "phase", "transition"},
    "fourier": {"kind", "mean", "cos", "sin", "phase"},
    "table": {"kind", "phase_points", "values", "phase"},
}
_ALLOWED_STE = {"cos", "sin"}
_ALLOWED_OPERATING = {"pinion_speed", "input_torque", "load_torque"}
_ALLOWED_INITIAL = {"dte", "dte_rate"}
_ALLOWED_SOLVER = {"method", "rk_method", "rtol", "atol", "stop_time", "output_interval"}


def _check_keys(table: dict, allowed: set, where: str) -> None:
    unknown = set(table) - allowed
    if unknown:
        raise SceneError(f"unknown key(s) {sorted(unknown)} in {where}")


def _number(table: dict, key: str, where: str, default=None, required=True) -> float:
    if key not in table:
        if default is not None or not required:
            return default
        raise SceneError(f"missing key '{key}' in {where}")
    value = table[key]
    # TOML integers are valid numbers too (e.g. `input_torque = 100`); booleans are not.
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise SceneError(f"'{key}' in {where} must be a number, got {value!r}")
    value = float(value)
    if not math.isfinite(value):
        raise SceneError(f"'{key}' in {where} must be finite")
    return value


def _number_list(table: dict, key: str, where: str) -> list[float]:
    value = table.get(key, [])
    if not isinstance(value, list):
        raise SceneError(f"'{key}' in {where} must be an array of numbers")
    return [_number({key: v}, key, where) for v in value]


@dataclass(frozen=True)
class Piece:
    """One piece of a periodic piecewise-linear stiffness, on s ∈ [s_a, s_b) of one period.

    k(s) = k_a + (k_b − k_a)(s − s_a)/(s_b − s_a). Jumps are represented by consecutive
    pieces whose end and start values differ (rectangular).
    """

    s_a: float
    s_b: float
    k_a: float
    k_b: float

    def value(self, s: float) -> float:
        if self.k_a == self.k_b:
            return self.k_a  # exact for flat pieces (rectangular / plateaus)
        return self.k_a + (self.k_b - self.k_a) * (s - self.s_a) / (self.s_b - self.s_a)


@dataclass
class Stiffness:
    """Mesh stiffness k(p) (docs/model.md, "Mesh stiffness k(p)").

    ``pieces`` is non-empty for the non-smooth shapes (rectangular, trapezoidal, table): the
    period [0, 1) of the shifted phase s is cut at every switch/corner/knot. For ``constant``
    and ``fourier`` it is empty (smooth in time: no stops needed).
    """

    kind: str
    phase: float
    mean: float
    pieces: list[Piece] = field(default_factory=list)
    cos: list[float] = field(default_factory=list)
    sin: list[float] = field(default_factory=list)

    def value_shifted(self, s: float) -> float:
        """k at the shifted phase s ∈ [0, 1) (already frac'ed), as the spec defines it."""
        if self.kind == "constant":
            return self.mean
        if self.kind == "fourier":
            return self.mean + _fourier_sum(self.cos, self.sin, s)
        for piece in self.pieces:  # half-open intervals: right-continuous at jumps
            if piece.s_a <= s < piece.s_b:
                return piece.value(s)
        return self.pieces[-1].value(s)  # s rounding to exactly 1.0

    def value(self, p: float) -> float:
        """k(p) with s = frac(p + phase) (output evaluation, not used inside segments)."""
        q = p + self.phase
        return self.value_shifted(q - math.floor(q))


def _fourier_sum(cos: list[float], sin: list[float], s: float) -> float:
    total = 0.0
    for h in range(1, max(len(cos), len(sin)) + 1):
        a = cos[h - 1] if h <= len(cos) else 0.0
        b = sin[h - 1] if h <= len(sin) else 0.0
        total += a * math.cos(TWO_PI * h * s) + b * math.sin(TWO_PI * h * s)
    return total


def _parse_stiffness(table: dict) -> Stiffness:
    where = "[mesh.stiffness]"
    if not isinstance(table, dict) or "kind" not in table:
        raise SceneError(f"{where} needs a 'kind'")
    kind = table["kind"]
    if kind not in _ALLOWED_STIFFNESS:
        raise SceneError(f"unknown stiffness kind {kind!r}")
    _check_keys(table, _ALLOWED_STIFFNESS[kind], where)
    phase = _number(table, "phase", where, default=0.0)

    if kind == "constant":
        value = _number(table, "value", where)
        stiff = Stiffness(kind, phase, value)
    elif kind in ("rectangular", "trapezoidal"):
        mean = _number(table, "mean", where)
        eps = _number(table, "peak_to_peak_ratio", where)
        c = _number(table, "contact_ratio", where)
        f = c - math.floor(c)
        k_low = mean * (1.0 - f * eps)
        k_high = k_low + eps * mean
        if kind == "rectangular":
            pieces = [Piece(0.0, 1.0 - f, k_low, k_low)]
            if f > 0.0:
                pieces.append(Piece(1.0 - f, 1.0, k_high, k_high))
        else:
            w = _number(table, "transition", where)
            if not (0.0 < w <= min(f, 1.0 - f)):
                raise SceneError(f"trapezoidal transition {w} must be in (0, min(f, 1-f)]")
            k_mid = 0.5 * (k_low + k_high)  # value at the centre of each ramp
            h = 0.5 * w
            # Corners of one period of s: ramp down centred on s = 0 (wrapping), ramp up
            # centred on s = 1 − f. Zero-length plateaus (w = f or w = 1 − f) are dropped.
            raw = [
                Piece(0.0, h, k_mid, k_low),
                Piece(h, 1.0 - f - h, k_low, k_low),
                Piece(1.0 - f - h, 1.0 - f + h, k_low, k_high),
                Piece(1.0 - f + h, 1.0 - h, k_high, k_high),
                Piece(1.0 - h, 1.0, k_high, k_mid),
            ]
            pieces = [pc for pc in raw if pc.s_b > pc.s_a]
        stiff = Stiffness(kind, phase, mean, pieces=pieces)
    elif kind == "fourier":
        mean = _number(table, "mean", where)
        stiff = Stiffness(kind, phase, mean, cos=_number_list(table, "cos", where),
                          sin=_number_list(table, "sin", where))
    else:  # table
        s_pts = _number_list(table, "phase_points", where)
        k_pts = _number_list(table, "values", where)
        n = len(s_pts)
        if n == 0 or n != len(k_pts):
            raise SceneError("table stiffness needs equally long, non-empty phase_points/values")
        if any(not (0.0 <= s < 1.0) for s in s_pts) or any(
            s_pts[i] >= s_pts[i + 1] for i in range(n - 1)
        ):
            raise SceneError("table phase_points must be strictly increasing in [0, 1)")
        # Knot list over one period including the wrap-around knot s_0 + 1.
        s_ext = s_pts + [s_pts[0] + 1.0]
        k_ext = k_pts + [k_pts[0]]
        # Value at s = 0 ≡ 1 on the wrap segment [s_{n−1}, s_0 + 1].
        span = s_ext[n] - s_ext[n - 1]
        k_wrap = k_ext[n - 1] + (k_ext[n] - k_ext[n - 1]) * (1.0 - s_ext[n - 1]) / span
        pieces = []
        if s_pts[0] > 0.0:
            pieces.append(Piece(0.0, s_pts[0], k_wrap, k_pts[0]))
        for i in range(n - 1):
            pieces.append(Piece(s_pts[i], s_pts[i + 1], k_pts[i], k_pts[i + 1]))
        pieces.append(Piece(s_pts[n - 1], 1.0, k_pts[n - 1], k_wrap))
        # Exact mean of the periodic piecewise-linear function (trapezoid rule is exact).
        mean = sum(0.5 * (k_ext[i] + k_ext[i + 1]) * (s_ext[i + 1] - s_ext[i]) for i in range(n))
        stiff = Stiffness(kind, phase, mean, pieces=pieces)

    # "The stiffness must be positive everywhere (checked at scene load)."
    if stiff.pieces:
        lowest = min(min(pc.k_a, pc.k_b) for pc in stiff.pieces)  # linear pieces: ends
    elif kind == "fourier":
        grid = np.linspace(0.0, 1.0, 20001)
        lowest = min(stiff.value_shifted(float(s)) for s in grid)
    else:
        lowest = stiff.mean
    if not lowest > 0.0:
        raise SceneError(f"mesh stiffness must be positive everywhere (min {lowest})")
    return stiff


@dataclass
class Scene:
    """The single-mesh model parameters derived from a scene (all SI units)."""

    name: str
    z1: int
    r_b1: float
    r_b2: float
    inertia1: float
    inertia2: float
    contact: str  # linear | contact_loss | backlash
    backlash: float  # total clearance 2b (0 unless backlash)
    damping: float  # c_m [N s/m]
    p0: float
    stiffness: Stiffness
    ste_cos: list[float]
    ste_sin: list[float]
    pinion_speed: float
    input_torque: float
    load_torque: float
    initial_dte: float
    initial_dte_rate: float
    stop_time: float | None
    output_interval: float | None
    solver: dict

    # Derived quantities (docs/model.md, "Coordinates and sign convention").
    @property
    def m_e(self) -> float:
        return 1.0 / (self.r_b1**2 / self.inertia1 + self.r_b2**2 / self.inertia2)

    @property
    def f_ext(self) -> float:
        return self.m_e * (
            self.r_b1 * self.input_torque / self.inertia1
            + self.r_b2 * self.load_torque / self.inertia2
        )

    @property
    def mesh_frequency(self) -> float:
        """f_m = z1 Ω / (2π) [Hz] (docs/model.md, "Mesh phase")."""
        return self.z1 * self.pinion_speed / TWO_PI

    @property
    def static_deflection(self) -> float:
        return self.f_ext / self.stiffness.mean

    def ste(self, p: float) -> float:
        """e(p) at the unshifted mesh phase (docs/model.md, "Static transmission error")."""
        return _fourier_sum(self.ste_cos, self.ste_sin, p)

    def ste_rate(self, p: float) -> float:
        """ė = f_m de/dp."""
        total = 0.0
        for h in range(1, max(len(self.ste_cos), len(self.ste_sin)) + 1):
            a = self.ste_cos[h - 1] if h <= len(self.ste_cos) else 0.0
            b = self.ste_sin[h - 1] if h <= len(self.ste_sin) else 0.0
            w = TWO_PI * h
            total += w * (-a * math.sin(w * p) + b * math.cos(w * p))
        return self.mesh_frequency * total

    def phase_at(self, t: float) -> float:
        return self.p0 + self.mesh_frequency * t


def load_scene(path: str | Path) -> Scene:
    with open(path, "rb") as fh:
        return scene_from_dict(tomllib.load(fh))


def scene_from_dict(doc: dict) -> Scene:
    """Validates a parsed scene (docs/model.md, "Scene file") and builds a :class:`Scene`."""
    _check_keys(doc, _ALLOWED_TOP, "the top level")
    name = doc.get("name")
    if not isinstance(name, str) or not _NAME_RE.match(name):
        raise SceneError(f"model name {name!r} must match [A-Za-z_][A-Za-z0-9_]*")

    gears = doc.get("gear")
    if not isinstance(gears, list) or len(gears) != 2:
        raise SceneError("a single-mesh scene needs exactly two [[gear]] tables")
    by_name = {}
    for g in gears:
        _check_keys(g, _ALLOWED_GEAR, "[[gear]]")
        gname = g.get("name")
        if not isinstance(gname, str) or gname in by_name:
            raise SceneError(f"gear names must be distinct strings, got {gname!r}")
        teeth = g.get("teeth")
        if isinstance(teeth, bool) or not isinstance(teeth, int) or teeth <= 0:
            raise SceneError(f"gear '{gname}': teeth must be a positive integer")
        r_b = _number(g, "base_radius", f"gear '{gname}'")
        inertia = _number(g, "inertia", f"gear '{gname}'")
        if r_b <= 0 or inertia <= 0:
            raise SceneError(f"gear '{gname}': base_radius and inertia must be positive")
        by_name[gname] = (teeth, r_b, inertia)

    mesh = doc.get("mesh")
    if not isinstance(mesh, dict):
        raise SceneError("missing [mesh]")
    _check_keys(mesh, _ALLOWED_MESH, "[mesh]")
    if mesh.get("pinion") not in by_name or mesh.get("gear") not in by_name or \
            mesh["pinion"] == mesh["gear"]:
        raise SceneError("[mesh] pinion/gear must name the two distinct gears")
    z1, r_b1, i1 = by_name[mesh["pinion"]]
    _z2, r_b2, i2 = by_name[mesh["gear"]]

    contact = mesh.get("contact")
    if contact not in ("linear", "contact_loss", "backlash"):
        raise SceneError(f"unknown contact law {contact!r}")
    if contact == "backlash":
        backlash = _number(mesh, "backlash", "[mesh]")
        if backlash < 0:
            raise SceneError("backlash must be >= 0")
    else:
        if "backlash" in mesh:
            raise SceneError("'backlash' is only allowed with contact = \"backlash\"")
        backlash = 0.0

    stiffness = _parse_stiffness(mesh.get("stiffness"))

    ste = mesh.get("ste", {})
    _check_keys(ste, _ALLOWED_STE, "[mesh.ste]")
    ste_cos = _number_list(ste, "cos", "[mesh.ste]")
    ste_sin = _number_list(ste, "sin", "[mesh.ste]")

    op = doc.get("operating")
    if not isinstance(op, dict):
        raise SceneError("missing [operating]")
    _check_keys(op, _ALLOWED_OPERATING, "[operating]")
    omega = _number(op, "pinion_speed", "[operating]")
    if omega < 0:
        raise SceneError("pinion_speed must be >= 0")
    t1 = _number(op, "input_torque", "[operating]")
    t2 = _number(op, "load_torque", "[operating]", required=False)
    if t2 is None:
        t2 = t1 * r_b2 / r_b1  # balanced load (spec default)

    p0 = _number(mesh, "initial_phase", "[mesh]", default=0.0)

    m_e = 1.0 / (r_b1**2 / i1 + r_b2**2 / i2)
    if ("damping" in mesh) == ("damping_ratio" in mesh):
        raise SceneError("[mesh] needs exactly one of 'damping' and 'damping_ratio'")
    if "damping" in mesh:
        c_m = _number(mesh, "damping", "[mesh]")
    else:
        c_m = 2.0 * _number(mesh, "damping_ratio", "[mesh]") * math.sqrt(stiffness.mean * m_e)
    if c_m < 0:
        raise SceneError("damping must be >= 0")

    solver = doc.get("solver", {})
    _check_keys(solver, _ALLOWED_SOLVER, "[solver]")

    scene = Scene(
        name=name, z1=z1, r_b1=r_b1, r_b2=r_b2, inertia1=i1, inertia2=i2, contact=contact,
        backlash=backlash, damping=c_m, p0=p0, stiffness=stiffness, ste_cos=ste_cos,
        ste_sin=ste_sin, pinion_speed=omega, input_torque=t1, load_torque=t2,
        initial_dte=0.0, initial_dte_rate=0.0,
        stop_time=_number(solver, "stop_time", "[solver]", required=False),
        output_interval=_number(solver, "output_interval", "[solver]", required=False),
        solver=solver,
    )

    initial = doc.get("initial", {})
    _check_keys(initial, _ALLOWED_INITIAL, "[initial]")
    dte0 = initial.get("dte", "static")
    if dte0 == "static":
        scene.initial_dte = scene.static_deflection + scene.ste(p0)
    else:
        scene.initial_dte = _number(initial, "dte", "[initial]")
    scene.initial_dte_rate = _number(initial, "dte_rate", "[initial]", default=0.0)
    return scene


# ---------------------------------------------------------------------------------------------
# Segments with frozen stiffness pieces
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Segment:
    """A time interval on which one stiffness piece holds.

    k(t) = piece.value(q(t) − n) with the shifted phase q(t) = p0 + phase + f_m t and the
    integer period index n fixed for the segment (no frac inside a segment).
    """

    t_start: float
    t_end: float
    piece: Piece | None  # None: smooth shape, evaluate the spec formula directly
    period_index: int


def stiffness_switch_times(scene: Scene, t_end: float) -> list[float]:
    """Known stiffness switch times in (0, t_end), sorted (rectangular jumps, trapezoid
    corners, table knots), from q(t) = n + s_i, i.e. t = (n + s_i − p0 − phase)/f_m."""
    stiff = scene.stiffness
    f_m = scene.mesh_frequency
    if not stiff.pieces or f_m == 0.0:
        return []
    q0 = scene.p0 + stiff.phase
    q1 = q0 + f_m * t_end
    times = set()
    for n in range(math.floor(q0) - 1, math.ceil(q1) + 2):
        for piece in stiff.pieces:
            t = (n + piece.s_a - q0) / f_m
            if 0.0 < t < t_end:
                times.add(t)
    return sorted(times)


def build_segments(scene: Scene, t_end: float) -> list[Segment]:
    bounds = [0.0] + stiffness_switch_times(scene, t_end) + [t_end]
    stiff = scene.stiffness
    segments = []
    for a, b in zip(bounds[:-1], bounds[1:]):
        if not stiff.pieces:
            segments.append(Segment(a, b, None, 0))
            continue
        # The piece is identified at the segment midpoint, away from any rounding at the ends.
        q_mid = scene.p0 + stiff.phase + scene.mesh_frequency * 0.5 * (a + b)
        n = math.floor(q_mid)
        s_mid = q_mid - n
        piece = next((pc for pc in stiff.pieces if pc.s_a <= s_mid < pc.s_b), stiff.pieces[-1])
        segments.append(Segment(a, b, piece, n))
    return segments


def frozen_stiffness(scene: Scene, seg: Segment, t: float) -> float:
    """k(t) on segment ``seg`` with the piece frozen (valid slightly outside the segment)."""
    stiff = scene.stiffness
    if seg.piece is None:
        q = scene.p0 + stiff.phase + scene.mesh_frequency * t
        if stiff.kind == "constant":
            return stiff.mean
        return stiff.mean + _fourier_sum(stiff.cos, stiff.sin, q)  # periodic: no frac needed
    if seg.piece.k_a == seg.piece.k_b:
        return seg.piece.k_a
    q = scene.p0 + stiff.phase + scene.mesh_frequency * t
    return seg.piece.value(q - seg.period_index)


# ---------------------------------------------------------------------------------------------
# Contact law and the integration loop
# ---------------------------------------------------------------------------------------------


def mesh_force(scene: Scene, state: int, k: float, x: float, v: float, p: float) -> float:
    """F of docs/model.md "Mesh force and contact law" for a *given* contact state."""
    delta = x - scene.ste(p)
    delta_rate = v - scene.ste_rate(p)
    if state == 0:
        return 0.0
    if state == 1:
        return k * delta + scene.damping * delta_rate
    return k * (delta + scene.backlash) + scene.damping * delta_rate  # back side, k(δ + 2b)


def classify_contact(scene: Scene, t: float, x: float, v: float) -> int:
    """Contact state at t = 0 from the table; on a surface, the direction of motion decides."""
    if scene.contact == "linear":
        return 1
    p = scene.phase_at(t)
    delta = x - scene.ste(p)
    delta_rate = v - scene.ste_rate(p)
    if delta > 0.0 or (delta == 0.0 and delta_rate > 0.0):
        return 1
    if scene.contact == "contact_loss":
        return 0
    gap = x - (scene.ste(p) - scene.backlash)  # δ + 2b, evaluated as the guard does
    if gap < 0.0 or (gap == 0.0 and delta_rate < 0.0):
        return -1
    return 0


@dataclass
class ReferenceResult:
    """Outputs on the requested grid (docs/model.md, "Outputs") plus diagnostics."""

    time: np.ndarray
    dte: np.ndarray
    dte_rate: np.ndarray
    mesh_force: np.ndarray
    contact_state: np.ndarray
    mesh_phase: np.ndarray
    mesh_stiffness: np.ndarray
    static_deflection: np.ndarray
    events: list[tuple[float, int]]  # (time, new contact state)
    stops: list[float]  # restart times at known stiffness switches
    nfev: int
    steps: int = 0  # accepted steps of all solve_ivp calls

    def columns(self) -> dict[str, np.ndarray]:
        return {"time": self.time, **{n: getattr(self, a) for n, a in OUTPUT_NAMES.items()}}


def default_atol(scene: Scene, rtol: float) -> np.ndarray:
    """Absolute tolerance = rtol × natural scale of (x, x'), so that the relative criterion
    governs even where x or x' passes through zero ("atol tiny")."""
    ste_amp = sum(abs(c) for c in scene.ste_cos) + sum(abs(s) for s in scene.ste_sin)
    x_scale = max(abs(scene.static_deflection), scene.backlash, ste_amp,
                  abs(scene.initial_dte), 1e-9)
    omega_n = math.sqrt(scene.stiffness.mean / scene.m_e)
    v_scale = max(x_scale * omega_n, abs(scene.initial_dte_rate))
    return rtol * np.array([x_scale, v_scale])


def simulate(scene: Scene, stop_time: float, output_times=None, output_interval=None,
             rtol: float = 1e-12, atol=None, max_events: int = 200000,
             method: str = "DOP853", check_grazing: bool = True,
             pieces: list | None = None) -> ReferenceResult:
    """Integrates the single-mesh model on [0, stop_time] and samples the outputs.

    ``output_times`` (sorted, within [0, stop_time]) overrides the grid built from
    ``output_interval`` (t_k = k·H). ``method`` is any ``solve_ivp`` method (the work-precision
    benchmark also runs RK45 and Radau); ``check_grazing=False`` skips the dense-output scan
    for guards that leave and re-enter within one step (the benchmark's "careful user" setup
    has segment stops and terminal events only). With a list ``pieces``, every smooth piece
    is appended to it as ``(t_start, t_end, dense solution, contact state, stiffness
    segment)``, for statistics from the continuous solution (`test_statistics_reference.py`).
    """
    if output_times is None:
        if not output_interval or output_interval <= 0:
            raise ValueError("need output_times or a positive output_interval")
        n = math.floor(stop_time / output_interval * (1.0 + 1e-12))
        output_times = [k * output_interval for k in range(n + 1)]
        if abs(stop_time - output_times[-1]) <= 1e-9 * output_interval:
            output_times[-1] = stop_time  # k·H rounding past (or short of) the stop time
        elif output_times[-1] < stop_time:
            output_times.append(stop_time)
    out_t = np.asarray(output_times, dtype=float)
    if atol is None:
        atol = default_atol(scene, rtol)

    f_ext = scene.f_ext
    m_e = scene.m_e
    two_b = scene.backlash
    contact_law = scene.contact

    segments = build_segments(scene, stop_time)
    x_out = np.full(out_t.shape, np.nan)
    v_out = np.full(out_t.shape, np.nan)
    state_out = np.zeros(out_t.shape, dtype=int)

    y = np.array([scene.initial_dte, scene.initial_dte_rate], dtype=float)
    state = classify_contact(scene, 0.0, y[0], y[1])
    events: list[tuple[float, int]] = []
    stops: list[float] = []
    nfev = 0
    steps = 0
    next_out = 0  # index of the first output time not yet filled

    def guard_drive(t, yy):  # δ = x − e(p); zero on the drive-side surface
        return yy[0] - scene.ste(scene.phase_at(t))

    def guard_back(t, yy):  # x − (e(p) − 2b) = δ + 2b; zero on the back-side surface
        return yy[0] - (scene.ste(scene.phase_at(t)) - two_b)

    for seg in segments:
        t = seg.t_start
        while True:
            # Guards active in the current (frozen) contact state, each with the crossing
            # direction that leaves the state, and the state entered on that crossing.
            guards = []
            if contact_law != "linear":
                if state == 1:
                    guards = [(guard_drive, -1.0, 0)]
                elif state == 0:
                    guards = [(guard_drive, 1.0, 1)]
                    if contact_law == "backlash":
                        guards.append((guard_back, -1.0, -1))
                else:
                    guards = [(guard_back, 1.0, 0)]
            event_fns = []
            for fn, direction, _ in guards:
                # After a snap the guard of the surface just crossed is exactly 0 at t0. scipy
                # would then report a root *at t0* whenever the first step ends on the far
                # side again (e.g. a whole free flight in one step), because brentq returns a
                # bracket end with f = 0. So at t0 an exact zero is replaced by a tiny value on
                # the inside of the current state (−direction side): the bracket then holds
                # the genuine interior root.
                def ev(tt, yy, fn=fn, t0=t, inside=-direction):
                    value = fn(tt, yy)
                    if tt == t0 and value == 0.0:
                        return inside * 1e-300
                    return value
                ev.terminal = True
                ev.direction = direction
                event_fns.append(ev)

            frozen_state = state

            def rhs(tt, yy, seg=seg, frozen_state=frozen_state):
                p = scene.phase_at(tt)
                if contact_law == "linear":
                    s = 1
                else:
                    s = frozen_state
                k = frozen_stiffness(scene, seg, tt) if s != 0 else 0.0
                force = mesh_force(scene, s, k, yy[0], yy[1], p) if s != 0 else 0.0
                return [yy[1], (f_ext - force) / m_e]

            max_step = np.inf
            for _attempt in range(8):
                sol = solve_ivp(rhs, (t, seg.t_end), y, method=method, rtol=rtol, atol=atol,
                                dense_output=True, events=event_fns or None,
                                max_step=max_step)
                if sol.status < 0:
                    raise RuntimeError(f"solve_ivp failed at t={t}: {sol.message}")
                nfev += sol.nfev
                steps += len(sol.t) - 1
                # Sign changes are only seen at step ends: a guard that leaves and re-enters
                # within one step (an even number of crossings) would be missed. Sample the
                # dense output inside every step; if a guard is found outside, redo the
                # sub-integration with shorter steps.
                bad_step = _missed_crossing(sol, guards, float(atol[0])) if check_grazing else None
                if bad_step is None:
                    break
                max_step = bad_step / 8.0
            else:
                raise RuntimeError(f"missed contact crossing persists near t={t}")

            hit = None
            if sol.status == 1:  # a terminal event ended the integration
                for i, (fn, _direction, new_state) in enumerate(guards):
                    if len(sol.t_events[i]):
                        t_ev = float(sol.t_events[i][0])
                        if hit is None or t_ev < hit[0]:
                            hit = (t_ev, i, new_state)
            t_stop = hit[0] if hit else seg.t_end
            if pieces is not None and t_stop > t:
                pieces.append((t, t_stop, sol.sol, 1 if contact_law == "linear" else state,
                                 seg))

            # Fill the output times in [t, t_stop) (and t_stop itself at the very end).
            last = seg is segments[-1] and hit is None
            while next_out < len(out_t) and (
                out_t[next_out] < t_stop or (last and out_t[next_out] <= t_stop)
            ):
                tq = out_t[next_out]
                yq = sol.sol(tq) if tq != t else y
                x_out[next_out], v_out[next_out] = yq[0], yq[1]
                state_out[next_out] = 1 if contact_law == "linear" else state
                next_out += 1

            if hit is None:
                y = sol.y[:, -1].copy()
                break
            t_ev, idx, new_state = hit
            y = sol.sol(t_ev).copy()
            # Snap onto the switching surface with the same expression the guard evaluates,
            # so the restarted guard starts at exactly 0 (numerics-notes §2.1 lesson 4).
            e_ev = scene.ste(scene.phase_at(t_ev))
            y[0] = e_ev if guards[idx][0] is guard_drive else e_ev - two_b
            state = new_state
            events.append((t_ev, new_state))
            if len(events) > max_events:
                raise RuntimeError(f"more than {max_events} contact events (Zeno/chatter?)")
            t = t_ev
            if t >= seg.t_end:
                # Event exactly at the segment end: nothing left to integrate here; an output
                # at the final time takes the snapped post-event state.
                if seg is segments[-1]:
                    while next_out < len(out_t) and out_t[next_out] <= t:
                        x_out[next_out], v_out[next_out] = y[0], y[1]
                        state_out[next_out] = state
                        next_out += 1
                break
        if seg is not segments[-1]:
            stops.append(seg.t_end)

    if next_out < len(out_t):
        raise RuntimeError("output times outside [0, stop_time]")

    phase = np.array([scene.phase_at(tq) for tq in out_t])
    k_out = np.array([scene.stiffness.value(p) for p in phase])
    force_out = np.array([
        mesh_force(scene, int(s), k, x, v, p)
        for s, k, x, v, p in zip(state_out, k_out, x_out, v_out, phase)
    ])
    return ReferenceResult(
        time=out_t, dte=x_out, dte_rate=v_out, mesh_force=force_out,
        contact_state=state_out.astype(float), mesh_phase=phase - np.floor(phase),
        mesh_stiffness=k_out, static_deflection=np.full(out_t.shape, scene.static_deflection),
        events=events, stops=stops, nfev=nfev, steps=steps,
    )


def _missed_crossing(sol, guards, tolerance: float):
    """Length of the first step whose interior (sampled on the dense output) lies outside the
    current contact state by more than ``tolerance``, or None."""
    if not guards:
        return None
    t_end = sol.t[-1]
    for t_a, t_b in zip(sol.t[:-1], sol.t[1:]):
        if t_b <= t_a:
            continue
        samples = t_a + (t_b - t_a) * np.linspace(0.0, 1.0, 10)[1:-1]
        samples = samples[samples < t_end]
        for ts in samples:
            ys = sol.sol(ts)
            for fn, direction, _ in guards:
                if direction * fn(ts, ys) > tolerance:
                    return t_b - t_a
    return None


def write_csv(result: ReferenceResult, path: str | Path) -> None:
    """CSV with the columns of `geardyn simulate`: time, then the outputs by name, %.17g."""
    cols = result.columns()
    names = list(cols)
    with open(path, "w") as fh:
        fh.write(",".join(names) + "\n")
        for i in range(len(result.time)):
            fh.write(",".join("%.17g" % cols[n][i] for n in names) + "\n")


def read_csv(path: str | Path) -> dict[str, np.ndarray]:
    with open(path) as fh:
        header = fh.readline().strip().split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return {name: data[:, i] for i, name in enumerate(header)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene")
    ap.add_argument("--stop-time", type=float)
    ap.add_argument("--output-interval", type=float)
    ap.add_argument("--rtol", type=float, default=1e-12)
    ap.add_argument("--out", required=True)
    args = ap.parse_args(argv)
    scene = load_scene(args.scene)
    stop = args.stop_time if args.stop_time is not None else scene.stop_time
    interval = args.output_interval if args.output_interval is not None else scene.output_interval
    if stop is None or interval is None:
        ap.error("stop time / output interval neither given nor in [solver]")
    result = simulate(scene, stop, output_interval=interval, rtol=args.rtol)
    write_csv(result, args.out)
    n_loss = sum(1 for _, s in result.events if s == 0)
    n_back = sum(1 for _, s in result.events if s == -1)
    periods = stop * scene.mesh_frequency
    print(f"{scene.name}: {len(result.time)} samples, {periods:.1f} mesh periods, "
          f"{len(result.events)} contact events ({n_loss} to separated, {n_back} back-side "
          f"impacts), {len(result.stops)} stiffness stops, nfev {result.nfev}, "
          f"static deflection {scene.static_deflection:.6g} m")
    return 0


if __name__ == "__main__":
    sys.exit(main())
