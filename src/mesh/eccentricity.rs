//! What a gear's eccentricity (runout) does to the involute mesh geometry besides the
//! displacement along the line of action of [`super::errors`]: it moves the mesh position
//! (frequency modulation of the stiffness) and the operating centre distance, hence the
//! pressure angle, the contact ratio and the backlash (`docs/errors.md`, "Runout as a moving
//! centre").
//!
//! Rigid involute kinematics of a pinion `a` (base radius `r_a`, `z_a` teeth, rotation sense
//! `σ_a`) and a gear `b` whose geometric centres `G_a`, `G_b` sit at `w_a`, `w_b` from their
//! rotation axes. The centre line `G_a → G_b` is `a0 ĉ + Δw`, `Δw = w_b − w_a`; with the
//! centre-line components `u_c = Δw·ĉ`, `u_⊥ = Δw·ĉ⊥` (`ĉ⊥` = `ĉ` turned by +π/2):
//!
//! - operating centre distance `a = |a0 ĉ + Δw| = √((a0 + u_c)² + u_⊥²)`, direction change
//!   `δχ = atan2(u_⊥, a0 + u_c)`;
//! - operating pressure angle `cos α_w = (r_a + r_b)/a` (the base circles' internal tangent);
//! - the contact of a tooth pair lies on that tangent at `d_a = r_a(θ_a − γ_a)` from the
//!   pinion's tangent point `T_a`, whose direction from `G_a` is `γ_a = χ − α_w` in the
//!   pinion's rotation sense (the sign that gives the textbook approach `−sin α_w Δa` and
//!   backlash change `2 sin α_w Δa`, e.g. Litvin & Fuentes 2004 §10). The pinion tip meets the
//!   line at a fixed `d_a`, so the mesh phase (contact position from the end of contact, in
//!   base pitches `p_b = 2π r_a/z_a`) shifts by `δq = −z_a(σ_a δχ − δα_w)/2π` cycles;
//! - the path of contact `T_a T_b = L = √(a² − (r_a + r_b)²)` changes the start of contact
//!   (the gear tip on the line, `d_a = L − √(r_tb² − r_b²)`): the contact ratio is
//!   `ε = ε0 − (L − L0)/p_b`, so a pair enters `(L − L0)/p_b` cycles later;
//! - normal backlash `j_n = p_b − s_ba − s_bb + 2(r_a + r_b) inv α_w` (ISO 21771 §5.3 tooth
//!   thicknesses on the base circle), so `Δj_n = 2(r_a + r_b)(inv α_w − inv α_w0)` ≈
//!   `2 sin α_w Δa`.
//!
//! These are the eccentricity effects of Velex & Maatar (1996, JSV 191(5):629–660, mounting
//! errors in the instantaneous contact conditions) and the AM/FM modulation of Inalpolat &
//! Kahraman (2009, JSV 323:677–696), derived here from the involute geometry.

use std::f64::consts::TAU;

/// The geometric centre of one gear of the mesh: `w = A(cos ψ, sin ψ)`,
/// `ψ = σ θ + φ`, `θ = 2π (p − p0)/z` its nominal rotation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Centre {
    /// `±A`: `+A` for the gear (it adds to `Δw`), `−A` for the pinion.
    pub signed_amplitude: f64,
    /// Rotation sense `σ` of the gear.
    pub sense: f64,
    /// Direction `φ` of the offset at `p = p0`, rad, in the scene frame (that of `β`).
    pub phase: f64,
    /// Tooth count `z` (mesh cycles per revolution).
    pub teeth: f64,
}

/// The involute geometry of one mesh whose gears have runout.
#[derive(Debug, Clone, PartialEq)]
pub struct Eccentricity {
    centres: Vec<Centre>,
    p0: f64,
    /// Centre-line direction `χ0` in the frame of the line of action.
    chi0: f64,
    a0: f64,
    /// `r_a + r_b`.
    base_sum: f64,
    alpha0: f64,
    inv0: f64,
    path0: f64,
    pinion_sense: f64,
    pinion_teeth: f64,
    base_pitch: f64,
}

/// The geometry changes at one mesh phase, and their derivatives per mesh cycle.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Modulation {
    /// `δq`: shift of the mesh position, cycles.
    pub phase: f64,
    pub phase_slope: f64,
    /// `(L − L0)/p_b`: delay of the start of contact (`−δε`), cycles.
    pub entry: f64,
    pub entry_slope: f64,
    /// `Δj_n`: change of the total normal backlash, m.
    pub backlash: f64,
    pub backlash_slope: f64,
}

