//! The `helical` stiffness source: a helical pair with sliding friction (He & Singh 2007,
//! `docs/helical.md`). The geometry is checked against the scene's gears and the paper's
//! piecewise-linear K_e(t) (eq. 25) is computed once, at scene load, as linear pieces, so the
//! dynamic model, the solvers and the FMU see nothing new.

use super::checks::{bounded, finite};
use crate::mesh::helical::{FrictionStiffness, HelicalGeometry};
use crate::mesh::MeshStiffness;
use crate::scene::spec::StiffnessSpec;
use crate::scene::{Gear, SceneError};

type Result<T> = std::result::Result<T, SceneError>;

const FIELD: &str = "mesh.stiffness";

/// Resolves a `StiffnessSpec::Helical`.
pub(super) fn stiffness(spec: &StiffnessSpec, pinion: &Gear, gear: &Gear) -> Result<MeshStiffness> {
    let StiffnessSpec::Helical {
        stiffness_density,
        friction_coefficient,
        phase,
        helical,
    } = spec
    else {
        unreachable!("called for the helical source only");
    };
    let density = bounded(&format!("{FIELD}.stiffness_density"), *stiffness_density)?;
    let friction = bounded(
        &format!("{FIELD}.friction_coefficient"),
        *friction_coefficient,
    )?;
    let phase = finite(&format!("{FIELD}.phase"), *phase)?;
    let prefix = format!("{FIELD}.helical.");
    let geometry = HelicalGeometry::new(helical, &prefix).map_err(SceneError)?;
    // The dynamic model's gears must be the geometry's gears.
    for (which, body, derived, table) in [
        ("mesh.pinion", pinion, &geometry.pinion, "pinion"),
        ("mesh.gear", gear, &geometry.gear, "gear"),
    ] {
        if body.teeth != derived.teeth {
            return Err(SceneError(format!(
                "{which} ({:?}).teeth = {}: differs from {prefix}{table}.teeth = {}",
                body.name, body.teeth, derived.teeth
            )));
        }
        if ((body.base_radius - derived.base_radius) / derived.base_radius).abs() > 1e-4 {
            return Err(SceneError(format!(
                "{which} ({:?}).base_radius = {}: differs from the geometry's base radius \
                 m_t·z·cos α_t/2 = {} m by more than 1e-4 (relative)",
                body.name, body.base_radius, derived.base_radius
            )));
        }
    }
    let params = FrictionStiffness {
        density,
        friction,
        pinion_inertia: pinion.inertia,
        gear_inertia: gear.inertia,
    };
    Ok(geometry.piecewise_stiffness(&params, phase))
}

impl crate::scene::PairScene {
    /// The same scene with another friction coefficient μ of its `helical` stiffness (the
    /// scene text is edited and validated again, so μ is checked like in a file).
    pub fn with_friction_coefficient(&self, mu: f64) -> Result<crate::scene::PairScene> {
        let mut table: toml::Table = toml::from_str(&self.source)
            .map_err(|e| SceneError(format!("scene {}: {e}", self.name)))?;
        let stiffness = table
            .get_mut("mesh")
            .and_then(|m| m.get_mut("stiffness"))
            .and_then(|s| s.as_table_mut())
            .filter(|s| s.get("kind").and_then(|k| k.as_str()) == Some("helical"))
            .ok_or_else(|| {
                SceneError(format!(
                    "scene {}: mesh.stiffness.kind is not \"helical\"; a friction coefficient \
                     applies to the helical stiffness only",
                    self.name
                ))
            })?;
        stiffness.insert("friction_coefficient".into(), toml::Value::Float(mu));
        let text =
            toml::to_string(&table).map_err(|e| SceneError(format!("scene {}: {e}", self.name)))?;
        let mut scene = crate::scene::PairScene::from_toml_str(&text, &self.name)?;
        scene.operating = self.operating;
        Ok(scene)
    }
}
