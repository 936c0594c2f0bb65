//! Units at the edges of geardyn: speeds typed on the command line or passed from Python
//! (`4500rpm`, `471.24rad/s`, ranges `1000rpm:10000rpm:181`), and the unit of every output
//! column for CSV headers that carry them (`dte [m]`, `--units`). Inside, everything is SI
//! (`docs/units.md`).
//!
//! A bare number is a speed in rad/s, the unit of the scene files, on every command. A range
//! whose one end has a unit and the other not is refused rather than guessed: `1000:5000rpm`
//! could be a slip for `1000rpm:5000rpm` as easily as it could mean 1000 rad/s.

use std::f64::consts::TAU;

/// rad/s → rpm.
pub fn rpm(speed: f64) -> f64 {
    speed * 60.0 / TAU
}

/// rpm → rad/s.
pub fn from_rpm(rpm: f64) -> f64 {
    rpm * TAU / 60.0
}

/// The unit a speed was written in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SpeedUnit {
    RadPerSecond,
    Rpm,
}

/// The spellings of a speed, for help texts and error messages.
pub const SPEED_SPELLINGS: &str = "4500rpm or 471.24rad/s (a bare number is rad/s)";

/// One speed as written: its value in rad/s and the unit it was given in (`None`: bare).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Written {
    rad_s: f64,
    unit: Option<SpeedUnit>,
}

/// Parses one speed token (`4500rpm`, `471.24rad/s`, `471.24`; space before the unit and
/// upper case allowed). `flag` names the option in messages (`--speed`).
fn written(flag: &str, token: &str) -> Result<Written, String> {
    let t = token.trim();
    let lower = t.to_ascii_lowercase();
    let (number, unit) = if let Some(n) = lower.strip_suffix("rpm") {
        (n, Some(SpeedUnit::Rpm))
    } else if let Some(n) = lower.strip_suffix("rad/s") {
        (n, Some(SpeedUnit::RadPerSecond))
    } else {
        (lower.as_str(), None)
    };
    let value: f64 = number.trim().parse().map_err(|_| {
        if unit.is_none() && t.chars().any(|c| c.is_ascii_alphabetic() || c == '/') {
            format!("{flag} '{t}': unknown unit; write a speed as {SPEED_SPELLINGS}")
        } else {
            format!("{flag} '{t}': not a speed; write it as {SPEED_SPELLINGS}")
        }
    })?;
    if !(value > 0.0 && value.is_finite()) {
        return Err(format!("{flag} '{t}': must be a finite speed > 0"));
    }
    let rad_s = match unit {
        Some(SpeedUnit::Rpm) => from_rpm(value),
        _ => value,
    };
    Ok(Written { rad_s, unit })
}

/// One speed in rad/s from `4500rpm`, `471.24rad/s` or a bare number (rad/s).
pub fn parse_speed(flag: &str, text: &str) -> Result<f64, String> {
    if text.contains(':') {
        return Err(format!(
            "{flag} '{text}': expected one speed, e.g. {SPEED_SPELLINGS}"
        ));
    }
    Ok(written(flag, text)?.rad_s)
}

/// A speed interval `from:to` (rad/s), ends in any unit; an end with a unit and a bare end
/// together are refused.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpeedInterval {
    pub from: f64,
    pub to: f64,
}

/// Parses the two ends of a range; `text` is the whole option value for messages.
fn ends(flag: &str, text: &str, from: &str, to: &str) -> Result<SpeedInterval, String> {
    let (a, b) = (written(flag, from)?, written(flag, to)?);
    if a.unit.is_some() != b.unit.is_some() {
        return Err(format!(
            "{flag} '{text}': give the unit on both ends (e.g. 1000rpm:5000rpm) or on neither \
             (rad/s)"
        ));
    }
    Ok(SpeedInterval {
        from: a.rad_s,
        to: b.rad_s,
    })
}

/// `from:to` (the harmonic-balance branch and the band scan), in rad/s.
pub fn parse_speed_interval(flag: &str, text: &str) -> Result<SpeedInterval, String> {
    match text.split(':').collect::<Vec<_>>()[..] {
        [from, to] => ends(flag, text, from, to),
        _ => Err(format!(
            "{flag} '{text}': expected from:to, e.g. 1000rpm:5000rpm"
        )),
    }
}

/// Most points of a speed sweep: each point is a steady-state run (up to `--max-periods`
/// response periods) and a row of results, so 1e5 points are already hours of work.
pub const MAX_SWEEP_POINTS: usize = 100_000;

