//! Tooth beam compliances by the potential-energy method: axial compression, bending and
//! shear of a non-uniform cantilever (Liao et al. 2025 eqs. (1)–(2); Yang & Lin 1987;
//! Tian 2004).
//!
//! Eq. (2) integrates over the involute from the load point (θ = −α_F) down to the base
//! circle (θ = θ_b), where the tangent point of the generating string sits at angle θ from the
//! tooth centre line: half thickness `h = r_b[sin θ + (θ_b − θ) cos θ]`, position along the
//! centre line `y = r_b[cos θ − (θ_b − θ) sin θ]`, `|dy| = r_b (θ_b − θ) cos θ dθ`.
//!
//! The paper assumes the root circle coincides with the base circle (notes §1.2). Two cases
//! are added, both standard:
//! - `r_f < r_b`: the tooth continues below the base circle with the base-circle thickness
//!   down to the root circle (a straight, constant-section segment; Chaari et al. 2009,
//!   Ma et al. 2015); its integrals are in closed form.
//! - `r_f > r_b`: the involute beam starts at the root circle, i.e. the upper limit of eq. (2)
//!   becomes the θ of the involute point of radius `r_f`.

use super::gear::Gear;
use super::quadrature::GaussLegendre;

/// The three beam compliances of one tooth for a unit load at load angle α_F, m/N.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeamCompliance {
    pub axial: f64,
    pub bending: f64,
    pub shear: f64,
}

impl BeamCompliance {
    /// `1/K_t = 1/K_a + 1/K_b + 1/K_s` (eq. (1)).
    pub fn total(&self) -> f64 {
        self.axial + self.bending + self.shear
    }
}

/// Beam compliances of `gear`'s tooth loaded at load angle `alpha_f` (eq. (2) plus the root
/// segment), with Gauss–Legendre rule `q` on the involute part.
pub fn beam_compliance(gear: &Gear, alpha_f: f64, q: &GaussLegendre) -> BeamCompliance {
    let tb = gear.theta_b;
    let (sa, ca) = alpha_f.sin_cos();
    let el = gear.e * gear.face_width;
    // Upper limit: base circle, or the involute point on the root circle when r_f > r_b.
    let upper = if gear.r_root > gear.r_base {
        tb - ((gear.r_root / gear.r_base).powi(2) - 1.0).sqrt()
    } else {
        tb
    };
    let mut beam = BeamCompliance {
        axial: 0.0,
        bending: 0.0,
        shear: 0.0,
    };
    let lower = -alpha_f;
    if upper > lower {
        let half = 0.5 * (upper - lower);
        let mid = 0.5 * (upper + lower);
        // Shared geometry at a node: w = |dy|/(r_b dθ), h = half thickness / r_b.
        let at = |u: f64| {
            let th = mid + half * u;
            let (st, ct) = th.sin_cos();
            let w = (tb - th) * ct;
            (th, st, ct, w, st + w)
        };
        beam.axial =
            half * q.integrate(-1.0, 1.0, |u| {
                let (_, _, _, w, h) = at(u);
                w * sa * sa / (2.0 * h)
            }) / el;
        beam.bending =
            half * q.integrate(-1.0, 1.0, |u| {
                let (th, st, ct, w, h) = at(u);
                let arm = 1.0 + ca * ((tb - th) * st - ct); // moment / (F r_b)
                3.0 * arm * arm * w / (2.0 * h * h * h)
            }) / el;
        beam.shear =
            half * q.integrate(-1.0, 1.0, |u| {
                let (_, _, _, w, h) = at(u);
                1.2 * (1.0 + gear.nu) * w * ca * ca / h
            }) / el;
    }
    if gear.r_root < gear.r_base {
        let seg = root_segment(gear, alpha_f);
        beam.axial += seg.axial;
        beam.bending += seg.bending;
        beam.shear += seg.shear;
    }
    beam
}

