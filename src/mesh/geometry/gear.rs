//! Spur-gear and gear-pair geometry: radii, tooth angles, path of contact, contact ratio,
//! and the checks that reject impossible gears (undercut, interference, pointed teeth,
//! contact ratio < 1) with the field and value named.
//!
//! Involute geometry is textbook (e.g. Litvin & Fuentes, *Gear Geometry and Applied Theory*,
//! ch. 10; ISO 21771): base radius `r_b = r cos α`, involute function `inv α = tan α − α`,
//! half tooth angle at the base circle `θ_b = π/(2z) + inv α + 2x tan α / z` (the notes'
//! `θ_b = π/(2N) + inv α_0`, Liao et al. 2025 §2.1 [EXT], extended by the profile shift).

use std::f64::consts::PI;

use super::spec::{GearPairSpec, GearSpec};

/// `inv α = tan α − α`.
pub fn inv(alpha: f64) -> f64 {
    alpha.tan() - alpha
}

/// Solves `inv α = v` for `α ∈ (0, π/2)` (Newton from a cube-root start; `inv` is convex and
/// increasing, so Newton from the right converges monotonically).
pub fn inv_inverse(v: f64) -> f64 {
    let mut a = (3.0 * v).cbrt().clamp(1e-6, 1.4);
    for _ in 0..60 {
        let t = a.tan();
        let step = (t - a - v) / (t * t);
        a -= step;
        if step.abs() < 1e-15 {
            break;
        }
    }
    a
}

/// One gear with its derived radii and angles (SI, radians).
#[derive(Debug, Clone, PartialEq)]
pub struct Gear {
    pub teeth: u32,
    pub module: f64,
    /// Rack pressure angle α, rad.
    pub alpha: f64,
    pub shift: f64,
    pub e: f64,
    pub nu: f64,
    pub face_width: f64,
    /// Pitch radius `m z / 2`.
    pub r: f64,
    pub r_base: f64,
    pub r_tip: f64,
    pub r_root: f64,
    pub r_bore: f64,
    /// Density ρ, kg/m³ (`None`: not given, inertia and mass are not derivable).
    pub density: Option<f64>,
    /// Radius where the generated involute starts (end of the cutter's straight flank).
    pub r_form: f64,
    /// Half tooth angle at the base circle θ_b.
    pub theta_b: f64,
    /// Half tooth angle at the junction of the fillet with the root circle θ_f (Sainsot 2004).
    pub theta_f: f64,
}

fn positive(field: &str, v: f64) -> Result<f64, String> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(format!("{field} = {v}: must be a finite number > 0"))
    }
}

fn finite(field: &str, v: f64) -> Result<f64, String> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("{field} = {v}: must be a finite number"))
    }
}