/// `from:to:points` of a sweep: `points ≥ 2` evenly spaced speeds (rad/s), `to > from`,
/// `points ≤` [`MAX_SWEEP_POINTS`].
pub fn parse_speed_range(flag: &str, text: &str) -> Result<Vec<f64>, String> {
    let [from, to, points] = text.split(':').collect::<Vec<_>>()[..] else {
        return Err(format!(
            "{flag} '{text}': expected from:to:points, e.g. 1000rpm:10000rpm:181"
        ));
    };
    let SpeedInterval { from, to } = ends(flag, text, from, to)?;
    if !(to > from) {
        return Err(format!(
            "{flag} '{text}': the upper end {} must be greater than the lower end {}",
            both_units(to),
            both_units(from)
        ));
    }
    let points: usize = points
        .trim()
        .parse()
        .map_err(|_| format!("{flag} '{text}': points '{points}' is not a whole number"))?;
    if points < 2 {
        return Err(format!(
            "{flag} '{text}': points = {points}, a sweep needs at least 2"
        ));
    }
    // Checked before the speeds are allocated (issue 34: 1e11 points aborted the process).
    if points > MAX_SWEEP_POINTS {
        return Err(format!(
            "{flag} '{text}': points = {points}, more than the {MAX_SWEEP_POINTS} a sweep may have"
        ));
    }
    Ok((0..points)
        .map(|i| from + (to - from) * i as f64 / (points - 1) as f64)
        .collect())
}

/// A number with six significant digits and no trailing zeros (`104.72`, `10000`).
pub fn significant(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let decimals = (5 - v.abs().log10().floor() as i32).max(0) as usize;
    let s = format!("{v:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// A speed in rad/s written in both units: `471.239 rad/s (4500 rpm)`.
pub fn both_units(speed: f64) -> String {
    format!(
        "{} rad/s ({} rpm)",
        significant(speed),
        significant(rpm(speed))
    )
}

/// The unit of an output column (CSV header, `--units`), by its quantity: the part after the
/// last `.` of an `<owner>.<quantity>` name (`mesh1.force` → `force`, `idler.x` → `x`,
/// `mesh1.pair0.force` → `force`; `docs/fmu.md`), or the whole name of an unowned column
/// (`time`, `speed_rpm`). `1` is dimensionless (the SI unit one, as CF/UDUNITS write it, so
/// the Python module's xarray attributes parse); phases are fractions of a mesh cycle.
pub fn column_unit(name: &str) -> Option<&'static str> {
    quantity_unit(name.rsplit_once('.').map_or(name, |(_, q)| q))
}

/// The unit of each output quantity (the column names of `docs/units.md`).
fn quantity_unit(q: &str) -> Option<&'static str> {
    Some(match q {
        "time" => "s",
        // Displacements along the line of action and bearing translations.
        "dte" | "dte_mean" | "dte_rms" | "dte_peak_to_peak" | "a1" | "a2" | "a3" | "deflection"
        | "static_deflection" | "x" | "y" | "z" => "m",
        "dte_rate" => "m/s",
        "angle" => "rad",
        "force" | "friction_force" | "peak_force" | "force_rms" => "N",
        "stiffness" => "N/m",
        "phase" | "separation_phase" => "cycles",
        "speed" => "rad/s",
        "acceleration" => "rad/s^2",
        "torque" | "drive_torque" => "N.m",
        "speed_rpm" => "rpm",
        "mesh_frequency" => "Hz",
        "contact_state"
        | "pairs_in_contact"
        | "contact_loss_fraction"
        | "dynamic_factor"
        | "direction"
        | "converged"
        | "response_periods"
        | "residual"
        | "transient_periods"
        | "aperiodic"
        | "spectral_radius"
        | "spectral_radius_periods"
        | "stable"
        | "neutral"
        | "fold"
        | "shooting_check"
        | "mesh"
        | "sample"
        | "pairs_loaded" => "1",
        // Per tooth-pair forces of `geardyn stiffness`: `force_<i>`.
        _ if q
            .strip_prefix("force_")
            .is_some_and(|j| !j.is_empty() && j.bytes().all(|b| b.is_ascii_digit())) =>
        {
            "N"
        }
        _ => return None,
    })
}

/// The unit of a scene parameter by its path (`operating.input_speed` → `rad/s`,
/// `gear[1].inertia` → `kg.m^2`, `shaft[0].stiffness` → `N.m/rad`), as the scene format
/// declares it beside each field (`x-unit` in [`crate::scene::schema`]); `1` for counts and
/// ratios; None for a path that is not a number the format knows (a table, a name, a switch,
/// a profile's values, whose unit is the profile's). Units are written as UDUNITS and pint
/// both read them (`N.m`, `kg.m^2`, `degree`).
pub fn parameter_unit(path: &str) -> Option<&'static str> {
    crate::scene::schema::describe(path, None)
        .ok()
        .and_then(|p| p.unit)
}

