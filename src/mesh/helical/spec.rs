//! The helical gear pair as written by the user (the `[mesh.stiffness.helical]` table of a
//! scene). Syntax only; [`super::geometry`] derives and checks. Lengths in one consistent unit
//! (SI metres in scenes), angles in degrees. Format: `docs/helical.md`.

use schemars::JsonSchema;
use serde::Deserialize;

/// Which cylinder the given helix angle is measured on (He & Singh 2007 print "helix angle
/// 21.5°" without saying; their eq. (2) uses it as the base helix angle β_b).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HelixAngleReference {
    /// The standard reading: the angle on the pitch cylinder, `tan β_b = tan β cos α_t`.
    Pitch,
    /// The angle is the base helix angle β_b itself.
    Base,
}

/// A helical gear pair of standard (unshifted) involute gears on parallel axes.
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct HelicalPairSpec {
    /// Transverse module m_t (pitch diameter = m_t z). Give this or `transverse_diametral_pitch`.
    pub transverse_module: Option<f64>,
    /// Transverse diametral pitch P_t = 1/m_t, teeth per unit length of pitch diameter.
    pub transverse_diametral_pitch: Option<f64>,
    /// Transverse pressure angle α_t, degrees.
    #[schemars(extend("x-unit" = "degree"))]
    pub transverse_pressure_angle: f64,
    /// Helix angle, degrees, in [0, 90): 0 is a spur pair.
    #[schemars(extend("x-unit" = "degree"))]
    pub helix_angle: f64,
    /// Where `helix_angle` is measured: `"pitch"` or `"base"` (required: the paper is
    /// ambiguous); parsed by [`HelixAngleReference::parse`] so a bad value is named.
    pub helix_angle_reference: String,
    /// Face width W (common to both gears).
    pub face_width: f64,
    /// Centre distance; must equal the sum of the pitch radii (no profile shift). Default: that sum.
    pub centre_distance: Option<f64>,
    /// The driving gear.
    pub pinion: HelicalGearSpec,
    /// The driven gear.
    pub gear: HelicalGearSpec,
}

/// One gear of a helical pair.
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct HelicalGearSpec {
    /// Number of teeth.
    #[schemars(extend("x-unit" = "1"))]
    pub teeth: i64,
    /// Outside (tip) diameter; default the standard addendum of one normal module,
    /// `m_t z + 2 m_n` with `m_n = m_t cos β` (β on the pitch cylinder).
    pub outside_diameter: Option<f64>,
    /// Root diameter (checked for tip-to-root clearance only); default none.
    pub root_diameter: Option<f64>,
}

impl HelixAngleReference {
    /// `"pitch"` or `"base"`.
    pub fn parse(field: &str, text: &str) -> Result<HelixAngleReference, String> {
        match text {
            "pitch" => Ok(HelixAngleReference::Pitch),
            "base" => Ok(HelixAngleReference::Base),
            other => Err(format!(
                "{field} = {other:?}: must be \"pitch\" (angle on the pitch cylinder) or \"base\" \
                 (the base helix angle β_b)"
            )),
        }
    }

    /// The TOML spelling.
    pub fn as_str(self) -> &'static str {
        match self {
            HelixAngleReference::Pitch => "pitch",
            HelixAngleReference::Base => "base",
        }
    }
}
