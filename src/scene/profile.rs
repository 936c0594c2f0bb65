//! Speed and torque profiles over time (`[operating.speed_profile]`,
//! `[operating.torque_profile]`, both scene formats): a linear ramp or a table, linear between
//! the knots and held constant outside them. Specified in `docs/runup.md`.

use schemars::JsonSchema;
use serde::Deserialize;

use super::SceneError;

/// A profile as written in the scene file.
#[derive(Debug, Clone, Deserialize, JsonSchema)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum ProfileSpec {
    /// `from` until `start`, linear to `to` at `end`, `to` after.
    Ramp {
        from: f64,
        to: f64,
        start: f64,
        end: f64,
    },
    /// Knots `(times[i], values[i])`, times strictly increasing.
    Table { times: Vec<f64>, values: Vec<f64> },
}

/// A validated piecewise-linear function of time: knots `(times[i], values[i])` with strictly
/// increasing finite times (at least two), linear in between, held constant before the first
/// and after the last knot.
#[derive(Debug, Clone, PartialEq)]
pub struct Profile {
    times: Vec<f64>,
    values: Vec<f64>,
}

impl Profile {
    /// Validates `spec` (the field `field`, e.g. `operating.speed_profile`); `non_negative`
    /// refuses negative values (speeds: the mesh phase runs forward).
    pub fn new(field: &str, spec: &ProfileSpec, non_negative: bool) -> Result<Profile, SceneError> {
        let (times, values) = match spec {
            ProfileSpec::Ramp {
                from,
                to,
                start,
                end,
            } => {
                for (key, v) in [("from", from), ("to", to), ("start", start), ("end", end)] {
                    if !v.is_finite() {
                        return Err(SceneError(format!(
                            "{field}.{key} = {v}: must be a finite number"
                        )));
                    }
                }
                if !(end > start) {
                    return Err(SceneError(format!(
                        "{field}: end = {end} s is not after start = {start} s (a ramp must go \
                         forward in time)"
                    )));
                }
                (vec![*start, *end], vec![*from, *to])
            }
            ProfileSpec::Table { times, values } => {
                if times.len() != values.len() {
                    return Err(SceneError(format!(
                        "{field}: times has {} entries, values {} (one value per time)",
                        times.len(),
                        values.len()
                    )));
                }
                if times.len() < 2 {
                    return Err(SceneError(format!(
                        "{field}: {} knot(s); a table needs at least two (a constant is the \
                         operating value itself)",
                        times.len()
                    )));
                }
                for (i, t) in times.iter().enumerate() {
                    if !t.is_finite() {
                        return Err(SceneError(format!(
                            "{field}.times[{i}] = {t}: must be a finite number"
                        )));
                    }
                    if i > 0 && !(*t > times[i - 1]) {
                        return Err(SceneError(format!(
                            "{field}.times[{i}] = {t} s is not after times[{}] = {} s (times must \
                             increase strictly: a profile cannot go back in time)",
                            i - 1,
                            times[i - 1]
                        )));
                    }
                }
                for (i, v) in values.iter().enumerate() {
                    if !v.is_finite() {
                        return Err(SceneError(format!(
                            "{field}.values[{i}] = {v}: must be a finite number"
                        )));
                    }
                }
                (times.clone(), values.clone())
            }
        };
        if non_negative {
            if let Some((i, v)) = values.iter().enumerate().find(|(_, v)| **v < 0.0) {
                let key = match spec {
                    ProfileSpec::Ramp { .. } => ["from", "to"][i].to_owned(),
                    ProfileSpec::Table { .. } => format!("values[{i}]"),
                };
                return Err(SceneError(format!(
                    "{field}.{key} = {v}: a speed must be >= 0 (the mesh phase runs forward)"
                )));
            }
        }
        Ok(Profile { times, values })
    }

    /// The knot times, s.
    pub fn times(&self) -> &[f64] {
        &self.times
    }

