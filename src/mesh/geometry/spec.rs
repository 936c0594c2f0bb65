//! The gear-pair description as written by the user (a gears file, or the inline
//! `[mesh.stiffness.geometry]` table of a scene). Syntax only; [`super::gear`] derives and
//! checks. Format: `docs/stiffness.md`.

use schemars::JsonSchema;
use serde::Deserialize;

use crate::scene::schema::positive;

/// A spur gear pair: shared cutting data plus one table per gear.
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct GearPairSpec {
    /// Module m, m.
    #[schemars(transform = positive, extend("x-unit" = "m"))]
    pub module: f64,
    /// Pressure angle α of the generating rack, degrees.
    #[schemars(extend("x-unit" = "degree"))]
    pub pressure_angle: f64,
    /// Face width L, m (common to both gears).
    #[schemars(transform = positive, extend("x-unit" = "m"))]
    pub face_width: f64,
    /// The driving gear.
    pub pinion: GearSpec,
    /// The driven gear.
    pub gear: GearSpec,
    /// Model options.
    #[serde(default)]
    pub model: ModelSpec,
}

/// One gear of the pair (rack-generated, ISO 53 style basic rack).
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct GearSpec {
    /// Number of teeth.
    #[schemars(extend("x-unit" = "1"))]
    pub teeth: i64,
    /// Profile-shift coefficient x (default 0).
    #[schemars(extend("x-unit" = "1"))]
    #[serde(default)]
    pub profile_shift: f64,
    /// Addendum coefficient h_a* (tip radius r + m(h_a* + x)), default 1.
    #[serde(default = "GearSpec::default_addendum")]
    pub addendum: f64,
    /// Dedendum coefficient h_f* = cutter addendum (root radius r − m(h_f* − x)), default 1.25.
    #[serde(default = "GearSpec::default_dedendum")]
    pub dedendum: f64,
    /// Cutter tip radius coefficient ρ*; default: the full round of the standard clearance,
    /// `0.25/(1 − sin α)` (= 0.380 at 20°, ISO 53 profile A).
    pub cutter_tip_radius: Option<f64>,
    /// Bore (or rim inner) radius r_int, m (Sainsot fillet foundation).
    #[schemars(extend("x-unit" = "m"))]
    pub bore_radius: f64,
    /// Material preset (`"steel"`, see [`super::material`]); explicit constants override it.
    pub material: Option<String>,
    /// Young's modulus E, Pa (default: the material's).
    #[schemars(extend("x-unit" = "Pa"))]
    pub youngs_modulus: Option<f64>,
    /// Poisson's ratio ν (default: the material's).
    pub poisson_ratio: Option<f64>,
    /// Density ρ, kg/m³ (default: the material's); needed only for derived inertias/masses.
    #[schemars(transform = positive, extend("x-unit" = "kg/m^3"))]
    pub density: Option<f64>,
}

impl GearSpec {
    fn default_addendum() -> f64 {
        1.0
    }
    fn default_dedendum() -> f64 {
        1.25
    }
}

/// Which Hertzian contact law.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, serde::Serialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum HertzLaw {
    /// Liao et al. 2025 eq. (3): `K_h = E^0.9 L^0.8 F^0.1 / 1.275` (load dependent).
    #[default]
    Nonlinear,
    /// Yang & Lin 1987: `K_h = π E L / (4 (1 − ν²))` (load independent).
    Linear,
}

/// Numerical and model options (`[model]`).
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ModelSpec {
    /// Hertzian contact law: `nonlinear` (Liao et al. 2025 eq. 3) or `linear`.
    #[serde(default)]
    pub hertz: HertzLaw,
    /// Gauss–Legendre points per tooth-beam integral.
    #[serde(default = "ModelSpec::default_quadrature")]
    pub quadrature: i64,
    /// Samples per contact zone of the stiffness curve (both ends included).
    #[serde(default = "ModelSpec::default_samples")]
    pub samples: i64,
}

impl ModelSpec {
    fn default_quadrature() -> i64 {
        32
    }
    fn default_samples() -> i64 {
        48
    }
}

impl Default for ModelSpec {
    fn default() -> Self {
        ModelSpec {
            hertz: HertzLaw::default(),
            quadrature: Self::default_quadrature(),
            samples: Self::default_samples(),
        }
    }
}

/// A gears file: `geardyn stiffness <gears.toml>`.
pub fn parse_gears_file(text: &str, origin: &str) -> Result<GearPairSpec, String> {
    toml::from_str(text).map_err(|e| format!("{origin}: {}", e.to_string().trim_end()))
}