/// The mesh data [`Eccentricity::new`] needs.
#[derive(Debug, Clone, Copy)]
pub struct MeshGeometry {
    /// Base radii of the pinion and the gear, m.
    pub base_radii: (f64, f64),
    pub pinion_teeth: u32,
    pub pinion_sense: f64,
    /// Operating pressure angle `α_w0` at the nominal centre distance, rad.
    pub pressure_angle: f64,
    /// Direction `β` of the line of action in the scene frame, rad.
    pub line_of_action: f64,
}

impl Eccentricity {
    /// The geometry of a mesh with the gear centres `centres` (phases in the scene frame),
    /// nominal rotations counted from mesh phase `p0`. An error when the eccentricities could
    /// bring the base circles together (`Σ A ≥ a0 − r_a − r_b`).
    pub fn new(geometry: MeshGeometry, centres: &[Centre], p0: f64) -> Result<Self, String> {
        let (ra, rb) = geometry.base_radii;
        let alpha0 = geometry.pressure_angle;
        let base_sum = ra + rb;
        let a0 = base_sum / alpha0.cos();
        let total: f64 = centres.iter().map(|c| c.signed_amplitude.abs()).sum();
        if !(total < 0.5 * (a0 - base_sum)) {
            return Err(format!(
                "runout amplitudes {total:e} m: not small against the centre distance's margin \
                 a0 − r_a − r_b = {:e} m (pressure angle {}°)",
                a0 - base_sum,
                alpha0.to_degrees()
            ));
        }
        // The centre line in the frame of the line of action: ĉ = ℓ turned by −σ_a(π/2 − α).
        let chi0 = geometry.line_of_action
            - geometry.pinion_sense * (std::f64::consts::FRAC_PI_2 - alpha0);
        Ok(Eccentricity {
            centres: centres.to_vec(),
            p0,
            chi0,
            a0,
            base_sum,
            alpha0,
            inv0: alpha0.tan() - alpha0,
            path0: (a0 * a0 - base_sum * base_sum).sqrt(),
            pinion_sense: geometry.pinion_sense,
            pinion_teeth: f64::from(geometry.pinion_teeth),
            base_pitch: TAU * ra / f64::from(geometry.pinion_teeth),
        })
    }

    /// The geometry changes at mesh phase `p` (nominal rotations).
    pub fn at(&self, p: f64) -> Modulation {
        // Δw along and across the centre line, and their rates per cycle.
        let (mut uc, mut uc1, mut up, mut up1) = (0.0, 0.0, 0.0, 0.0);
        for c in &self.centres {
            let w = c.sense * TAU / c.teeth;
            let psi = w * (p - self.p0) + c.phase - self.chi0;
            let (s, co) = psi.sin_cos();
            uc += c.signed_amplitude * co;
            uc1 -= c.signed_amplitude * s * w;
            up += c.signed_amplitude * s;
            up1 += c.signed_amplitude * co * w;
        }
        let x = self.a0 + uc;
        let a = x.hypot(up);
        let a1 = (x * uc1 + up * up1) / a;
        let dchi = up.atan2(x);
        let dchi1 = (x * up1 - up * uc1) / (a * a);
        let alpha = (self.base_sum / a).acos();
        let alpha1 = a1 / (a * alpha.tan());
        let path = (a * a - self.base_sum * self.base_sum).sqrt();
        let k = -self.pinion_teeth / TAU;
        let tan = alpha.tan();
        Modulation {
            phase: k * (self.pinion_sense * dchi - (alpha - self.alpha0)),
            phase_slope: k * (self.pinion_sense * dchi1 - alpha1),
            entry: (path - self.path0) / self.base_pitch,
            entry_slope: a * a1 / (path * self.base_pitch),
            backlash: 2.0 * self.base_sum * ((tan - alpha) - self.inv0),
            backlash_slope: 2.0 * self.base_sum * tan * tan * alpha1,
        }
    }

    /// Bounds on `|d²/dp²|` of (phase, entry, backlash): the first-order amplitudes
    /// `Σ A (2π/z)²` times their gains, with a factor 2 for the neglected higher orders
    /// (relative size `A/a0`).
    pub fn curvature_bounds(&self) -> (f64, f64, f64) {
        let s: f64 = self
            .centres
            .iter()
            .map(|c| c.signed_amplitude.abs() * (TAU / c.teeth).powi(2))
            .sum();
        let (sin, tan) = (self.alpha0.sin(), self.alpha0.tan());
        (
            2.0 * s * self.pinion_teeth / TAU * (1.0 + 1.0 / tan) / self.a0,
            2.0 * s / (sin * self.base_pitch),
            2.0 * s * 2.0 * sin,
        )
    }

