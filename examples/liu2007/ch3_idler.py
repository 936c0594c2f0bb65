#!/usr/bin/env python3
"""Writes the geardyn scene of the two-mesh idler of Liu (2007), Ch. 3 (issue 16, item 4).

    python3 examples/liu2007/ch3_idler.py --eps 0.2 --gamma 0.04 --omega 1.0 > ch3.toml

Standard library only.  The dimensionless parameters of Ch. 3 are mapped onto the drivetrain
scene format of docs/train.md:

* Table 3.1: teeth 38/55/94, base radii 45.35/65.64/112.2 mm, inertias 2.62e-3, 3.27e-3 and
  0.119 kg m² (the printed 1.19e-2 is taken as a typo, notes §8 item 7), k̄_1 = 2.98e8 N/m and
  λ = k̄_2/k̄_1 = 1.08 (neither is in Table 3.1: Table 2.1's value and Ch. 4's ratio, which give
  c = ω_2/ω_1 = 2.762 against the table's 2.76), contact ratios ς_1 = ς_2 = 1.5, φ = 0, Γ = 0.04.
* Torsional only, rigid bearings (`bearings = "rigid"`), no ground couplings: the free train has
  one rigid-body mode and the two elastic modes of eq. (3.2).
* Mesh stiffness: lumped `rectangular` (docs/model.md: low on s ∈ [0, 1 − f), high on
  [1 − f, 1), s = 0 where the number of pairs drops, Liu's phase reference of §3.2).  Ch. 3's
  ε = 2|κ̃_1|/k̄_1 (first-harmonic cosine amplitude over the mean, eq. 3.12) is realised as the
  peak-to-peak ratio ε_pp = πε/(2|sin πς|) (= πε/2 for ς = 1.5), the same ratio on both meshes.
* Mesh phase: mesh 2 leads mesh 1 by φ rad, i.e. `phase = φ/2π` mesh cycles (docs/train.md);
  (3.13) prints the opposite sign convention, immaterial for ς_1 = ς_2 (notes §2.3 [R]).
* Damping: Ch. 3 has modal damping only, 2Γc_l q̇_l in eq. (3.11) on the mean-stiffness modes,
  no mesh damper: `modal_damping_ratio = Γ`, mesh `damping = 0`.  Ĉ is constant, so it also
  acts while a mesh is separated, as in (3.11).
* Contact law: `contact_loss` (H_j = [1 + sgn x_j]/2, no back side, §3.2.1).
* Load: T_1 on the pinion (default 100 N m as in Ch. 2), the load torque by the moment balance
  (geardyn's default); T = T_1/r_1 is the nominal mesh force of (3.2).  The dimensionless
  results do not depend on it (eq. 3.51): DTE_j = x̄_1 y_j with x̄_1 = T/k̄_1.
* Speed: the dimensionless mesh frequency ω = ω̃/ω_1 gives the pinion speed ω ω_1 / z_1 (rad/s).
"""

import argparse
import math

TEETH = (38, 55, 94)
BASE_RADIUS = (0.04535, 0.06564, 0.1122)
INERTIA = (2.62e-3, 3.27e-3, 0.119)
K1_MEAN = 2.98e8
LAMBDA = 1.08
CONTACT_RATIO = (1.5, 1.5)


def omega_1(inertia=INERTIA, base_radius=BASE_RADIUS, k1=K1_MEAN, lam=LAMBDA):
    """First natural frequency (rad/s) of the mean system, eq. (3.2): det(K − ω²M) = 0."""
    m = [i / r ** 2 for i, r in zip(inertia, base_radius)]
    s = sum(m)
    a, b, d = (m[1] + m[2]) * m[0] / s, m[0] * m[2] / s, (m[0] + m[1]) * m[2] / s
    k2 = lam * k1
    # (a d − b²) w² − (a k2 + d k1) w + k1 k2 = 0, w = ω².
    A, B, C = a * d - b * b, -(a * k2 + d * k1), k1 * k2
    w = (-B - math.sqrt(B * B - 4 * A * C)) / (2 * A)
    return math.sqrt(w)


def pp_ratio(eps, contact_ratio):
    """Peak-to-peak ratio of the rectangular wave whose first harmonic gives Ch. 3's ε."""
    return math.pi * eps / (2 * abs(math.sin(math.pi * contact_ratio)))


