"""Issue 36, acceptance 4: the per-tooth-pair stiffness of Liu's (2007) Ch. 2 gears from the
gear geometry (`[mesh.pairs] kind = "geometry"`, `src/mesh/geometry/pairs.rs`) against an
independent evaluation of the potential-energy integrals, to 1e-6 relative.

The independent side is written here from the papers' equations, not from geardyn's code:
- the tooth beam (Yang & Lin 1987; Tian 2004; Liao et al. 2025 eqs. (1)–(2)) as the
  Cartesian potential energies `∫ M²/(E I) dy`, `∫ 1.2 F_b²/(G A) dy`, `∫ F_a²/(E A) dy` over a
  tooth described by the *polar* involute (half angle `ψ(r) = θ_b − inv(acos(r_b/r))`), in
  the radius r from the root circle to the load point, by `scipy.integrate.quad` at
  `epsrel = 1e-13` (geardyn uses Gauss–Legendre on the string-tangent angle of eq. (2));
- the fillet foundation by Sainsot et al. (2004) with the notes' `u_f` (not geardyn's
  simplified `r_b/cos α_F − r_f`) and the Table 1 coefficients of
  `shared/reference/models-liao-2025-etc.md` §1.4;
- the Hertz term of eq. (3) at the transmitted force `W = T/r_b1`;
- the pair geometry (operating pressure angle, path of contact, contact ratio) from textbook
  involute relations.

The gears are the ones of `examples/liu2007/ch2_idler_geometry.toml`, read from the scene, so
the test also checks that their tip radii give the printed contact ratios 1.504 / 1.510 and
the printed operating pressure angles 21.22° / 21.02° (Table 2.1, notes §1.10).
"""

import csv
import math
import tomllib

import pytest
from scipy.integrate import quad
from scipy.optimize import brentq

from conftest import run_geardyn

TOL = 1e-6
SAINSOT = {  # Sainsot et al. 2004, Table 1 (notes §1.4): A, B, C, D, E, F
    "L": (-5.574e-5, -1.9986e-3, -2.3015e-4, 4.7702e-3, 0.0271, 6.8045),
    "M": (60.111e-5, 28.100e-3, -83.431e-4, -9.9256e-3, 0.1624, 0.9086),
    "P": (-50.952e-5, 185.50e-3, 0.0538e-4, 53.300e-3, 0.2895, 0.9236),
    "Q": (-6.2042e-5, 9.0889e-3, -4.0964e-4, 7.8297e-3, -0.1472, 0.6904),
}
STEEL = (206e9, 0.3)  # the `steel` preset: ISO 6336-2 (docs/stiffness.md, "Material")


def inv(a):
    return math.tan(a) - a