    /// The knot values.
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// Value and slope (per second) of the piece that starts at or before `t` and continues
    /// after it (right-continuous: at a knot, the piece after it). The value at a knot is the
    /// knot's value exactly, so re-anchoring at knots accumulates no rounding.
    pub fn segment_at(&self, t: f64) -> (f64, f64) {
        let n = self.times.len();
        // Index of the last knot at or before t.
        let i = self.times.partition_point(|&k| k <= t);
        if i == 0 {
            return (self.values[0], 0.0);
        }
        if i == n {
            return (self.values[n - 1], 0.0);
        }
        let (t0, t1) = (self.times[i - 1], self.times[i]);
        let (v0, v1) = (self.values[i - 1], self.values[i]);
        let slope = (v1 - v0) / (t1 - t0);
        let value = if t == t0 { v0 } else { v0 + slope * (t - t0) };
        (value, slope)
    }

    /// The value at `t`.
    pub fn value_at(&self, t: f64) -> f64 {
        self.segment_at(t).0
    }

    /// The first knot strictly after `t` (`+inf` after the last).
    pub fn next_knot(&self, t: f64) -> f64 {
        let i = self.times.partition_point(|&k| k <= t);
        self.times.get(i).copied().unwrap_or(f64::INFINITY)
    }

    /// The first knot strictly after `t` where the slope changes (`+inf` if none): the
    /// knots the driver must stop at. A constant profile has none, so it runs exactly as the
    /// constant operating point it equals.
    pub fn next_change(&self, t: f64) -> f64 {
        let n = self.times.len();
        let slope = |i: usize| -> f64 {
            // Slope of the piece that starts at knot i (0 before the first and after the last).
            if i + 1 >= n {
                0.0
            } else {
                (self.values[i + 1] - self.values[i]) / (self.times[i + 1] - self.times[i])
            }
        };
        let mut i = self.times.partition_point(|&k| k <= t);
        while i < n {
            let before = if i == 0 { 0.0 } else { slope(i - 1) };
            if before.to_bits() != slope(i).to_bits() {
                return self.times[i];
            }
            i += 1;
        }
        f64::INFINITY
    }

    /// Largest value over all time.
    pub fn max_value(&self) -> f64 {
        self.values
            .iter()
            .copied()
            .fold(f64::NEG_INFINITY, f64::max)
    }
}

/// The time-varying operating inputs of a scene: a run-up or run-down (`docs/runup.md`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Profiles {
    /// Nominal speed of the pinion / input gear, rad/s.
    pub speed: Option<Profile>,
    /// Input torque, N·m.
    pub torque: Option<Profile>,
    /// With a torque profile and no `load_torque` given: the balanced load follows the input
    /// torque, `T_load = load_ratio · T_in` (the ratio of the static balance).
    pub load_ratio: Option<f64>,
}

/// The operating point the profiles give on the piece starting at `t`: each value with its
/// rate per second. The load is `None` when it is a constant of the scene.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OperatingPiece {
    pub speed: (f64, f64),
    pub torque: (f64, f64),
    pub load: Option<(f64, f64)>,
}

impl Profiles {
    /// The piece of the operating point at `t`, with `speed` and `torque` the scene's
    /// constants where it has no profile (one rule for the pair and the drivetrain kernels).
    pub fn piece_at(&self, t: f64, speed: f64, torque: f64) -> OperatingPiece {
        let speed = self
            .speed
            .as_ref()
            .map_or((speed, 0.0), |p| p.segment_at(t));
        let torque = self
            .torque
            .as_ref()
            .map_or((torque, 0.0), |p| p.segment_at(t));
        let load = self
            .load_ratio
            .map(|ratio| (torque.0 * ratio, torque.1 * ratio));
        OperatingPiece {
            speed,
            torque,
            load,
        }
    }

    /// Whether a profile varies over time (has a knot where its slope changes); a constant
    /// profile is the operating point it equals.
    pub fn speed_varies(&self) -> bool {
        self.speed
            .as_ref()
            .is_some_and(|p| p.next_change(f64::NEG_INFINITY) < f64::INFINITY)
    }