    /// The largest `|δq'|` per cycle (same first-order bound with a factor 2).
    pub fn phase_slope_bound(&self) -> f64 {
        let s: f64 = (self.centres.iter())
            .map(|c| c.signed_amplitude.abs() * TAU / c.teeth)
            .sum();
        2.0 * s * self.pinion_teeth / TAU * (1.0 + 1.0 / self.alpha0.tan()) / self.a0
    }

    /// The largest `|Δj_n'|` per cycle (`2 sin α |Δa'|`, same first-order bound with a
    /// factor 2), m.
    pub fn backlash_slope_bound(&self) -> f64 {
        let s: f64 = (self.centres.iter())
            .map(|c| c.signed_amplitude.abs() * TAU / c.teeth)
            .sum();
        2.0 * s * 2.0 * self.alpha0.sin()
    }

    /// The largest `|entry|` over a revolution (first-order bound with a factor 2), cycles.
    pub fn entry_bound(&self) -> f64 {
        let s: f64 = self.centres.iter().map(|c| c.signed_amplitude.abs()).sum();
        2.0 * s / (self.alpha0.sin() * self.base_pitch)
    }

    /// The nominal phase `p` at which `p + δq(p) − entry_weight·entry(p) = target`
    /// (fixed-point iteration: the modulation's slope is of the order `A z/a0 ≪ 1`).
    pub fn solve_phase(&self, target: f64, entry_weight: f64) -> f64 {
        let mut p = target;
        for _ in 0..60 {
            let m = self.at(p);
            let next = target - m.phase + entry_weight * m.entry;
            if next == p {
                break;
            }
            p = next;
        }
        p
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pair(centres: &[Centre]) -> Eccentricity {
        Eccentricity::new(
            MeshGeometry {
                base_radii: (0.04535, 0.06564),
                pinion_teeth: 38,
                pinion_sense: 1.0,
                pressure_angle: 20f64.to_radians(),
                line_of_action: 0.0,
            },
            centres,
            0.0,
        )
        .unwrap()
    }

    /// A gear centre pushed along the centre line by `A`: the textbook first-order changes.
    #[test]
    fn centre_distance_changes_match_the_textbook_sensitivities() {
        let alpha = 20f64.to_radians();
        let a = 1e-7;
        // ĉ is at −(π/2 − α) from the line of action: a gear offset in that direction.
        let e = pair(&[Centre {
            signed_amplitude: a,
            sense: -1.0,
            phase: -(std::f64::consts::FRAC_PI_2 - alpha),
            teeth: 55.0,
        }]);
        let m = e.at(0.0);
        let a0 = (0.04535 + 0.06564) / alpha.cos();
        let pb = TAU * 0.04535 / 38.0;
        assert!(
            (m.backlash / (2.0 * alpha.sin() * a) - 1.0).abs() < 1e-5,
            "{m:?}"
        );
        assert!(
            (m.entry / (a / (alpha.sin() * pb)) - 1.0).abs() < 1e-5,
            "{m:?}"
        );
        let dq = 38.0 / TAU * a / (a0 * alpha.tan());
        assert!((m.phase / dq - 1.0).abs() < 1e-5, "{m:?}");
        // The slopes are the derivatives of the values (a larger runout: the central
        // difference of a 1e-7 m runout is dominated by the rounding of acos).
        let e = pair(&[Centre {
            signed_amplitude: 1e-5,
            sense: -1.0,
            phase: 0.4,
            teeth: 55.0,
        }]);
        let h = 1e-2;
        let (lo, hi) = (e.at(0.3 - h), e.at(0.3 + h));
        let mid = e.at(0.3);
        for (d, s) in [
            (hi.phase - lo.phase, mid.phase_slope),
            (hi.entry - lo.entry, mid.entry_slope),
            (hi.backlash - lo.backlash, mid.backlash_slope),
        ] {
            assert!((d / (2.0 * h) - s).abs() <= 1e-6 * s.abs(), "{d} {s}");
        }
        let p = e.solve_phase(0.5, 1.0);
        let m = e.at(p);
        assert!((p + m.phase - m.entry - 0.5).abs() < 1e-15);
    }
}