class Gear:
    def __init__(self, spec, module, alpha, width):
        self.z = spec["teeth"]
        self.x = spec.get("profile_shift", 0.0)
        ha = spec.get("addendum", 1.0)
        hf = spec.get("dedendum", 1.25)
        rho = spec.get("cutter_tip_radius", 0.25 / (1 - math.sin(alpha)))
        self.e, self.nu = STEEL
        self.width = width
        self.r = module * self.z / 2
        self.rb = self.r * math.cos(alpha)
        self.ra = self.r + module * (ha + self.x)
        self.rf = self.r - module * (hf - self.x)
        self.r_bore = spec["bore_radius"]
        # Half tooth angle at the base circle (tooth thickness s = m(π/2 + 2x tan α)).
        self.theta_b = math.pi / (2 * self.z) + inv(alpha) + 2 * self.x * math.tan(alpha) / self.z
        # Fillet/root junction: the end of the rack's tip land (width m(π/2 − 2(h_f − ρ)tan α
        # − 2ρ/cos α)), which rolls on the pitch circle; half tooth angle there.
        land = module * (math.pi / 4 - (hf - rho) * math.tan(alpha) - rho / math.cos(alpha))
        self.theta_f = math.pi / self.z - land / self.r

    def psi(self, r):
        """Half angular tooth thickness at radius r (polar involute)."""
        return self.theta_b - inv(math.acos(self.rb / r))

    def beam(self, roll):
        """Axial + bending + shear compliance of the tooth for a unit load at roll length
        `roll` (contact on the line of action), m/N."""
        rc = math.hypot(self.rb, roll)
        alpha_f = roll / self.rb - self.theta_b  # load angle: tan α_c − θ_b
        sa, ca = math.sin(alpha_f), math.cos(alpha_f)
        yc = rc * math.cos(self.psi(rc))
        xc = rc * math.sin(self.psi(rc))
        el = self.e * self.width
        g_over_e = 1 / (2 * (1 + self.nu))
        assert self.rf > self.rb  # the involute reaches down to the root circle (Liu's gears)

        def dy(r):  # d(r cos ψ)/dr
            p = self.psi(r)
            dpsi = -math.sqrt(r * r - self.rb**2) / (r * self.rb)  # −d inv(acos(r_b/r))/dr
            return math.cos(p) - r * math.sin(p) * dpsi

        def terms(r):
            p = self.psi(r)
            y, h = r * math.cos(p), r * math.sin(p)
            area, inertia = 2 * h, (2 * h) ** 3 / 12
            m = ca * (yc - y) - xc * sa
            w = dy(r)
            return (sa * sa / area * w, m * m / inertia * w, 1.2 * ca * ca / (g_over_e * area) * w)

        total = 0.0
        for k in range(3):
            v, _ = quad(lambda r: terms(r)[k], self.rf, rc, epsabs=0, epsrel=1e-13, limit=200)
            total += v / el
        return total

    def fillet(self, roll):
        alpha_f = roll / self.rb - self.theta_b
        tf, hf = self.theta_f, self.rf / self.r_bore
        c = {k: a / tf**2 + b * hf**2 + cc * hf / tf + d / tf + e * hf + f
             for k, (a, b, cc, d, e, f) in SAINSOT.items()}
        h_load = self.rb * ((alpha_f + self.theta_b) * math.cos(alpha_f) - math.sin(alpha_f))
        u = (self.rb * ((alpha_f + self.theta_b) * math.sin(alpha_f) + math.cos(alpha_f))
             - h_load * math.tan(alpha_f) - self.rf)
        s = u / (2 * self.rf * tf)
        return (math.cos(alpha_f) ** 2 / (self.e * self.width)
                * (c["L"] * s * s + c["M"] * s + c["P"] * (1 + c["Q"] * math.tan(alpha_f) ** 2)))


class PairGeometry:
    def __init__(self, g):
        alpha = math.radians(g["pressure_angle"])
        self.p = Gear(g["pinion"], g["module"], alpha, g["face_width"])
        self.g = Gear(g["gear"], g["module"], alpha, g["face_width"])
        v = inv(alpha) + 2 * math.tan(alpha) * (self.p.x + self.g.x) / (self.p.z + self.g.z)
        self.alpha_w = brentq(lambda a: inv(a) - v, 1e-3, 1.4, xtol=1e-16, rtol=1e-15)
        self.t1t2 = (self.p.rb + self.g.rb) * math.tan(self.alpha_w)
        self.x_end = math.sqrt(self.p.ra**2 - self.p.rb**2)
        self.x_start = self.t1t2 - math.sqrt(self.g.ra**2 - self.g.rb**2)
        self.pb = 2 * math.pi * self.p.rb / self.p.z
        self.c = (self.x_end - self.x_start) / self.pb

    def stiffness(self, x, torque):
        w = torque / self.p.rb
        kh = STEEL[0] ** 0.9 * self.p.width**0.8 * w**0.1 / 1.275
        comp = (self.p.beam(x) + self.g.beam(self.t1t2 - x) + self.p.fillet(x)
                + self.g.fillet(self.t1t2 - x) + 1 / kh)
        return 1 / comp