impl Gear {
    /// Derives and checks one gear; `field` is the TOML path of its table (e.g. `pinion`).
    pub fn new(
        field: &str,
        spec: &GearSpec,
        module: f64,
        alpha: f64,
        face_width: f64,
    ) -> Result<Gear, String> {
        let f = |name: &str| format!("{field}.{name}");
        if spec.teeth < 5 || spec.teeth > 10_000 {
            return Err(format!(
                "{} = {}: must be an integer in 5..=10000",
                f("teeth"),
                spec.teeth
            ));
        }
        let z = spec.teeth as f64;
        let x = finite(&f("profile_shift"), spec.profile_shift)?;
        let ha = positive(&f("addendum"), spec.addendum)?;
        let hf = positive(&f("dedendum"), spec.dedendum)?;
        let material = super::material::resolve(field, spec)?;
        let e = positive(&f("youngs_modulus"), material.youngs_modulus)?;
        let nu = material.poisson_ratio;
        if !(nu.is_finite() && nu > 0.0 && nu < 0.5) {
            return Err(format!(
                "{} = {nu}: must lie in (0, 0.5)",
                f("poisson_ratio")
            ));
        }
        let r_bore = positive(&f("bore_radius"), spec.bore_radius)?;
        let density = material
            .density
            .map(|rho| positive(&f("density"), rho))
            .transpose()?;
        let (sin_a, cos_a, tan_a) = (alpha.sin(), alpha.cos(), alpha.tan());
        // Default: the full round of the standard clearance c* = 0.25, ρ* = c*/(1 − sin α)
        // (tip circle tangent to the tip line and to the flank at depth h_f* − c*; ISO 53
        // profile A rounds this to ρ_fP* = 0.38 at 20°, ROSS uses it exactly).
        let rho = match spec.cutter_tip_radius {
            Some(v) => {
                if !(v.is_finite() && v >= 0.0) {
                    return Err(format!(
                        "{} = {v}: must be a finite number >= 0",
                        f("cutter_tip_radius")
                    ));
                }
                v
            }
            None => 0.25 / (1.0 - sin_a),
        };
        if hf <= ha {
            return Err(format!(
                "{} = {hf}: must exceed the addendum {ha} (no tip clearance otherwise)",
                f("dedendum")
            ));
        }
        let r = module * z / 2.0;
        let r_base = r * cos_a;
        let r_tip = r + module * (ha + x);
        let r_root = r - module * (hf - x);
        if !(r_root > 0.0) {
            return Err(format!(
                "{} = {x}: the root radius r − m(h_f* − x) = {r_root:e} m is not positive",
                f("profile_shift")
            ));
        }
        // Cutter tip land half-width (rack tooth centred on the space), Litvin ch. 10: the
        // tip circle centre sits ρ above the tip line and ρ from the flank.
        let land = module * (PI / 4.0 - (hf - rho) * tan_a - rho / cos_a);
        if land < 0.0 {
            return Err(format!(
                "{} = {rho}: the cutter tip circle does not fit the rack tooth (tip land {land:e} m < 0)",
                f("cutter_tip_radius")
            ));
        }
        // The junction of fillet and root circle is generated by the end of the tip land; it
        // lies at angle land/r from the space centre line (the rack rolls on the pitch
        // circle), hence θ_f = π/z − land/r.
        let theta_f = PI / z - land / r;
        // Depth (below the rolling line) where the straight cutter flank ends; the involute
        // it generates starts on the line of action at r sin α − depth/sin α from T.
        let depth = module * (hf - rho * (1.0 - sin_a) - x);
        let roll_form = r * sin_a - depth / sin_a;
        if roll_form < 0.0 {
            let z_min = 2.0 * (hf - rho * (1.0 - sin_a) - x) / (sin_a * sin_a);
            return Err(format!(
                "{} = {}: the tooth is undercut by the generating rack (needs teeth >= {z_min:.2} \
                 with profile_shift = {x}, or a larger profile_shift)",
                f("teeth"),
                spec.teeth
            ));
        }
        let r_form = (r_base * r_base + roll_form * roll_form).sqrt();
        let theta_b = PI / (2.0 * z) + inv(alpha) + 2.0 * x * tan_a / z;
        let alpha_tip = (r_base / r_tip).acos();
        let half_tip = theta_b - inv(alpha_tip);
        if r_tip <= r_form || half_tip <= 0.0 {
            return Err(format!(
                "{} = {x}: the tooth is pointed (half tooth angle at the tip {half_tip:.4e} rad); \
                 reduce profile_shift or addendum",
                f("profile_shift")
            ));
        }
        if r_root <= r_bore {
            return Err(format!(
                "{} = {r_bore}: must be smaller than the root radius {r_root} m",
                f("bore_radius")
            ));
        }
        Ok(Gear {
            teeth: spec.teeth as u32,
            module,
            alpha,
            shift: x,
            e,
            nu,
            face_width,
            r,
            r_base,
            r_tip,
            r_root,
            r_bore,
            density,
            r_form,
            theta_b,
            theta_f,
        })
    }

    /// Polar moment of inertia of the gear body, kg·m²: a solid disc of the face width
    /// between the bore and the pitch circle, `J = ½ ρ π L (r⁴ − r_bore⁴)`. Teeth above and
    /// tooth spaces below the pitch circle roughly balance, which is the usual approximation
    /// (e.g. the ROSS rotordynamics package, `GearElement`, uses the pitch diameter).
    /// `None` without a density.
    pub fn inertia(&self) -> Option<f64> {
        self.density
            .map(|rho| 0.5 * rho * PI * self.face_width * (self.r.powi(4) - self.r_bore.powi(4)))
    }

    /// Mass of the same disc, `m = ρ π L (r² − r_bore²)`, kg (`None` without a density).
    pub fn mass(&self) -> Option<f64> {
        self.density
            .map(|rho| rho * PI * self.face_width * (self.r.powi(2) - self.r_bore.powi(2)))
    }

    /// Roll length `sqrt(r² − r_b²)` of radius `r` (distance from the base tangent point).
    pub fn roll(&self, radius: f64) -> f64 {
        (radius * radius - self.r_base * self.r_base)
            .max(0.0)
            .sqrt()
    }

    /// Load angle α_F of a contact at roll length `l` (contact pressure angle α_c with
    /// `tan α_c = l/r_b`): `α_F = tan α_c − θ_b` (notes §1.2 [EXT]).
    pub fn load_angle(&self, roll: f64) -> f64 {
        roll / self.r_base - self.theta_b
    }
}

/// A meshing pair at its zero-backlash centre distance.
#[derive(Debug, Clone, PartialEq)]
pub struct Pair {
    pub pinion: Gear,
    pub gear: Gear,
    /// Working pressure angle α_w (from `inv α_w = inv α + 2 tan α (x1+x2)/(z1+z2)`).
    pub alpha_w: f64,
    pub center_distance: f64,
    /// Length `T1T2 = a sin α_w` of the line of action between the base tangent points.
    pub t1t2: f64,
    /// Start A of the path of contact (gear tip), as distance from T1.
    pub x_start: f64,
    /// End E of the path of contact (pinion tip), as distance from T1.
    pub x_end: f64,
    /// Base pitch `2π r_b1 / z1`.
    pub base_pitch: f64,
    /// Involute contact ratio `AE / p_b`.
    pub contact_ratio: f64,
}

