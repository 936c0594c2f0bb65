//! The lumped mesh-stiffness shapes (`constant`, `rectangular`, `trapezoidal`, `fourier`,
//! `table`; `docs/model.md`) of any mesh; `geometry` and `helical` are resolved by their own
//! files.

use super::checks::{bounded, err, finite, harmonic_list};
use crate::mesh::MeshStiffness;
use crate::scene::spec::StiffnessSpec;
use crate::scene::SceneError;

type Result<T> = std::result::Result<T, SceneError>;

pub(crate) fn stiffness_kind(spec: &StiffnessSpec) -> &'static str {
    match spec {
        StiffnessSpec::Constant { .. } => "constant",
        StiffnessSpec::Rectangular { .. } => "rectangular",
        StiffnessSpec::Trapezoidal { .. } => "trapezoidal",
        StiffnessSpec::Fourier { .. } => "fourier",
        StiffnessSpec::Table { .. } => "table",
        StiffnessSpec::Geometry { .. } => "geometry",
        StiffnessSpec::Helical { .. } => "helical",
    }
}

/// Checks the contact ratio and the peak-to-peak ratio shared by the rectangular shapes.
fn wave_parameters(mean: f64, ratio: f64, contact_ratio: f64) -> Result<()> {
    bounded("mesh.stiffness.mean", mean)?;
    bounded("mesh.stiffness.peak_to_peak_ratio", ratio)?;
    if !(contact_ratio.is_finite() && contact_ratio >= 1.0) {
        return err(format!(
            "mesh.stiffness.contact_ratio = {contact_ratio}: must be >= 1 (a contact ratio below 1 means the \
             gears lose contact between tooth pairs)"
        ));
    }
    Ok(())
}

pub(crate) fn stiffness(spec: &StiffnessSpec) -> Result<MeshStiffness> {
    let phase = |p: f64| finite("mesh.stiffness.phase", p);
    Ok(match spec {
        StiffnessSpec::Constant { value } => {
            MeshStiffness::constant(bounded("mesh.stiffness.value", *value)?)
        }
        StiffnessSpec::Rectangular {
            mean,
            peak_to_peak_ratio,
            contact_ratio,
            phase: p,
        } => {
            wave_parameters(*mean, *peak_to_peak_ratio, *contact_ratio)?;
            MeshStiffness::rectangular(*mean, *peak_to_peak_ratio, *contact_ratio, phase(*p)?)
        }
        StiffnessSpec::Trapezoidal {
            mean,
            peak_to_peak_ratio,
            contact_ratio,
            transition,
            phase: p,
        } => {
            wave_parameters(*mean, *peak_to_peak_ratio, *contact_ratio)?;
            let f = contact_ratio - contact_ratio.floor();
            let limit = f.min(1.0 - f);
            // `contact_ratio − floor` rounds (1.4 − 1 = 0.3999…96): a transition equal to the
            // zone as the user wrote it is accepted and taken as the zone itself.
            let rounding = 8.0 * f64::EPSILON * contact_ratio.abs().max(1.0);
            if !(transition.is_finite() && *transition > 0.0 && *transition <= limit + rounding) {
                return err(format!(
                    "mesh.stiffness.transition = {transition}: must be > 0 and <= {limit} (the shorter of the \
                     single- and double-contact zones for contact_ratio = {contact_ratio})"
                ));
            }
            MeshStiffness::trapezoidal(
                *mean,
                *peak_to_peak_ratio,
                *contact_ratio,
                transition.min(limit),
                phase(*p)?,
            )
        }
        StiffnessSpec::Fourier {
            mean,
            cos,
            sin,
            phase: p,
        } => {
            bounded("mesh.stiffness.mean", *mean)?;
            harmonic_list("mesh.stiffness.cos", cos)?;
            harmonic_list("mesh.stiffness.sin", sin)?;
            MeshStiffness::fourier(*mean, cos, sin, phase(*p)?)
        }
        StiffnessSpec::Table {
            phase_points,
            values,
            phase: p,
        } => {
            if phase_points.len() != values.len() {
                return err(format!(
                    "mesh.stiffness.values: {} values for {} phase_points; the lists must have the same length",
                    values.len(),
                    phase_points.len()
                ));
            }
            if phase_points.len() < 2 {
                return err(format!(
                    "mesh.stiffness.phase_points: {} points given; a table needs at least 2",
                    phase_points.len()
                ));
            }
            for (i, &s) in phase_points.iter().enumerate() {
                if !(s.is_finite() && (0.0..1.0).contains(&s)) {
                    return err(format!(
                        "mesh.stiffness.phase_points[{i}] = {s}: must lie in [0, 1)"
                    ));
                }
                if i > 0 && s <= phase_points[i - 1] {
                    return err(format!(
                        "mesh.stiffness.phase_points[{i}] = {s}: must be greater than phase_points[{}] = {}",
                        i - 1,
                        phase_points[i - 1]
                    ));
                }
            }
            for (i, &k) in values.iter().enumerate() {
                bounded(&format!("mesh.stiffness.values[{i}]"), k)?;
            }
            MeshStiffness::table(phase_points, values, phase(*p)?)
        }
        StiffnessSpec::Geometry { .. } => unreachable!("resolved by scene::geometry"),
        StiffnessSpec::Helical { .. } => unreachable!("resolved by scene::helical"),
    })
}