def pinion_speed(omega):
    """Pinion speed (rad/s) of the dimensionless mesh frequency ω = ω̃/ω_1."""
    return omega * omega_1() / TEETH[0]


def scene(eps=0.2, gamma=0.04, phi=0.0, torque=100.0, omega=1.0, periods=400, samples=32,
          contact_ratio=CONTACT_RATIO, name="liu_ch3_idler"):
    """TOML text of the Ch. 3 idler for Ch. 3's ε, modal damping Γ, mesh phase φ (rad),
    pinion torque (N m) and dimensionless mesh frequency ω; the run spans `periods` mesh
    periods with `samples` outputs per period."""
    speed = pinion_speed(omega)
    f_mesh = TEETH[0] * speed / (2 * math.pi)
    pp = [pp_ratio(eps, c) for c in contact_ratio]
    gears = "".join(
        f"""
[[gear]]
name = "{n}"
teeth = {z}
base_radius = {r!r}
inertia = {i!r}
""" for n, z, r, i in zip(("pinion", "idler", "gear"), TEETH, BASE_RADIUS, INERTIA))
    return f"""# Liu (2007) Ch. 3 two-mesh idler (Table 3.1), written by examples/liu2007/ch3_idler.py:
#   eps = {eps!r} (Ch. 3's 2|k~_1|/k_mean; peak-to-peak ratio {pp[0]!r}), Gamma = {gamma!r},
#   phi = {phi!r} rad, T_1 = {torque!r} N m, omega = {omega!r} (mesh frequency / omega_1,
#   omega_1 = {omega_1():.6f} rad/s = {omega_1() / (2 * math.pi):.4f} Hz).
# Mapping and the corrections to Table 3.1: see the docstring of ch3_idler.py and
# docs/validation/liu-ch3-perturbation.md.
name = "{name}"
description = "Liu (2007) Ch. 3 idler: 2 elastic DOF, rectangular mesh stiffness, contact loss, modal damping"

[model]
bearings = "rigid"
modal_damping_ratio = {gamma!r}
{gears}
[[mesh]]
name = "mesh1"
pinion = "pinion"
gear = "idler"
contact = "contact_loss"
model = "lumped"
damping = 0.0
initial_phase = 0.0

[mesh.stiffness]
kind = "rectangular"
mean = {K1_MEAN!r}
peak_to_peak_ratio = {pp[0]!r}
contact_ratio = {contact_ratio[0]!r}

[[mesh]]
name = "mesh2"
pinion = "idler"
gear = "gear"
contact = "contact_loss"
model = "lumped"
damping = 0.0
phase = {phi / (2 * math.pi)!r}

[mesh.stiffness]
kind = "rectangular"
mean = {LAMBDA * K1_MEAN!r}
peak_to_peak_ratio = {pp[1]!r}
contact_ratio = {contact_ratio[1]!r}

[operating]
input_speed = {speed!r}          # rad/s: mesh frequency {f_mesh:.4f} Hz
input_torque = {torque!r}

[initial]
dte = "static"

[solver]
method = "auto"
stop_time = {periods / f_mesh!r}
output_interval = {1.0 / (f_mesh * samples)!r}
"""


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--eps", type=float, default=0.2, help="Ch. 3's ε = 2|κ̃_1|/k̄_1 (default 0.2)")
    p.add_argument("--gamma", type=float, default=0.04, help="modal damping ratio Γ (Table 3.1: 0.04)")
    p.add_argument("--phi", type=float, default=0.0, help="mesh phase φ, rad (Table 3.1: 0)")
    p.add_argument("--torque", type=float, default=100.0, help="pinion torque T_1, N m")
    p.add_argument("--omega", type=float, default=1.0, help="mesh frequency / ω_1 (default 1: first resonance)")
    p.add_argument("--periods", type=int, default=400, help="mesh periods to simulate")
    p.add_argument("--out", help="write here instead of stdout")
    a = p.parse_args()
    text = scene(a.eps, a.gamma, a.phi, a.torque, a.omega, a.periods)
    if a.out:
        with open(a.out, "w") as f:
            f.write(text)
    else:
        print(text, end="")


if __name__ == "__main__":
    main()