    /// See [`Profiles::speed_varies`].
    pub fn torque_varies(&self) -> bool {
        self.torque
            .as_ref()
            .is_some_and(|p| p.next_change(f64::NEG_INFINITY) < f64::INFINITY)
    }

    /// Why a run-up makes a scene whose segments are LTI at constant speed not piecewise
    /// LTI: `ste` (the scene has an STE or another phase-periodic excitation in the exact
    /// propagator's augmented state) and `phase_ramp` (gaps affine in the phase).
    pub fn not_lti_reason(&self, ste: bool, phase_ramp: bool) -> Option<String> {
        if self.torque_varies() {
            return Some(
                "operating.torque_profile makes the external force vary within a stiffness \
                 segment (linear in time), so the segments are not time-invariant"
                    .into(),
            );
        }
        if self.speed_varies() && ste {
            return Some(
                "with operating.speed_profile the STE excitation is a chirp (its frequency \
                 varies within a segment), so the segments are not time-invariant"
                    .into(),
            );
        }
        if self.speed_varies() && phase_ramp {
            return Some(
                "with operating.speed_profile the tooth-pair gaps (tip relief) vary \
                 quadratically in time within a segment, so the segments are not time-invariant"
                    .into(),
            );
        }
        None
    }

    /// Whether the scene has any profile.
    pub fn any(&self) -> bool {
        self.speed.is_some() || self.torque.is_some()
    }

    /// The first knot of any profile strictly after `t` where a slope changes
    /// ([`Profile::next_change`]).
    pub fn next_change(&self, t: f64) -> f64 {
        let s = self
            .speed
            .as_ref()
            .map_or(f64::INFINITY, |p| p.next_change(t));
        let q = self
            .torque
            .as_ref()
            .map_or(f64::INFINITY, |p| p.next_change(t));
        s.min(q)
    }

    /// The keys of the profiles present (for messages of tools that need a constant
    /// operating point).
    pub fn keys(&self) -> String {
        let mut k = Vec::new();
        if self.speed.is_some() {
            k.push("operating.speed_profile");
        }
        if self.torque.is_some() {
            k.push("operating.torque_profile");
        }
        k.join(" and ")
    }

    /// Refuses the scene as an FMU: an FMU takes speed and torque as inputs from its host
    /// (`docs/runup.md`, "FMUs"), so a profile in the scene would compete with them.
    pub fn refuse_in_fmu(&self) -> Result<(), String> {
        if self.any() {
            Err(format!(
                "the scene has {}: an FMU takes its speed and torque as inputs from the host, so \
                 it cannot carry a profile; remove it and drive the inputs from the host (e.g. \
                 an input CSV), or run the profile natively with `geardyn simulate`",
                self.keys()
            ))
        } else {
            Ok(())
        }
    }

    /// Refuses the scene for `tool`, which needs a constant operating point, when it has a
    /// profile.
    pub fn require_constant(&self, tool: &str) -> Result<(), String> {
        if self.any() {
            Err(format!(
                "{tool} needs a constant operating point, and this scene has {} (a run-up has no \
                 periodic steady state); give a constant speed and torque in [operating] \
                 instead, or run the run-up with `geardyn simulate` (its order map: `geardyn waterfall`)",
                self.keys()
            ))
        } else {
            Ok(())
        }
    }
}

/// Validates the two profile keys of `[operating]` (both scene formats).
pub(crate) fn profiles(
    speed: &Option<ProfileSpec>,
    torque: &Option<ProfileSpec>,
) -> Result<Profiles, SceneError> {
    Ok(Profiles {
        speed: speed
            .as_ref()
            .map(|s| Profile::new("operating.speed_profile", s, true))
            .transpose()?,
        torque: torque
            .as_ref()
            .map(|s| Profile::new("operating.torque_profile", s, false))
            .transpose()?,
        load_ratio: None,
    })
}

