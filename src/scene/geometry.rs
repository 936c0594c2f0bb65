//! The `geometry` stiffness source: the gear pair is checked against the scene's gears and
//! its stiffness curve is computed once, at scene load, then handed to the model as an
//! existing form (piecewise-linear `table` pieces or a `fourier` series), so the dynamic model,
//! the solvers and the FMU see nothing new.

use super::spec::{GeometryForm, StiffnessSpec};
use super::validate::{finite, positive};
use super::{Gear, SceneError};
use crate::mesh::geometry::{CurveOptions, MeshModel};
use crate::mesh::MeshStiffness;

type Result<T> = std::result::Result<T, SceneError>;

const FIELD: &str = "mesh.stiffness";

/// Resolves a `StiffnessSpec::Geometry`.
pub(super) fn stiffness(
    spec: &StiffnessSpec,
    input_torque: f64,
    pinion: &Gear,
    gear: &Gear,
) -> Result<MeshStiffness> {
    let StiffnessSpec::Geometry {
        torque,
        etc,
        form,
        harmonics,
        phase,
        geometry,
    } = spec
    else {
        unreachable!("called for the geometry source only");
    };
    let prefix = format!("{FIELD}.geometry.");
    let model = MeshModel::new(geometry, &prefix).map_err(SceneError)?;
    // The dynamic model's gears must be the geometry's gears.
    for (i, (body, derived, table)) in [
        (pinion, &model.pair.pinion, "pinion"),
        (gear, &model.pair.gear, "gear"),
    ]
    .into_iter()
    .enumerate()
    {
        let which = if i == 0 { "mesh.pinion" } else { "mesh.gear" };
        if body.teeth != derived.teeth {
            return Err(SceneError(format!(
                "{which} ({:?}).teeth = {}: differs from {prefix}{table}.teeth = {}",
                body.name, body.teeth, derived.teeth
            )));
        }
        if ((body.base_radius - derived.r_base) / derived.r_base).abs() > 1e-4 {
            return Err(SceneError(format!(
                "{which} ({:?}).base_radius = {}: differs from the geometry's base radius m·z·cos α/2 = {} m \
                 by more than 1e-4 (relative)",
                body.name, body.base_radius, derived.r_base
            )));
        }
    }
    let torque = match torque {
        Some(t) => positive(&format!("{FIELD}.torque"), *t)?,
        None => {
            let t = finite("operating.input_torque", input_torque)?;
            if !(t > 0.0) {
                return Err(SceneError(format!(
                    "operating.input_torque = {t}: the geometry stiffness is load dependent and needs a \
                     positive torque (or set {FIELD}.torque)"
                )));
            }
            t
        }
    };
    let phase = finite(&format!("{FIELD}.phase"), *phase)?;
    let curve = model
        .curve(CurveOptions { torque, etc: *etc })
        .map_err(|e| SceneError(format!("{FIELD}: {e}")))?;
    Ok(match (form, harmonics) {
        (GeometryForm::Table, None) => curve.to_table(phase),
        (GeometryForm::Table, Some(h)) => {
            return Err(SceneError(format!(
                "{FIELD}.harmonics = {h}: only allowed with form = \"fourier\""
            )))
        }
        (GeometryForm::Fourier, h) => {
            let h = h.unwrap_or(4);
            if !(1..=256).contains(&h) {
                return Err(SceneError(format!(
                    "{FIELD}.harmonics = {h}: must be an integer in 1..=256"
                )));
            }
            curve.to_fourier(h as usize, phase)
        }
    })
}
