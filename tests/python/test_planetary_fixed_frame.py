"""Fixed-frame spectra of a planetary stage (issue 33 item 2: `spectrum` with planet-pass and
mesh orders, docs/planetary.md "Fixed-frame spectra").

The stage of test_planetary_reference.py (3 planets, Z = 20/22/64, ring held, rectangular
stiffness with the Parker & Lin phasing) with linear contact, 5 % modal damping and a pin error
on planet 1 (so the sun's translation has a mean offset in the carrier frame, and the load is
not shared equally). `geardyn spectrum --signal sun.x_fixed --signal sun.y_fixed` gives the
lines a fixed sensor sees: the carrier-frame lines shifted by ±f_c.

Independent check: `geardyn simulate` of the same scene, run to its steady state, its
carrier-frame columns sun.x, sun.y rotated by numpy to the ground frame with the carrier's
nominal angle θ_c = Ω_c t (X = x cos θ_c − y sin θ_c, Y = x sin θ_c + y cos θ_c) over one
whole carrier revolution, and their exact DFT (numpy FFT of the record): the largest lines at
the same frequencies with the same amplitudes (to the transient left, bound 1e-4 of the largest
line), and each line's label names its frequency exactly (planet-pass and mesh orders, or
±1 carrier order).
"""

from __future__ import annotations

import csv
import math
import re
import subprocess

import numpy as np
import pytest

import test_planetary_reference as ref_model
from test_planetary_reference import SPEED, TEETH

OMEGA_C = SPEED * TEETH["s"] / (TEETH["s"] + TEETH["r"])
F_C = OMEGA_C / (2 * math.pi)
F_MESH = TEETH["s"] * (SPEED - OMEGA_C) / (2 * math.pi)
N = ref_model.N


def scene_text():
    t = ref_model.scene_text().replace('contact = "contact_loss"', 'contact = "linear"')
    t = t.replace('position_angle = 0.0\n', 'position_angle = 0.0\npin_error = [0.0, 5e-6]\n', 1)
    t = t.replace('bearings = "compliant"\n', 'bearings = "compliant"\nmodal_damping_ratio = 0.05\n', 1)
    assert "pin_error" in t and "modal_damping_ratio" in t
    return t


def spectrum_lines(path):
    rows = list(csv.DictReader(open(path)))
    f = np.array([float(r["frequency_Hz"]) for r in rows])
    cols = [k for k in rows[0] if k.endswith("_amplitude_m")]
    amp = {c.split("_amplitude")[0]: np.array([float(r[c]) for r in rows]) for c in cols}
    return f, amp, [r["order"] for r in rows]


def test_fixed_frame_lines_match_a_numpy_rotation(tmp_path, geardyn_bin):
    scene = tmp_path / "scene.toml"
    scene.write_text(scene_text())
    out = tmp_path / "spectrum.csv"
    subprocess.run([str(geardyn_bin), "spectrum", str(scene), "--out", str(out), "--signal",
                    "sun.x_fixed", "--signal", "sun.y_fixed", "--samples", "32"],
                   check=True, capture_output=True, text=True)
    f, amp, labels = spectrum_lines(out)
    resolution = f[1] - f[0]
    assert abs(F_C / resolution - round(F_C / resolution)) < 1e-9  # whole revolutions

    # The independent side: simulate to the steady state, rotate, DFT one revolution.
    rev = 1.0 / F_C
    # 64 mesh periods per revolution (f_mesh = Z_r f_c), 128 samples each: geardyn integrates
    # its lines alias-free, so the samples must resolve the lines beyond its 16 mesh orders.
    per_rev = 64 * 128
    assert abs(F_MESH / F_C - TEETH["r"]) < 1e-9
    settle = 12 * rev
    run = tmp_path / "run.csv"
    subprocess.run([str(geardyn_bin), "simulate", str(scene), "--out", str(run), "--stop-time",
                    repr(settle + rev), "--output-interval", repr(rev / per_rev), "--quiet"],
                   check=True, capture_output=True, text=True)
    data = np.genfromtxt(run, delimiter=",", names=True, deletechars="")
    t = data["time"]
    keep = t >= settle - 1e-12
    t, x, y = t[keep][:-1], data["sun.x"][keep][:-1], data["sun.y"][keep][:-1]
    assert len(t) == per_rev
    theta = OMEGA_C * t
    fixed = {"sun.x_fixed": x * np.cos(theta) - y * np.sin(theta),
             "sun.y_fixed": x * np.sin(theta) + y * np.cos(theta)}
    for name, signal in fixed.items():
        c = np.fft.rfft(signal) / len(signal)
        ours = 2 * np.abs(c)
        ours[0] /= 2
        ours_f = np.arange(len(ours)) * F_C
        top = amp[name].max()
        big = np.argsort(amp[name])[::-1][:8]
        for k in big:
            j = int(round(f[k] / F_C))
            print(f"{name}: {f[k]:10.4f} Hz {amp[name][k]:.4e} m ({labels[k]}); numpy "
                  f"{ours_f[j]:10.4f} Hz {ours[j]:.4e} m")
            assert abs(ours[j] - amp[name][k]) <= 1e-4 * top, (name, f[k])
        # Nothing large where geardyn has no line.
        lines = set(int(round(fk / F_C)) for fk in f[amp[name] > 1e-6 * top])
        stray = max(((ours[j], ours_f[j]) for j in range(len(ours))
                     if j not in lines and ours_f[j] < f[-1]), default=(0.0, 0.0))
        print(f"{name}: largest numpy line where geardyn has none: {stray[0]:.3e} m at "
              f"{stray[1]:.4f} Hz")
        assert stray[0] <= 1e-4 * top, stray

    # The labels name their lines exactly: k·f_mesh + m·N·f_c (planet-pass orders) or
    # k·f_mesh ± j·f_c.
    f_pp = N * F_C
    named = 0
    # The six largest lines lie within the labels' 10 mesh orders.
    for k in np.argsort(amp["sun.x_fixed"])[::-1][:6]:
        label = labels[k]
        terms = re.findall(r"([+-]?)(\d+)×(\w+)", label)
        assert terms, (f[k], label)
        value = 0.0
        for sign, order, what in terms:
            base = {"carrier_mesh": F_MESH, "carrier_planet_pass": f_pp, "carrier": F_C}[what]
            value += (-1 if sign == "-" else 1) * int(order) * base
        assert abs(value - f[k]) <= 1e-9 * f[k], (f[k], label)
        named += 1
    assert named == 6
