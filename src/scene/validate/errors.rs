//! Runout and pitch errors of a gear (`docs/errors.md`), checked the same in every scene.

use super::checks::{err, finite};
use crate::mesh::errors::{cumulative_from_individual, GearErrors, Runout};
use crate::scene::spec::GearSpec;
use crate::scene::SceneError;

type Result<T> = std::result::Result<T, SceneError>;

/// Runout and pitch tables of a gear (`docs/errors.md`): finite values, a non-negative runout
/// amplitude, one pitch value per tooth, and one pitch key only.
pub(crate) fn gear_errors(
    f: &dyn Fn(&str) -> String,
    name: &str,
    teeth: u32,
    g: &GearSpec,
) -> Result<GearErrors> {
    let runout = match &g.runout {
        Some(r) => {
            let amplitude = r.amplitude;
            if !(amplitude.is_finite() && amplitude >= 0.0) {
                return err(format!(
                    "{}.amplitude = {amplitude}: the runout (eccentricity) amplitude must be a \
                     finite number >= 0 in m; give its direction with runout.phase",
                    f("runout")
                ));
            }
            Some(Runout {
                amplitude,
                phase: finite(&format!("{}.phase", f("runout")), r.phase)?,
            })
        }
        None => None,
    };
    let table = |key: &str, values: &[f64]| -> Result<()> {
        if values.len() != teeth as usize {
            return err(format!(
                "{} has {} values: a pitch table needs one value per tooth, {teeth} for gear {:?}",
                f(key),
                values.len(),
                name
            ));
        }
        for (i, &v) in values.iter().enumerate() {
            finite(&format!("{}[{i}]", f(key)), v)?;
        }
        Ok(())
    };
    let cumulative_pitch = match (&g.pitch_errors, &g.cumulative_pitch_errors) {
        (Some(_), Some(_)) => {
            return err(format!(
                "{} and {}: give one of them (the cumulative table is the running sum of the \
                 individual one)",
                f("pitch_errors"),
                f("cumulative_pitch_errors")
            ))
        }
        (Some(individual), None) => {
            table("pitch_errors", individual)?;
            let cumulative = cumulative_from_individual(individual);
            // Around a whole gear the single pitches add up to the circumference: their
            // deviations sum to zero (ISO 1328-1), else the last tooth would not close on the first.
            let sum = cumulative[cumulative.len() - 1];
            let scale: f64 = individual.iter().map(|v| v.abs()).sum();
            if sum.abs() > 1e-9 * scale {
                return err(format!(
                    "{}: the individual pitch deviations sum to {sum:e} m, not 0: around the \
                     gear they must close (or give cumulative_pitch_errors)",
                    f("pitch_errors")
                ));
            }
            cumulative
        }
        (None, Some(cumulative)) => {
            table("cumulative_pitch_errors", cumulative)?;
            cumulative.clone()
        }
        (None, None) => Vec::new(),
    };
    Ok(GearErrors {
        runout,
        cumulative_pitch,
    })
}
