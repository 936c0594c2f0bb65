//! Derived transverse geometry of a helical pair and its contact plane (He & Singh 2007 §3,
//! Fig. 2; standard involute relations in `shared/reference/models-he-singh-2007.md` §1.2).
//!
//! The contact plane is the plane of action unrolled: `x` runs along the line of action from
//! T1 (the pinion's base-circle tangent point), `z` along the face, `z ∈ [−W/2, W/2]`. Contact
//! is possible on the rectangle `L_T1A ≤ x ≤ L_T1D`; the pitch line is `x = L_T1P`.

use super::spec::{HelicalGearSpec, HelicalPairSpec, HelixAngleReference};

/// Fewest teeth accepted: below this a standard pressure angle undercuts badly and the
/// contact-zone formulas lose meaning.
pub const MIN_TEETH: i64 = 5;

/// Largest total contact ratio `ε_α + ε_β` accepted: every tooth pair in contact is tracked
/// (its contact line, integrals and breakpoints), so the work and memory of the stiffness grow
/// with it; real helical pairs stay below about 5.
pub const MAX_CONTACT_RATIO: f64 = 64.0;

/// Relative tolerance on the centre distance against the sum of the pitch radii.
pub const CENTRE_DISTANCE_TOLERANCE: f64 = 1e-4;

/// Radii of one gear.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HelicalGear {
    pub teeth: u32,
    pub pitch_radius: f64,
    /// `r_b = r cos α_t`.
    pub base_radius: f64,
    pub outside_radius: f64,
    pub root_radius: Option<f64>,
}

/// A validated helical pair with its contact-plane landmarks.
#[derive(Debug, Clone, PartialEq)]
pub struct HelicalGeometry {
    pub pinion: HelicalGear,
    pub gear: HelicalGear,
    pub transverse_module: f64,
    /// α_t, rad.
    pub pressure_angle: f64,
    /// β on the pitch cylinder, rad.
    pub pitch_helix_angle: f64,
    /// β_b, rad: the contact lines are inclined by β_b in the contact plane.
    pub base_helix_angle: f64,
    /// W.
    pub face_width: f64,
    pub centre_distance: f64,
    /// Transverse base pitch λ = π m_t cos α_t.
    pub base_pitch: f64,
    /// Start of active contact A (the gear's tip circle on the line of action), from T1.
    pub l_t1a: f64,
    /// Pitch point P, `r_bp tan α_t`.
    pub l_t1p: f64,
    /// End of active contact D (the pinion's tip circle), `sqrt(r_op² − r_bp²)`.
    pub l_t1d: f64,
    /// `x_g = L_T1T2 = C sin α_t`, the gear's base tangent point: the gear's friction arm is `x_g − x`.
    pub x_g: f64,
}

fn degrees(field: &str, value: f64, lo: f64, hi: f64, what: &str) -> Result<f64, String> {
    if value.is_finite() && value >= lo && value < hi {
        Ok(value.to_radians())
    } else {
        Err(format!("{field} = {value}: {what}"))
    }
}

fn positive(field: &str, value: f64) -> Result<f64, String> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(format!("{field} = {value}: must be a finite number > 0"))
    }
}