/// Closed-form compliances of the constant-section segment between the root circle and the
/// base circle (half thickness `h_b = r_b sin θ_b`), for `r_f < r_b`:
/// `1/K_b = ∫ M²/(F² E I) dy` with `M/F = cos α_F (y_c − y) − x_c sin α_F` linear in `y`,
/// `I = (2h_b)³L/12`; `1/K_s = 1.2 cos²α_F ℓ/(G A)`; `1/K_a = sin²α_F ℓ/(E A)`, `A = 2h_b L`.
pub fn root_segment(gear: &Gear, alpha_f: f64) -> BeamCompliance {
    let rb = gear.r_base;
    let tb = gear.theta_b;
    let (sa, ca) = alpha_f.sin_cos();
    let hb = rb * tb.sin();
    let y_base = rb * tb.cos();
    let y_root = (gear.r_root * gear.r_root - hb * hb).sqrt();
    let len = y_base - y_root;
    // Load point (θ = −α_F on the involute).
    let yc = rb * (ca + (tb + alpha_f) * sa);
    let xc = rb * ((tb + alpha_f) * ca - sa);
    let arm = |y: f64| ca * (yc - y) - xc * sa;
    let el = gear.e * gear.face_width;
    let g_over_e = 1.0 / (2.0 * (1.0 + gear.nu));
    let inertia = (2.0 * hb).powi(3) / 12.0; // per unit E·L
    BeamCompliance {
        axial: sa * sa * len / (el * 2.0 * hb),
        bending: (arm(y_root).powi(3) - arm(y_base).powi(3)) / (3.0 * ca) / (el * inertia),
        shear: 1.2 * ca * ca * len / (el * g_over_e * 2.0 * hb),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::geometry::gear::{inv, Gear};
    use crate::mesh::geometry::spec::GearSpec;

    fn gear(teeth: i64) -> Gear {
        let spec = GearSpec {
            teeth,
            profile_shift: 0.0,
            addendum: 1.0,
            dedendum: 1.25,
            cutter_tip_radius: None,
            bore_radius: 0.01,
            material: None,
            youngs_modulus: Some(2.06e11),
            poisson_ratio: Some(0.3),
            density: None,
        };
        Gear::new("g", &spec, 0.003, 20f64.to_radians(), 0.02).unwrap()
    }

    /// The same three potential-energy integrals in Cartesian form, `∫ M²/(EI) dy`,
    /// `∫ 1.2 F_b²/(GA) dy`, `∫ F_a²/(EA) dy`, over a tooth described by the polar involute
    /// (half angle `ψ(r) = θ_b − inv(acos(r_b/r))`, an independent parametrisation from the
    /// string-tangent one of eq. (2)) plus the constant-section segment below the base circle,
    /// integrated by the trapezoidal rule on a fine grid.
    fn cartesian(g: &Gear, alpha_f: f64) -> BeamCompliance {
        let (sa, ca) = alpha_f.sin_cos();
        let rb = g.r_base;
        let rc = rb * (1.0 + (g.theta_b + alpha_f).powi(2)).sqrt(); // load-point radius
        let psi = |r: f64| g.theta_b - inv((rb / r).min(1.0).acos());
        let yc = rc * psi(rc).cos();
        let xc = rc * psi(rc).sin();
        // (y, half thickness) from the root circle up to the load point.
        let mut pts = Vec::new();
        let hb = rb * g.theta_b.sin();
        let y_root = (g.r_root * g.r_root - hb * hb).sqrt();
        let y_base = rb * g.theta_b.cos();
        let n = 40_000;
        for i in 0..n {
            pts.push((y_root + (y_base - y_root) * i as f64 / n as f64, hb));
        }
        for i in 0..=n {
            // Cluster points near the base circle where dψ/dr varies fastest.
            let t = (i as f64 / n as f64).powi(2);
            let r = rb + (rc - rb) * t;
            pts.push((r * psi(r).cos(), r * psi(r).sin()));
        }
        let el = g.e * g.face_width;
        let ge = 1.0 / (2.0 * (1.0 + g.nu));
        let (mut a, mut b, mut s) = (0.0, 0.0, 0.0);
        for w in pts.windows(2) {
            let f = |(y, h): (f64, f64)| {
                let m = ca * (yc - y) - xc * sa;
                let area = 2.0 * h;
                let inertia = (2.0 * h).powi(3) / 12.0;
                (sa * sa / area, m * m / inertia, 1.2 * ca * ca / (ge * area))
            };
            let dy = w[1].0 - w[0].0;
            let (a0, b0, s0) = f(w[0]);
            let (a1, b1, s1) = f(w[1]);
            a += 0.5 * dy * (a0 + a1);
            b += 0.5 * dy * (b0 + b1);
            s += 0.5 * dy * (s0 + s1);
        }
        BeamCompliance {
            axial: a / el,
            bending: b / el,
            shear: s / el,
        }
    }

    #[test]
    fn eq2_matches_cartesian_potential_energy() {
        // z = 20: root circle below the base circle (straight segment active).
        for teeth in [20, 30] {
            let g = gear(teeth);
            assert!(g.r_root < g.r_base);
            let q = GaussLegendre::new(48);
            for alpha_f in [0.05, 0.2, 0.35] {
                let got = beam_compliance(&g, alpha_f, &q);
                let want = cartesian(&g, alpha_f);
                for (name, x, y) in [
                    ("axial", got.axial, want.axial),
                    ("bending", got.bending, want.bending),
                    ("shear", got.shear, want.shear),
                ] {
                    assert!(
                        (x / y - 1.0).abs() < 2e-6,
                        "z = {teeth}, α_F = {alpha_f}, {name}: eq. (2) {x:e} vs Cartesian {y:e}"
                    );
                }
            }
        }
    }
}