/// Resolves `value` (`name`, e.g. `operating.pinion_speed`) against an optional profile
/// (`profile_field`): exactly one of them must be given; with a profile the value is the
/// profile's at t = 0.
pub(crate) fn resolve(
    name: &str,
    value: Option<f64>,
    profile_field: &str,
    profile: Option<&Profile>,
) -> Result<f64, SceneError> {
    match (value, profile) {
        (Some(v), None) => Ok(v),
        (None, Some(p)) => Ok(p.value_at(0.0)),
        (Some(v), Some(_)) => Err(SceneError(format!(
            "{name} = {v} and {profile_field} are both given: the profile sets the value over \
             time (its value at t = 0 is the initial one); remove {name}"
        ))),
        (None, None) => Err(SceneError(format!(
            "{name} is missing (give it, or {profile_field})"
        ))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(times: &[f64], values: &[f64]) -> ProfileSpec {
        ProfileSpec::Table {
            times: times.to_vec(),
            values: values.to_vec(),
        }
    }

    #[test]
    fn interpolates_and_holds() {
        let p = Profile::new("p", &table(&[1.0, 3.0, 4.0], &[10.0, 30.0, 0.0]), true).unwrap();
        assert_eq!(p.segment_at(0.0), (10.0, 0.0));
        assert_eq!(p.segment_at(1.0), (10.0, 10.0));
        assert_eq!(p.segment_at(2.0), (20.0, 10.0));
        assert_eq!(p.segment_at(3.0), (30.0, -30.0));
        assert_eq!(p.segment_at(4.0), (0.0, 0.0));
        assert_eq!(p.segment_at(9.0), (0.0, 0.0));
        assert_eq!(p.next_knot(-1.0), 1.0);
        assert_eq!(p.next_knot(1.0), 3.0);
        assert_eq!(p.next_knot(4.0), f64::INFINITY);
        assert_eq!(p.next_change(-1.0), 1.0);
        let c = Profile::new("p", &table(&[1.0, 3.0, 4.0], &[5.0, 5.0, 5.0]), true).unwrap();
        assert_eq!(c.next_change(-1.0), f64::INFINITY);
        let l = Profile::new("p", &table(&[0.0, 1.0, 2.0], &[0.0, 1.0, 2.0]), true).unwrap();
        assert_eq!(l.next_change(0.5), 2.0);
    }

    #[test]
    fn rejects_with_the_field_and_value() {
        let e = |spec: ProfileSpec, nn: bool| Profile::new("op.p", &spec, nn).unwrap_err().0;
        let back = e(
            ProfileSpec::Ramp {
                from: 0.0,
                to: 1.0,
                start: 2.0,
                end: 1.0,
            },
            true,
        );
        assert!(
            back.contains("op.p: end = 1 s is not after start = 2 s"),
            "{back}"
        );
        let back = e(table(&[0.0, 2.0, 1.5], &[1.0, 2.0, 3.0]), true);
        assert!(
            back.contains("op.p.times[2] = 1.5 s is not after times[1] = 2 s"),
            "{back}"
        );
        let nan = e(table(&[0.0, 1.0], &[1.0, f64::NAN]), true);
        assert!(nan.contains("op.p.values[1] = NaN"), "{nan}");
        let neg = e(table(&[0.0, 1.0], &[1.0, -2.0]), true);
        assert!(
            neg.contains("op.p.values[1] = -2: a speed must be >= 0"),
            "{neg}"
        );
        assert!(Profile::new("t", &table(&[0.0, 1.0], &[1.0, -2.0]), false).is_ok());
        let len = e(table(&[0.0, 1.0, 2.0], &[1.0, 2.0]), true);
        assert!(len.contains("times has 3 entries, values 2"), "{len}");
        let inf = e(
            ProfileSpec::Ramp {
                from: 0.0,
                to: f64::INFINITY,
                start: 0.0,
                end: 1.0,
            },
            true,
        );
        assert!(
            inf.contains("op.p.to = inf: must be a finite number"),
            "{inf}"
        );
    }
}
