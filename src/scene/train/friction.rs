//! Coulomb tooth friction of a Model-1 mesh (Liu 2007 Ch. 5, eqs. 4.39–4.48; notes
//! `models-liu-parker-2007.md` §4): the validated `[mesh.friction]` table and the contact
//! geometry along the line of action that the friction forces and moments need.
//!
//! A tooth pair at window position `ξ ∈ [0, c)` (mesh cycles) touches at the distance
//! `l(ξ) = ρ_0 + p_b(ξ − ξ_p)` from the pinion's base tangent point `T_1`, `ρ_0 = r_a tan φ`
//! (the pitch point), `p_b = 2πr_a/z_a`; its arm about the gear is `D − l`,
//! `D = (r_a + r_b) tan φ` the length `T_1T_2` (notes §4.3 [R]: the printed arm constants are
//! garbled; this is the self-consistent set with the base pitch). The sliding velocity of the
//! gear's flank relative to the pinion's, `Ω_b(D − l) − Ω_a l`, is positive before the pitch
//! point (approach) and negative after it (recess): the friction sign is a function of the
//! mesh phase alone (`v_i ≈ v̄_i`, §5.2).

use super::PairStiffness;
use crate::mesh::helical::HelicalGeometry;

/// A helical tooth-pair mesh (He & Singh 2007): the contact-line geometry and the stiffness
/// density `k` along the lines.
#[derive(Debug, Clone, PartialEq)]
pub struct HelicalPair {
    pub geometry: HelicalGeometry,
    pub density: f64,
}

impl HelicalPair {
    /// The contact-line integrals of a pair whose line's top end has advanced `ξ` base pitches
    /// from the start of active contact A (He & Singh eq. 11, `x_i = L_T1A + (s + i)λ`), or
    /// `None` out of contact.
    pub fn integrals(&self, xi: f64) -> Option<crate::mesh::helical::ContactLineIntegrals> {
        self.geometry.contact_line(0, xi).map(|l| l.integrals())
    }

    /// Window of a pair in mesh cycles: the total contact ratio `(L_AD + W tan β_b)/λ`.
    pub fn window(&self) -> f64 {
        self.geometry.total_contact_ratio()
    }

    /// Positions in the window (mesh cycles) where an end of the line crosses A, P or D: the
    /// pair stiffness is affine and the friction integrals quadratic between them.
    pub fn knots(&self) -> Vec<f64> {
        let g = &self.geometry;
        let c = self.window();
        let adv = g.helix_advance();
        let mut k: Vec<f64> = [g.l_t1a, g.l_t1p, g.l_t1d]
            .iter()
            .flat_map(|&x| [x, x + adv])
            .map(|x| (x - g.l_t1a) / g.base_pitch)
            .filter(|&xi| xi > 0.0 && xi < c)
            .collect();
        k.push(0.0);
        k.push(c);
        k.sort_by(f64::total_cmp);
        k.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
        k
    }

    /// Pair stiffness `k cos β_b Δz(ξ)` over the window, piecewise linear between the knots
    /// (the one-sided limits at the knots from two interior samples: a spur line enters whole).
    pub fn pair_stiffness(&self) -> PairStiffness {
        let cos_b = self.geometry.base_helix_angle.cos();
        let k = |xi: f64| {
            self.integrals(xi)
                .map_or(0.0, |i| self.density * cos_b * i.length)
        };
        let knots = self.knots();
        let pieces = knots
            .windows(2)
            .map(|w| {
                let width = w[1] - w[0];
                let (q1, q3) = (k(w[0] + 0.25 * width), k(w[0] + 0.75 * width));
                crate::mesh::Piece {
                    start: w[0],
                    end: w[1],
                    k_start: 1.5 * q1 - 0.5 * q3,
                    slope: (q3 - q1) / (0.5 * width),
                }
            })
            .collect();
        PairStiffness {
            contact_ratio: self.window(),
            pieces,
        }
    }

    /// Distributed friction weights at window position `ξ` (He & Singh eqs. 7 and 10 with the
    /// approach part of the line pushing the pinion along the sliding direction):
    /// `w0 = μk(Δz_app − Δz_rec)`, `w1 = μk(∫_app x dz − ∫_rec x dz)`.
    pub fn weights(&self, mu: f64, xi: f64) -> (f64, f64) {
        self.integrals(xi).map_or((0.0, 0.0), |i| {
            (
                mu * self.density * (i.approach_length - i.recess_length),
                mu * self.density * (i.approach_moment - i.recess_moment),
            )
        })
    }
}

/// Tooth friction of one mesh.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeshFriction {
    /// Coulomb coefficient μ.
    pub coefficient: f64,
    /// β̃ of eq. (4.42); the pair stiffness is `k(1 ± β̃μ)`.
    pub bending_factor: f64,
    /// Pitch point `ξ_p` in the engagement window, mesh cycles.
    pub pitch_point: f64,
    /// `ρ_0 = r_a tan φ`: the pinion's friction arm at the pitch point, m.
    pub pitch_arm: f64,
    /// `D = (r_a + r_b) tan φ`: the line of action between the base tangent points, m.
    pub loa_length: f64,
    /// Base pitch `p_b = 2πr_a/z_a`, m (the arm's advance per mesh cycle).
    pub base_pitch: f64,
}

impl MeshFriction {
    /// The friction-bending factor `β = β̃μ` of eq. (4.42).
    pub fn bending(&self) -> f64 {
        self.bending_factor * self.coefficient
    }

    /// Arm `l(ξ)` of the friction force about the pinion centre, m.
    pub fn pinion_arm(&self, xi: f64) -> f64 {
        self.pitch_arm + self.base_pitch * (xi - self.pitch_point)
    }

    /// `sgn(v)`: +1 in approach (`ξ < ξ_p`), −1 in recess.
    pub fn sliding_sign(&self, xi: f64) -> f64 {
        if xi < self.pitch_point {
            1.0
        } else {
            -1.0
        }
    }

    /// The pair stiffness with friction bending, eq. (4.42): `k(1 + β)` in approach,
    /// `k(1 − β)` in recess, split at the pitch point (a knot even for β = 0).
    pub fn pair_stiffness(&self, pair: &PairStiffness) -> PairStiffness {
        pair.with_friction_bending(self.pitch_point, self.bending())
    }

    /// Friction weights of a spur pair at window position `ξ` with (bent) pair stiffness
    /// `pair`: `w0 = μ sgn(v) k(ξ)` (friction force on the pinion per metre of deflection) and
    /// `w1 = w0 l(ξ)` (its moment about the pinion's base tangent point), eq. (4.44).
    pub fn weights(&self, pair: &PairStiffness, xi: f64) -> (f64, f64) {
        let w0 = self.coefficient * self.sliding_sign(xi) * pair.value(xi);
        (w0, w0 * self.pinion_arm(xi))
    }
}
