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

use super::spec::FrictionSpec;
use super::{PairStiffness, TrainGear};
use crate::scene::SceneError;

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

    /// The pitch point in the window of a pair with contact ratio `c` when the gears have
    /// standard full-depth addenda of one module on their operating pitch circles
    /// (`r_t = r_w(1 + 2/z)`, `r_w = r_b/cos φ`): approach length over the whole path of
    /// contact, scaled to the window, `ξ_p = c·L_AP/(L_AP + L_PD)` with
    /// `L_AP = √(r_tb² − r_bb²) − r_bb tan φ` (gear tip) and `L_PD` likewise for the pinion.
    pub fn standard_pitch_point(pinion: &TrainGear, gear: &TrainGear, phi: f64, c: f64) -> f64 {
        let beyond_pitch = |g: &TrainGear| {
            let r_w = g.base_radius / phi.cos();
            let r_t = r_w * (1.0 + 2.0 / g.teeth as f64);
            (r_t * r_t - g.base_radius * g.base_radius).sqrt() - g.base_radius * phi.tan()
        };
        let approach = beyond_pitch(gear);
        let recess = beyond_pitch(pinion);
        c * approach / (approach + recess)
    }
}

/// Validates `[mesh.friction]` (`field` is its name in messages) for a Model-1 mesh with
/// contact ratio `c` and operating pressure angle `phi` (0 when not given).
pub(super) fn validate(
    field: &str,
    spec: &FrictionSpec,
    pinion: &TrainGear,
    gear: &TrainGear,
    phi: f64,
    c: f64,
) -> Result<MeshFriction, SceneError> {
    let err = |msg: String| Err(SceneError(msg));
    let mu = spec.coefficient;
    if !(mu.is_finite() && mu >= 0.0) {
        return err(format!(
            "{field}.coefficient = {mu}: the friction coefficient must be finite and >= 0"
        ));
    }
    let bt = spec.bending_factor;
    if !bt.is_finite() {
        return err(format!("{field}.bending_factor = {bt}: must be finite"));
    }
    if !((bt * mu).abs() < 1.0) {
        return err(format!(
            "{field}.bending_factor = {bt}: β = bending_factor·coefficient = {} must lie in \
             (−1, 1), else a pair stiffness k(1 ± β) is not positive (Liu 2007 eq. 4.42 assumes \
             |β| ≪ 1)",
            bt * mu
        ));
    }
    if !(phi > 0.0) {
        return err(format!(
            "{field}: the friction arms need the mesh's pressure_angle (operating, rad)"
        ));
    }
    let pitch_point = match spec.pitch_point {
        Some(p) if p.is_finite() && p > 0.0 && p < c => p,
        Some(p) => {
            return err(format!(
                "{field}.pitch_point = {p}: must lie inside the engagement window (0, {c}) \
                 (mesh cycles)"
            ))
        }
        None => MeshFriction::standard_pitch_point(pinion, gear, phi, c),
    };
    let friction = MeshFriction {
        coefficient: mu,
        bending_factor: bt,
        pitch_point,
        pitch_arm: pinion.base_radius * phi.tan(),
        loa_length: (pinion.base_radius + gear.base_radius) * phi.tan(),
        base_pitch: std::f64::consts::TAU * pinion.base_radius / pinion.teeth as f64,
    };
    let (first, last) = (friction.pinion_arm(0.0), friction.pinion_arm(c));
    if first < 0.0 || last > friction.loa_length {
        return err(format!(
            "{field}.pitch_point = {pitch_point}: the contact path runs from {first:e} m to {last:e} m \
             from the pinion's base tangent point, outside the line of action [0, {:e}] m between \
             the tangent points (pressure_angle too small for this contact ratio?)",
            friction.loa_length
        ));
    }
    Ok(friction)
}