def scene_meshes(repo_root):
    scene = tomllib.loads((repo_root / "examples/liu2007/ch2_idler_geometry.toml").read_text())
    return [m["pairs"]["geometry"] for m in scene["mesh"]]


def toml_value(v):
    if isinstance(v, str):
        return f'"{v}"'
    return repr(v)


def gears_file(path, g):
    lines = [f"{k} = {toml_value(v)}" for k, v in g.items() if not isinstance(v, dict)]
    for table in ("pinion", "gear", "model"):
        lines.append(f"[{table}]")
        lines += [f"{k} = {toml_value(v)}" for k, v in g[table].items()]
    path.write_text("\n".join(lines) + "\n")


def geardyn_pairs(tmp_path, g, torque, etc):
    gf = tmp_path / "gears.toml"
    gears_file(gf, g)
    out = tmp_path / "pairs.csv"
    run_geardyn("stiffness", gf, "--torque", torque, "--etc", "on" if etc else "off",
                "--out", tmp_path / "k.csv", "--pairs", out, "--quiet")
    return [{k: float(v) for k, v in r.items()} for r in csv.DictReader(out.open())]


@pytest.mark.parametrize("mesh", [0, 1])
def test_gears_give_the_printed_contact_ratios(repo_root, mesh):
    pg = PairGeometry(scene_meshes(repo_root)[mesh])
    c_printed, alpha_printed = ((1.504, 21.22), (1.510, 21.02))[mesh]
    assert abs(pg.c - c_printed) < 1e-9, pg.c
    assert abs(math.degrees(pg.alpha_w) - alpha_printed) < 1e-9, math.degrees(pg.alpha_w)
    # The base radii of Table 2.1 to its printed digits (0.04535 / 0.06564 / 0.11218 m).
    for gear, rb in ((pg.p, (0.04535, 0.06564)[mesh]), (pg.g, (0.06564, 0.11218)[mesh])):
        assert abs(gear.rb - rb) < 0.5e-5 * 1.01, (gear.rb, rb)


@pytest.mark.parametrize("mesh,torque,etc", [(0, 100.0, True), (0, 50.0, False),
                                             (1, 144.74, True), (1, 300.0, False)])
def test_pair_stiffness_matches_independent_potential_energy(repo_root, tmp_path, geardyn_bin,
                                                              mesh, torque, etc):
    g = scene_meshes(repo_root)[mesh]
    pg = PairGeometry(g)
    rows = geardyn_pairs(tmp_path, g, torque, etc)
    e = 0.01 if etc else 0.0  # the ETC extension of the pair window, mesh cycles
    assert abs(rows[-1]["xi"] - (pg.c + 2 * e)) < 1e-12
    worst = 0.0
    checked = 0
    # Every knot of the window: approach, single contact, recess and the ETC ends.
    for r in rows:
        x = min(max(pg.x_start + pg.pb * (r["xi"] - e), pg.x_start), pg.x_end)
        assert abs(r["position"] - x) < 1e-12, (r["xi"], r["position"], x)
        want = pg.stiffness(x, torque)
        rel = abs(r["stiffness"] / want - 1)
        worst = max(worst, rel)
        checked += 1
        # The terms one by one (so a compensating error cannot hide).
        for name, got, ref in (("beam_pinion", r["beam_pinion"], pg.p.beam(x)),
                               ("beam_gear", r["beam_gear"], pg.g.beam(pg.t1t2 - x)),
                               ("fillet_pinion", r["fillet_pinion"], pg.p.fillet(x)),
                               ("fillet_gear", r["fillet_gear"], pg.g.fillet(pg.t1t2 - x))):
            assert abs(got / ref - 1) <= TOL, (name, r["xi"], got, ref)
    print(f"mesh {mesh + 1}, {torque} N·m, ETC {etc}: {checked} knots, "
          f"largest relative difference {worst:.2e}")
    assert checked >= 20
    assert worst <= TOL
