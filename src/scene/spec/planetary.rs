//! The planetary tables of a scene file (`docs/planetary.md`): `[[carrier]]`, and the gear keys
//! that place a gear in a planetary stage (`internal`, `carrier`, `position_angle`,
//! `pin_error` of [`super::GearSpec`]).

use schemars::JsonSchema;
use serde::Deserialize;

use crate::scene::schema::{non_negative, positive};

/// `[[carrier]]`: the carrier of a planetary stage, a body of the drivetrain like a gear (its
/// name can be a shaft end, the input or the output gear), without teeth.
#[derive(Debug, Clone, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CarrierSpec {
    /// Carrier name (a body of the drivetrain).
    pub name: String,
    /// Radius of the circle of planet centres r_c, m: the carrier's rotation coordinate is
    /// `u_c = r_c θ_c` (Lin & Parker 1999).
    #[schemars(transform = positive, extend("x-unit" = "m"))]
    pub radius: f64,
    /// Polar moment of inertia, kg·m².
    #[schemars(transform = positive, extend("x-unit" = "kg.m^2"))]
    pub inertia: f64,
    /// Mass, kg (needed with `bearing_stiffness`).
    #[schemars(transform = positive, extend("x-unit" = "kg"))]
    pub mass: Option<f64>,
    /// Bearing stiffness `[k_x, k_y]`, N/m, in the carrier frame: the carrier translates.
    #[schemars(transform = positive, extend("x-unit" = "N/m"))]
    pub bearing_stiffness: Option<[f64; 2]>,
    /// Bearing damping `[c_x, c_y]`, N·s/m.
    #[schemars(transform = non_negative, extend("x-unit" = "N.s/m"))]
    pub bearing_damping: Option<[f64; 2]>,
    /// Torsional support to ground, N·m/rad (a held carrier).
    #[serde(default)]
    #[schemars(transform = non_negative, extend("x-unit" = "N.m/rad"))]
    pub ground_stiffness: f64,
    /// Torsional damping to ground, N·m·s/rad.
    #[serde(default)]
    #[schemars(transform = non_negative, extend("x-unit" = "N.m.s/rad"))]
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
