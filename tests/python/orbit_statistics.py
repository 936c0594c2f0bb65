"""Statistics of one period of a periodic orbit from the continuous solution of an independent
scipy reference, for `test_statistics_reference.py` (issue 31, acceptances 1 and 2).

The orbit is given, per mesh, as its smooth pieces `Piece(a, b, dte, force, lost)` covering
[t_a, t_a + period]: `dte(t)` and `force(t)` evaluate the piece's dense output (a scipy
`OdeSolution`), `lost` says whether the mesh is out of contact on the piece. Nothing here
knows a gear model: the references build the pieces from their own equations.

- contact-loss fraction: the lost pieces' total length (their ends are located events);
- separation phase: the mesh phase at the start of the first lost piece that follows a piece
  in contact (NaN if the mesh never separates);
- mean, RMS and the harmonics' amplitudes 2|c_h| by adaptive quadrature (`scipy.integrate.quad`,
  relative 1e-13) piece by piece;
- extremes by a fine scan of each piece (its ends included: one-sided limits at the jumps),
  the best points refined by a bounded scalar minimisation.
"""

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.integrate import quad
from scipy.optimize import minimize_scalar

LINES = 40  # mesh harmonics compared with `geardyn spectrum` (issue 31 acceptance 2)


@dataclass
class Piece:
    a: float
    b: float
    dte: Callable[[float], float]
    force: Callable[[float], float]
    lost: bool


def clip(pieces, t_a, t_b):
    """The pieces restricted to [t_a, t_b] (dense outputs are valid on their whole piece)."""
    out = []
    for p in pieces:
        a, b = max(p.a, t_a), min(p.b, t_b)
        if b > a:
            out.append(Piece(a, b, p.dte, p.force, p.lost))
    return out


def extreme(pieces, fun, sign):
    """max over the pieces of sign·fun(piece)(t)."""
    found = []
    for p in pieces:
        g = fun(p)
        ts = np.linspace(p.a, p.b, 65)
        vals = np.array([sign * g(t) for t in ts])
        i = int(np.argmax(vals))
        found.append((vals[i], p, g, ts, i))
    best = max(v for v, *_ in found)
    result = best
    for v, p, g, ts, i in found:
        if v < best - 0.05 * abs(best):
            continue
        lo, hi = ts[max(i - 1, 0)], ts[min(i + 1, len(ts) - 1)]
        r = minimize_scalar(lambda t: -sign * g(t), bounds=(lo, hi), method="bounded",
                            options={"xatol": 1e-15 * (p.b - p.a) + 1e-18})
        result = max(result, -r.fun)
    return sign * result


def _integral(pieces, fun, weight):
    return sum(quad(lambda t: fun(p)(t) * weight(t), p.a, p.b, epsabs=0, epsrel=1e-13,
                    limit=200)[0] for p in pieces)


def harmonic_amplitudes(pieces, fun, t_a, period, frequency, count):
    """2|c_h| of fun over the period for h = 1..count, at multiples of `frequency`."""
    amps = []
    for h in range(1, count + 1):
        w = 2 * math.pi * h * frequency
        re = _integral(pieces, fun, lambda t: math.cos(w * (t - t_a)))
        im = _integral(pieces, fun, lambda t: math.sin(w * (t - t_a)))
        amps.append(2 * math.hypot(re, im) / period)
    return amps


def statistics(pieces, t_a, period, mesh_frequency, phase_at, lost_before, lines=LINES):
    """One mesh's statistics over [t_a, t_a + period]; `phase_at(t)` is its mesh phase in
    cycles, `lost_before` whether it was out of contact just before t_a."""
    pieces = clip(pieces, t_a, t_a + period)

    def dte(p):
        return p.dte

    def force(p):
        return p.force

    def one(_t):
        return 1.0

    f_mean = _integral(pieces, force, one) / period
    f_var = sum(quad(lambda t: (p.force(t) - f_mean) ** 2, p.a, p.b, epsabs=0, epsrel=1e-13,
                     limit=200)[0] for p in pieces) / period
    d_mean = _integral(pieces, dte, one) / period
    d_var = sum(quad(lambda t: (p.dte(t) - d_mean) ** 2, p.a, p.b, epsabs=0, epsrel=1e-13,
                     limit=200)[0] for p in pieces) / period
    harmonics = harmonic_amplitudes(pieces, dte, t_a, period, mesh_frequency, 3)
    spectrum = {
        "dte": harmonic_amplitudes(pieces, dte, t_a, period, mesh_frequency, lines),
        "force": harmonic_amplitudes(pieces, force, t_a, period, mesh_frequency, lines),
    } if lines else {}
    separation = math.nan
    previous_lost = lost_before
    for p in pieces:
        if p.lost and not previous_lost:
            separation = phase_at(p.a) % 1.0
            break
        previous_lost = p.lost
    return {
        "contact_loss_fraction": sum(p.b - p.a for p in pieces if p.lost) / period,
        "separation_phase": separation,
        "peak_force": max(extreme(pieces, force, 1.0), -extreme(pieces, force, -1.0)),
        "force_rms": math.sqrt(f_var),
        "dte_mean": d_mean,
        "dte_rms": math.sqrt(d_var),
        "dte_peak_to_peak": extreme(pieces, dte, 1.0) - extreme(pieces, dte, -1.0),
        "a1": harmonics[0], "a2": harmonics[1], "a3": harmonics[2],
        "lines": spectrum,
    }
