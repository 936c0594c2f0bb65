//! Effective torsional mesh stiffness with sliding friction (He & Singh 2007 §4, eqs. (18)–(25);
//! general closed form and errata in `shared/reference/models-he-singh-2007.md` §2.5).
//!
//! With rigid bearings and a constant stiffness density `k` along the contact lines, pair `i`
//! gives the pinion and the gear the torsional stiffnesses (eq. 18, `c1 = −δ`)
//!
//! ```text
//! K_p,i = (k/r_bp) [ r_bp cos β_b Δz + μ (∫_rec x dz − ∫_app x dz) ]
//! K_g,i = (k/r_bg) [ r_bg cos β_b Δz + μ (∫_rec (x_g − x) dz − ∫_app (x_g − x) dz) ]
//! ```
//!
//! (this reproduces every zone formula of eqs. (19)–(21) once the printed typos are fixed), and
//! the inertia weighting of eq. (24) turns them into one equivalent stiffness on the DTE δ:
//! `K_e,i = (r_bp² J_g K_p,i + r_bg² J_p K_g,i) / (r_bg² J_p + r_bp² J_g)`.
//!
//! Because the line ends move linearly with the phase, `K_e(s)` is piecewise *quadratic* with
//! friction; the paper (eq. 25) uses the linear interpolation between the region boundaries,
//! which is what [`HelicalGeometry::piecewise_stiffness`] hands to the dynamic model.

use super::geometry::HelicalGeometry;
use super::lines::ContactLineIntegrals;
use crate::mesh::{MeshStiffness, Piece};

/// Parameters of the stiffness model beyond geometry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrictionStiffness {
    /// Stiffness density `k` per unit contact-line length projected on `z` (N/m² in SI).
    pub density: f64,
    /// Coulomb friction coefficient μ ≥ 0 (sign reversal at the pitch line).
    pub friction: f64,
    /// Polar moment of inertia of the pinion J_p.
    pub pinion_inertia: f64,
    /// Polar moment of inertia of the gear J_g.
    pub gear_inertia: f64,
}

/// Torsional stiffnesses of one pair, or of the whole mesh (N/m in SI).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TorsionalStiffness {
    /// K_p (eq. 18: pinion mesh moment / (r_bp δ)).
    pub pinion: f64,
    /// K_g (eq. 18: gear mesh moment / (r_bg δ)).
    pub gear: f64,
    /// K_e (eq. 24), the stiffness of the SDOF model on the DTE.
    pub effective: f64,
}

impl HelicalGeometry {
    /// `K_p`, `K_g`, `K_e` of the lines summarised by `integrals` (one pair or a sum: the
    /// formulas are linear in the integrals).
    pub fn torsional_stiffness(
        &self,
        integrals: &ContactLineIntegrals,
        params: &FrictionStiffness,
    ) -> TorsionalStiffness {
        let (r_bp, r_bg) = (self.pinion.base_radius, self.gear.base_radius);
        let (j_p, j_g) = (params.pinion_inertia, params.gear_inertia);
        let k = params.density;
        let mu = params.friction;
        let cos_b = self.base_helix_angle.cos();
        let i = integrals;
        let pinion_arm = i.recess_moment - i.approach_moment;
        let gear_arm = (self.x_g * i.recess_length - i.recess_moment)
            - (self.x_g * i.approach_length - i.approach_moment);
        let pinion = k / r_bp * (r_bp * cos_b * i.length + mu * pinion_arm);
        let gear = k / r_bg * (r_bg * cos_b * i.length + mu * gear_arm);
        let effective = (r_bp * r_bp * j_g * pinion + r_bg * r_bg * j_p * gear)
            / (r_bg * r_bg * j_p + r_bp * r_bp * j_g);
        TorsionalStiffness {
            pinion,
            gear,
            effective,
        }
    }

    /// The exact (piecewise-quadratic) mesh stiffnesses at mesh phase `s`, summed over pairs.
    pub fn stiffness_at(&self, s: f64, params: &FrictionStiffness) -> TorsionalStiffness {
        self.torsional_stiffness(&self.total_integrals(s), params)
    }

    /// The paper's piecewise-linear `K_e` (eq. 25): linear between the sorted
    /// [`HelicalGeometry::breakpoints`], through the exact values at them, as a periodic source
    /// in mesh phase (`phase` shifts it like every other source). Pieces are contiguous and
    /// cover `[0, 1)`.
    ///
    /// The end values of each piece are the exact one-sided limits, taken from the quadratic
    /// through three interior samples (exact, the integrals are of degree ≤ 2 between
    /// breakpoints): `K_e` is continuous for a helical pair, but a spur pair (β = 0) jumps
    /// where a whole line enters or leaves, and the rectangular wave must come out unchanged.
    pub fn piecewise_stiffness(&self, params: &FrictionStiffness, phase: f64) -> MeshStiffness {
        let points = self.breakpoints();
        let n = points.len();
        let pieces = (0..n)
            .map(|j| {
                let start = points[j];
                let end = if j + 1 < n { points[j + 1] } else { 1.0 };
                let w = end - start;
                let k = |u: f64| self.stiffness_at(start + u * w, params).effective;
                let (q1, q2, q3) = (k(0.25), k(0.5), k(0.75));
                let k_start = 3.0 * q1 - 3.0 * q2 + q3;
                let k_end = q1 - 3.0 * q2 + 3.0 * q3;
                Piece {
                    start,
                    end,
                    k_start,
                    slope: (k_end - k_start) / w,
                }
            })
            .collect();
        MeshStiffness::Piecewise { phase, pieces }
    }
}