impl HelicalGeometry {
    /// Derives and checks the geometry; messages name fields as `{prefix}field`.
    pub fn new(spec: &HelicalPairSpec, prefix: &str) -> Result<HelicalGeometry, String> {
        let f = |name: &str| format!("{prefix}{name}");
        let module = match (spec.transverse_module, spec.transverse_diametral_pitch) {
            (Some(m), None) => positive(&f("transverse_module"), m)?,
            (None, Some(p)) => 1.0 / positive(&f("transverse_diametral_pitch"), p)?,
            (Some(_), Some(_)) => {
                return Err(format!(
                    "{} and {}: give one of them, not both",
                    f("transverse_module"),
                    f("transverse_diametral_pitch")
                ))
            }
            (None, None) => {
                return Err(format!(
                    "{}: missing; give transverse_module or transverse_diametral_pitch",
                    f("transverse_module")
                ))
            }
        };
        let alpha = degrees(
            &f("transverse_pressure_angle"),
            spec.transverse_pressure_angle,
            1.0,
            45.0,
            "must be a finite angle in [1°, 45°)",
        )?;
        let helix = degrees(
            &f("helix_angle"),
            spec.helix_angle,
            0.0,
            90.0,
            "must be a finite angle in [0°, 90°) (0 is a spur pair)",
        )?;
        let reference =
            HelixAngleReference::parse(&f("helix_angle_reference"), &spec.helix_angle_reference)?;
        let (pitch_helix, base_helix) = match reference {
            HelixAngleReference::Pitch => (helix, (helix.tan() * alpha.cos()).atan()),
            HelixAngleReference::Base => ((helix.tan() / alpha.cos()).atan(), helix),
        };
        let face_width = positive(&f("face_width"), spec.face_width)?;
        let normal_module = module * pitch_helix.cos();
        let gear = |which: &str, g: &HelicalGearSpec| -> Result<HelicalGear, String> {
            let field = |name: &str| f(&format!("{which}.{name}"));
            if g.teeth < MIN_TEETH || g.teeth > 100_000 {
                return Err(format!(
                    "{} = {}: must be an integer in {MIN_TEETH}..=100000",
                    field("teeth"),
                    g.teeth
                ));
            }
            let pitch_radius = 0.5 * module * g.teeth as f64;
            let base_radius = pitch_radius * alpha.cos();
            let outside_radius = match g.outside_diameter {
                Some(d) => 0.5 * positive(&field("outside_diameter"), d)?,
                None => pitch_radius + normal_module,
            };
            if outside_radius <= pitch_radius {
                return Err(format!(
                    "{} = {}: must exceed the pitch diameter m_t z = {}",
                    field("outside_diameter"),
                    2.0 * outside_radius,
                    2.0 * pitch_radius
                ));
            }
            let root_radius = match g.root_diameter {
                Some(d) => {
                    let r = 0.5 * positive(&field("root_diameter"), d)?;
                    if r >= pitch_radius {
                        return Err(format!(
                            "{} = {d}: must be below the pitch diameter m_t z = {}",
                            field("root_diameter"),
                            2.0 * pitch_radius
                        ));
                    }
                    Some(r)
                }
                None => None,
            };
            Ok(HelicalGear {
                teeth: g.teeth as u32,
                pitch_radius,
                base_radius,
                outside_radius,
                root_radius,
            })
        };
        let pinion = gear("pinion", &spec.pinion)?;
        let wheel = gear("gear", &spec.gear)?;
        let standard = pinion.pitch_radius + wheel.pitch_radius;
        let centre_distance = match spec.centre_distance {
            Some(c) => {
                let c = positive(&f("centre_distance"), c)?;
                if ((c - standard) / standard).abs() > CENTRE_DISTANCE_TOLERANCE {
                    return Err(format!(
                        "{} = {c}: differs from the sum of the pitch radii m_t (z_p + z_g)/2 = {standard} \
                         by more than {CENTRE_DISTANCE_TOLERANCE:e} (relative); shifted or \
                         non-standard centre distances are not modelled",
                        f("centre_distance")
                    ));
                }
                c
            }
            None => standard,
        };
        for (a, b, a_name, b_name) in [
            (&pinion, &wheel, "pinion", "gear"),
            (&wheel, &pinion, "gear", "pinion"),
        ] {
            if let Some(root) = a.root_radius {
                if root + b.outside_radius > centre_distance {
                    return Err(format!(
                        "{} = {}: the {b_name}'s tip (outside radius {}) reaches below this root \
                         at centre distance {centre_distance}",
                        f(&format!("{a_name}.root_diameter")),
                        2.0 * root,
                        b.outside_radius
                    ));
                }
            }
        }
        let x_g = centre_distance * alpha.sin();
        let l_t1p = pinion.base_radius * alpha.tan();
        let l_t1d = (pinion.outside_radius.powi(2) - pinion.base_radius.powi(2)).sqrt();
        let l_t1a = x_g - (wheel.outside_radius.powi(2) - wheel.base_radius.powi(2)).sqrt();
        if !(l_t1a > 0.0) {
            return Err(format!(
                "{} = {}: the gear's tip circle meets the line of action before the pinion's base \
                 tangent point (L_T1A = {l_t1a}); the pair interferes",
                f("gear.outside_diameter"),
                2.0 * wheel.outside_radius
            ));
        }
        if !(l_t1d < x_g) {
            return Err(format!(
                "{} = {}: the pinion's tip circle meets the line of action beyond the gear's base \
                 tangent point (L_T1D = {l_t1d} >= x_g = {x_g}); the pair interferes",
                f("pinion.outside_diameter"),
                2.0 * pinion.outside_radius
            ));
        }
        let base_pitch = std::f64::consts::PI * module * alpha.cos();
        let geometry = HelicalGeometry {
            pinion,
            gear: wheel,
            transverse_module: module,
            pressure_angle: alpha,
            pitch_helix_angle: pitch_helix,
            base_helix_angle: base_helix,
            face_width,
            centre_distance,
            base_pitch,
            l_t1a,
            l_t1p,
            l_t1d,
            x_g,
        };
        let total = geometry.total_contact_ratio();
        if !(total >= 1.0) {
            return Err(format!(
                "{}: the total contact ratio ε_α + ε_β = {total} is below 1 (the gears lose contact \
                 between tooth pairs)",
                f("face_width")
            ));
        }
        if !(total <= MAX_CONTACT_RATIO) {
            return Err(format!(
                "{} = {face_width:e}: the total contact ratio ε_α + ε_β = {total:e} exceeds \
                 {MAX_CONTACT_RATIO} (every tooth pair in contact is tracked; real helical pairs \
                 have a few)",
                f("face_width")
            ));
        }
        Ok(geometry)
    }

    /// Length of the contact zone along the line of action, `L_AD`.
    pub fn contact_length(&self) -> f64 {
        self.l_t1d - self.l_t1a
    }

    /// Transverse contact ratio ε_α = L_AD / λ.
    pub fn transverse_contact_ratio(&self) -> f64 {
        self.contact_length() / self.base_pitch
    }

    /// Axial offset of a contact line's ends along the line of action, `W tan β_b`.
    pub fn helix_advance(&self) -> f64 {
        self.face_width * self.base_helix_angle.tan()
    }

    /// Overlap (face) contact ratio ε_β = W tan β_b / λ.
    pub fn overlap_ratio(&self) -> f64 {
        self.helix_advance() / self.base_pitch
    }

    /// ε_α + ε_β (the paper's "overall contact ratio σ").
    pub fn total_contact_ratio(&self) -> f64 {
        self.transverse_contact_ratio() + self.overlap_ratio()
    }
}
