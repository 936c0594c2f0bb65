//! The planetary tables of a scene file (`docs/planetary.md`): `[[carrier]]`, and the gear keys
//! that place a gear in a planetary stage (`internal`, `carrier`, `position_angle`,
//! `pin_error` of [`super::GearSpec`]).

use serde::Deserialize;

/// `[[carrier]]`: the carrier of a planetary stage, a body of the drivetrain like a gear (its
/// name can be a shaft end, the input or the output gear), without teeth.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CarrierSpec {
    pub name: String,
    /// Radius of the circle of planet centres r_c, m: the carrier's rotation coordinate is
    /// `u_c = r_c θ_c` (Lin & Parker 1999).
    pub radius: f64,
    /// Polar moment of inertia, kg·m².
    pub inertia: f64,
    /// Mass, kg (needed with `bearing_stiffness`).
    pub mass: Option<f64>,
    /// Bearing stiffness `[k_x, k_y]`, N/m, in the carrier frame: the carrier translates.
    pub bearing_stiffness: Option<[f64; 2]>,
    /// Bearing damping `[c_x, c_y]`, N·s/m.
    pub bearing_damping: Option<[f64; 2]>,
    /// Torsional support to ground, N·m/rad (a held carrier).
    #[serde(default)]
    pub ground_stiffness: f64,
    /// Torsional damping to ground, N·m·s/rad.
    #[serde(default)]
    pub ground_damping: f64,
    /// The central member (sun, ring or this carrier) whose nominal speed is zero; default:
    /// the only one of them with a `ground_stiffness`.
    pub fixed: Option<String>,
    /// Add the gyroscopic and centripetal terms of the rotating carrier frame at the carrier's
    /// nominal speed (Lin & Parker 1999 eq. 1: `Ω_c G q'` and `−Ω_c² K_Ω q`); off by
    /// default, as in the papers' analyses (`docs/planetary.md`, "Gyroscopic terms").
    #[serde(default)]
    pub gyroscopic: bool,
}