impl Pair {
    /// Derives and checks the pair; `prefix` is the TOML path of the gear-pair table
    /// (`""` for a gears file, `"mesh.stiffness.geometry."` in a scene).
    pub fn new(spec: &GearPairSpec, prefix: &str) -> Result<Pair, String> {
        let module = positive(&format!("{prefix}module"), spec.module)?;
        let alpha_deg = spec.pressure_angle;
        if !(alpha_deg.is_finite() && (10.0..=35.0).contains(&alpha_deg)) {
            return Err(format!(
                "{prefix}pressure_angle = {alpha_deg}: must lie in [10, 35] degrees"
            ));
        }
        let alpha = alpha_deg.to_radians();
        let width = positive(&format!("{prefix}face_width"), spec.face_width)?;
        let pinion = Gear::new(
            &format!("{prefix}pinion"),
            &spec.pinion,
            module,
            alpha,
            width,
        )?;
        let gear = Gear::new(&format!("{prefix}gear"), &spec.gear, module, alpha, width)?;
        let (z1, z2) = (pinion.teeth as f64, gear.teeth as f64);
        let alpha_w =
            inv_inverse(inv(alpha) + 2.0 * alpha.tan() * (pinion.shift + gear.shift) / (z1 + z2));
        let center_distance = (pinion.r_base + gear.r_base) / alpha_w.cos();
        let t1t2 = center_distance * alpha_w.sin();
        let x_end = pinion.roll(pinion.r_tip);
        let x_start = t1t2 - gear.roll(gear.r_tip);
        // Tip clearance: a tip must not reach the mating root circle.
        for (name, tip, other_root) in [
            ("pinion", pinion.r_tip, gear.r_root),
            ("gear", gear.r_tip, pinion.r_root),
        ] {
            if tip + other_root >= center_distance {
                return Err(format!(
                    "{prefix}{name}.addendum: tip radius {tip} m reaches the mating root circle \
                     (centre distance {center_distance} m, mating root radius {other_root} m)"
                ));
            }
        }
        // Interference: each start of active profile must lie on the generated involute.
        let pinion_sap = x_start;
        if pinion_sap < pinion.roll(pinion.r_form) {
            return Err(format!(
                "{prefix}gear.addendum = {}: interference — the gear tip (radius {} m) meets the pinion at \
                 roll length {pinion_sap:e} m, below the pinion's involute form circle (roll length {:e} m)",
                spec.gear.addendum,
                gear.r_tip,
                pinion.roll(pinion.r_form)
            ));
        }
        let gear_sap = t1t2 - x_end;
        if gear_sap < gear.roll(gear.r_form) {
            return Err(format!(
                "{prefix}pinion.addendum = {}: interference — the pinion tip (radius {} m) meets the gear at \
                 roll length {gear_sap:e} m, below the gear's involute form circle (roll length {:e} m)",
                spec.pinion.addendum,
                pinion.r_tip,
                gear.roll(gear.r_form)
            ));
        }
        let base_pitch = 2.0 * PI * pinion.r_base / z1;
        let contact_ratio = (x_end - x_start) / base_pitch;
        if !(contact_ratio >= 1.0) {
            return Err(format!(
                "{prefix}pinion.addendum = {}, {prefix}gear.addendum = {}: contact ratio {contact_ratio:.4} < 1 \
                 (the gears lose contact between tooth pairs)",
                spec.pinion.addendum, spec.gear.addendum
            ));
        }
        let frac = contact_ratio - contact_ratio.floor();
        if !(1e-6..=1.0 - 1e-6).contains(&frac) {
            return Err(format!(
                "contact ratio {contact_ratio:.9} is an integer: the single- and multiple-contact zones \
                 degenerate (change {prefix}pinion.addendum = {})",
                spec.pinion.addendum
            ));
        }
        Ok(Pair {
            pinion,
            gear,
            alpha_w,
            center_distance,
            t1t2,
            x_start,
            x_end,
            base_pitch,
            contact_ratio,
        })
    }

    /// Roll lengths `(l_pinion, l_gear)` of a contact at distance `x` from T1.
    pub fn rolls(&self, x: f64) -> (f64, f64) {
        (x, self.t1t2 - x)
    }

    /// Where a pair passes the pitch point P in the mesh cycle of the stiffness curve, mesh
    /// cycles: `(x_P − x_E)/p_b = −L_PE/p_b` with `x_P = T1P = r_b1 tan α_w` and `x_E` the pinion
    /// tip (pair `k` of the curve sits at `x_E + p_b (s + k)`, `crate::mesh::geometry::curve`).
    /// A stage's mesh phasing is referred to the pitch point (`docs/planetary.md`, eq. PL5).
    pub fn pitch_point_phase(&self) -> f64 {
        (self.pinion.r_base * self.alpha_w.tan() - self.x_end) / self.base_pitch
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inv_inverse_round_trips() {
        for deg in [5.0_f64, 14.5, 20.0, 25.0, 40.0, 60.0] {
            let a = deg.to_radians();
            assert!((inv_inverse(inv(a)) - a).abs() < 1e-13, "{deg}");
        }
    }
}
