//! `[mesh.friction]` of a Model-1 or helical mesh (Liu 2007 Ch. 5; He & Singh 2007): the
//! coefficient, bending factor and pitch point, checked into the contact geometry of
//! [`MeshFriction`].

use crate::scene::spec::FrictionSpec;
use crate::scene::train::{HelicalPair, MeshFriction};
use crate::scene::{Gear, SceneError};

/// Validates `[mesh.friction]` (`field` is its name in messages) for a Model-1 mesh with
/// contact ratio `c` and operating pressure angle `phi` (0 when not given); a helical pair
/// fixes the pitch line and has no friction-bending factor.
pub(crate) fn validate(
    field: &str,
    spec: &FrictionSpec,
    pinion: &Gear,
    gear: &Gear,
    phi: f64,
    c: f64,
    helical: Option<&HelicalPair>,
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
            "{field}: the friction arms need the mesh's pressure_angle (operating, degrees)"
        ));
    }
    if let Some(h) = helical {
        if bt != 0.0 {
            return err(format!(
                "{field}.bending_factor = {bt}: not part of the helical model (He & Singh 2007)"
            ));
        }
        if let Some(p) = spec.pitch_point {
            return err(format!(
                "{field}.pitch_point = {p}: a helical pair's pitch line comes from its geometry"
            ));
        }
        let g = &h.geometry;
        return Ok(MeshFriction {
            coefficient: mu,
            bending_factor: 0.0,
            pitch_point: (g.l_t1p - g.l_t1a) / g.base_pitch,
            pitch_arm: g.l_t1p,
            loa_length: g.x_g,
            base_pitch: g.base_pitch,
        });
    }
    let pitch_point = match spec.pitch_point {
        Some(p) if p.is_finite() && p > 0.0 && p < c => p,
        Some(p) => {
            return err(format!(
                "{field}.pitch_point = {p}: must lie inside the engagement window (0, {c}) \
                 (mesh cycles)"
            ))
        }
        None => standard_pitch_point(pinion, gear, phi, c),
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

/// The pitch point in the window of a pair with contact ratio `c` when the gears have
/// standard full-depth addenda of one module on their operating pitch circles
/// (`r_t = r_w(1 + 2/z)`, `r_w = r_b/cos φ`): approach length over the whole path of
/// contact, scaled to the window, `ξ_p = c·L_AP/(L_AP + L_PD)` with
/// `L_AP = √(r_tb² − r_bb²) − r_bb tan φ` (gear tip) and `L_PD` likewise for the pinion.
fn standard_pitch_point(pinion: &Gear, gear: &Gear, phi: f64, c: f64) -> f64 {
    let beyond_pitch = |g: &Gear| {
        let r_w = g.base_radius / phi.cos();
        let r_t = r_w * (1.0 + 2.0 / g.teeth as f64);
        (r_t * r_t - g.base_radius * g.base_radius).sqrt() - g.base_radius * phi.tan()
    };
    let approach = beyond_pitch(gear);
    let recess = beyond_pitch(pinion);
    c * approach / (approach + recess)
}
