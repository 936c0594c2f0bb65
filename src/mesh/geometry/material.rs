//! Gear materials: the named presets of `material = "…"` and the resolution of a gear's
//! elastic constants and density from a preset and explicit overrides (`docs/stiffness.md`,
//! "Material").
//!
//! Presets carry one documented data set each, so that a scene reads the same everywhere:
//!
//! - `steel`: E = 206 GPa and ν = 0.3, the steel values of ISO 6336-2:2019 behind its
//!   elasticity factor of steel on steel, Z_E = √(E/(2π(1 − ν²))) = 189.8 √(N/mm²);
//!   ρ = 7850 kg/m³ (7.85 kg/dm³, the density the mass-per-metre tables of steel bar
//!   standards such as EN 10060 are computed with).

use super::spec::GearSpec;

/// Elastic constants and density of a material.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Material {
    /// Young's modulus E, Pa.
    pub youngs_modulus: f64,
    /// Poisson's ratio ν.
    pub poisson_ratio: f64,
    /// Density ρ, kg/m³.
    pub density: f64,
}

/// The named presets (see the module documentation for the sources).
pub const PRESETS: &[(&str, Material)] = &[(
    "steel",
    Material {
        youngs_modulus: 206.0e9,
        poisson_ratio: 0.3,
        density: 7850.0,
    },
)];

/// A preset by name; the error names the value and lists the known presets.
pub fn preset(field: &str, name: &str) -> Result<Material, String> {
    PRESETS
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, m)| *m)
        .ok_or_else(|| {
            let known: Vec<_> = PRESETS.iter().map(|(n, _)| format!("{n:?}")).collect();
            format!(
                "{field} = {name:?}: unknown material (known: {}); or omit it and give \
                 youngs_modulus and poisson_ratio (and density for derived inertias)",
                known.join(", ")
            )
        })
}

/// A gear's resolved constants: an explicit key overrides the preset; without a preset, E and
/// ν must be given (no silent default material). The density is `None` when neither gives it
/// (inertia and mass are then not derivable).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Resolved {
    pub youngs_modulus: f64,
    pub poisson_ratio: f64,
    pub density: Option<f64>,
}

/// Resolves the material of one gear table; `field` is its TOML path (e.g. `…geometry.pinion`).
pub fn resolve(field: &str, spec: &GearSpec) -> Result<Resolved, String> {
    let base = spec
        .material
        .as_deref()
        .map(|name| preset(&format!("{field}.material"), name))
        .transpose()?;
    let pick = |key: &str, explicit: Option<f64>, from: Option<f64>| -> Result<f64, String> {
        explicit.or(from).ok_or_else(|| {
            let known: Vec<_> = PRESETS.iter().map(|(n, _)| format!("{n:?}")).collect();
            format!(
                "{field}.{key}: missing; give material = one of {} or {key} explicitly",
                known.join(", ")
            )
        })
    };
    Ok(Resolved {
        youngs_modulus: pick(
            "youngs_modulus",
            spec.youngs_modulus,
            base.map(|m| m.youngs_modulus),
        )?,
        poisson_ratio: pick(
            "poisson_ratio",
            spec.poisson_ratio,
            base.map(|m| m.poisson_ratio),
        )?,
        density: spec.density.or(base.map(|m| m.density)),
    })
}