/// Column names with their units, `dte [m]`; a column without a known unit is an error
/// (every column geardyn writes has one: `tests/units.rs`).
pub fn with_units(columns: &[impl AsRef<str>]) -> Result<Vec<String>, String> {
    columns
        .iter()
        .map(|c| {
            let c = c.as_ref();
            column_unit(c)
                .map(|u| format!("{c} [{u}]"))
                .ok_or_else(|| format!("column '{c}': no unit known for it (src/units.rs)"))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parameters_have_the_units_of_the_scene_format() {
        for (path, unit) in [
            ("operating.pinion_speed", Some("rad/s")),
            ("operating.input_torque", Some("N.m")),
            ("gear[0].teeth", Some("1")),
            ("gear[1].inertia", Some("kg.m^2")),
            ("gear[2].bearing_stiffness[1]", Some("N/m")),
            ("mesh.stiffness.mean", Some("N/m")),
            ("mesh[1].damping", Some("N.s/m")),
            ("shaft[0].damping", Some("N.m.s/rad")),
            ("mesh.pressure_angle", Some("degree")),
            ("gear[0].runout.phase", Some("rad")),
            ("mesh.ste.cos[0]", Some("m")),
            ("operating.speed_profile.values[1]", None),
            ("mesh.contact", None),
            ("gear[0].name", None),
            ("", None),
        ] {
            assert_eq!(parameter_unit(path), unit, "{path}");
        }
    }

    #[test]
    fn rpm_and_rad_s_are_the_same_speed() {
        // 4500 rpm = 4500·2π/60 rad/s = 150π rad/s exactly.
        let w = parse_speed("--speed", "4500rpm").unwrap();
        assert_eq!(w, 4500.0 * TAU / 60.0);
        assert!((w - 150.0 * std::f64::consts::PI).abs() < 1e-12);
        assert_eq!(parse_speed("--speed", "471.24rad/s").unwrap(), 471.24);
        assert_eq!(parse_speed("--speed", "471.24").unwrap(), 471.24);
        assert_eq!(parse_speed("--speed", " 4500 RPM ").unwrap(), w);
    }

    #[test]
    fn ranges_in_either_unit() {
        let r = parse_speed_range("--speed", "1000rpm:10000rpm:181").unwrap();
        assert_eq!(r.len(), 181);
        assert_eq!(r[0], from_rpm(1000.0));
        assert_eq!(r[180], from_rpm(10000.0));
        let mixed = parse_speed_range("--speed", "1000rpm:1047.2rad/s:3").unwrap();
        assert_eq!(mixed[2], 1047.2);
        let i = parse_speed_interval("--speed", "300:600").unwrap();
        assert_eq!((i.from, i.to), (300.0, 600.0));
    }

    #[test]
    fn bad_speeds_name_the_value() {
        for (text, needle) in [
            ("1000rpn:2000rpm:5", "'1000rpn': unknown unit"),
            ("1000:2000rpm:5", "give the unit on both ends"),
            ("2000rpm:1000rpm:5", "must be greater"),
            ("1000rpm:2000rpm:1", "points = 1"),
            ("1000rpm:2000rpm:x", "points 'x'"),
            ("1000rpm:2000rpm", "expected from:to:points"),
            ("0rpm:2000rpm:3", "'0rpm': must be a finite speed > 0"),
            ("-5:20:3", "'-5': must be"),
            ("a:200:3", "'a': unknown unit"),
        ] {
            let err = parse_speed_range("--speed", text).unwrap_err();
            assert!(err.contains(needle), "{text}: {err}");
            assert!(err.starts_with("--speed"), "{text}: {err}");
        }
        let err = parse_speed("--speed", "4500rpm:5000rpm").unwrap_err();
        assert!(err.contains("expected one speed"), "{err}");
        let err = parse_speed("--speed", "nanrpm").unwrap_err();
        assert!(err.contains("'nanrpm'"), "{err}");
    }

    #[test]
    fn both_units_echo() {
        assert_eq!(both_units(from_rpm(4500.0)), "471.239 rad/s (4500 rpm)");
        assert_eq!(both_units(1000.0), "1000 rad/s (9549.3 rpm)");
    }

    #[test]
    fn column_units() {
        let cols = [
            "time",
            "mesh.dte",
            "mesh1.force",
            "mesh1.pair0.force",
            "idler.x",
            "pinion.angle",
            "speed_rpm",
        ];
        assert_eq!(
            with_units(&cols).unwrap(),
            [
                "time [s]",
                "mesh.dte [m]",
                "mesh1.force [N]",
                "mesh1.pair0.force [N]",
                "idler.x [m]",
                "pinion.angle [rad]",
                "speed_rpm [rpm]"
            ]
        );
        assert!(with_units(&["mesh1.bogus"])
            .unwrap_err()
            .contains("'mesh1.bogus'"));
        // An old underscored name has no unit: every column follows `<owner>.<quantity>`.
        assert!(with_units(&["mesh1_force"]).is_err());
    }
}
