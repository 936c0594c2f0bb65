//! The field checks every scene validation shares: numbers, counts and the tables that read
//! the same in every scene (`[solver]`, `[initial]`). Each message names the field as a TOML
//! path and its value; nothing is clamped.

use crate::scene::schema;
use crate::scene::spec::{InitialDteSpec, SolverSpec};
use crate::scene::{InitialDte, MethodChoice, SceneError, SolverSettings};

type Result<T> = std::result::Result<T, SceneError>;

pub(crate) fn err<T>(msg: String) -> Result<T> {
    Err(SceneError(msg))
}

/// `field = value` within the bounds the scene format declares beside the field
/// ([`crate::scene::schema`]: `> 0`, `>= 0 and <= 1`, …), so a bound is written once and
/// `scene.describe` shows the one validation applies. A field without declared bounds is an
/// error of the program, not of the scene: validating it here would let anything finite pass.
pub(crate) fn bounded(field: &str, value: f64) -> Result<f64> {
    let bounds = schema::bounds_of(field).map_err(|e| SceneError(format!("internal: {e}")))?;
    if bounds.is_open() {
        return err(format!(
            "internal: {field} has no bounds in the scene format (src/scene/spec)"
        ));
    }
    if bounds.contains(value) {
        Ok(value)
    } else {
        err(format!(
            "{field} = {value}: must be a finite number {bounds}"
        ))
    }
}

pub(crate) fn finite(field: &str, value: f64) -> Result<f64> {
    if value.is_finite() {
        Ok(value)
    } else {
        err(format!("{field} = {value}: must be a finite number"))
    }
}

pub(crate) fn finite_list(field: &str, values: &[f64]) -> Result<()> {
    for (i, &v) in values.iter().enumerate() {
        finite(&format!("{field}[{i}]"), v)?;
    }
    Ok(())
}

/// Most teeth on a gear: far beyond any real gear, and small enough that tooth counts, mesh
/// cycles per revolution and their products stay exact in a double.
pub(crate) const MAX_TEETH: i64 = 100_000;

/// Most harmonics in a Fourier list (STE, Fourier stiffness): each harmonic adds two states to
/// the exact propagator's dense matrices, whose memory grows with their square; 256 (as for
/// the `geometry` stiffness' `harmonics`) is far beyond any measured STE spectrum.
pub(crate) const MAX_HARMONICS: usize = 256;

/// A tooth count: an integer in `1..=MAX_TEETH`.
pub(crate) fn teeth(field: &str, value: i64) -> Result<u32> {
    if value < 1 {
        err(format!("{field} = {value}: must be an integer >= 1"))
    } else if value > MAX_TEETH {
        err(format!(
            "{field} = {value}: too large, must be at most {MAX_TEETH} teeth"
        ))
    } else {
        Ok(value as u32)
    }
}

/// A list of Fourier coefficients: finite, and at most [`MAX_HARMONICS`] of them (checked
/// before anything is sized by the list).
pub(crate) fn harmonic_list(field: &str, values: &[f64]) -> Result<()> {
    if values.len() > MAX_HARMONICS {
        return err(format!(
            "{field}: {} harmonics given; at most {MAX_HARMONICS} are allowed",
            values.len()
        ));
    }
    finite_list(field, values)
}

/// Checks that a gear's base radius and inertia give a usable compliance `r_b²/I` (1/kg on
/// the line of action): a positive normal double, so that the equivalent mass and every
/// mass-matrix entry built from it are neither zero nor infinite. `field` is the gear's TOML
/// path (`gear[0]`).
pub(crate) fn gear_compliance(field: &str, base_radius: f64, inertia: f64) -> Result<f64> {
    let c = base_radius.powi(2) / inertia;
    if c.is_normal() && c > 0.0 {
        Ok(c)
    } else {
        err(format!(
            "{field}.base_radius = {base_radius:e} with {field}.inertia = {inertia:e}: r_b²/I = {c:e} 1/kg \
             is outside the range of a double; the base radius or the inertia is not physical"
        ))
    }
}

/// Largest mesh damping ratio `c/(2·sqrt(k̄ m_e))`: measured mesh damping ratios lie between
/// 0.01 and 0.2; beyond 100 the mesh is a dashpot whose fast and slow time scales differ by
/// `4ζ² = 4e4`, which makes any run stiff and tells of a unit error.
pub(crate) const MAX_DAMPING_RATIO: f64 = 100.0;

/// Checks the mesh damping against [`MAX_DAMPING_RATIO`]; `field` is the field that gave it
/// (`damping` in N·s/m or `damping_ratio`).
pub(crate) fn damping_ratio_range(field: &str, c: f64, k_mean: f64, m_e: f64) -> Result<()> {
    let zeta = c / (2.0 * (k_mean * m_e).sqrt());
    if zeta <= MAX_DAMPING_RATIO {
        Ok(())
    } else {
        err(format!(
            "{field}: the mesh damping {c:e} N·s/m is a damping ratio of {zeta:e} on the mean stiffness \
             {k_mean:e} N/m and the equivalent mass {m_e:e} kg; it must be at most {MAX_DAMPING_RATIO}"
        ))
    }
}

/// Checks the mesh time scales that the model's arithmetic needs finite: the natural
/// frequency `sqrt(k_max/m_e)` and the damping rate `c/m_e` (`field_k`, `field_c` name the
/// stiffness and the damping in messages).
pub(crate) fn mesh_rates(field_k: &str, k_max: f64, field_c: &str, c: f64, m_e: f64) -> Result<()> {
    let omega2 = k_max / m_e;
    if !omega2.is_finite() {
        return err(format!(
            "{field_k}: the stiffness {k_max:e} N/m on the equivalent mass {m_e:e} kg gives a natural \
             frequency outside the range of a double"
        ));
    }
    let rate = c / m_e;
    if !rate.is_finite() {
        return err(format!(
            "{field_c}: the damping {c:e} N·s/m on the equivalent mass {m_e:e} kg gives a decay rate \
             outside the range of a double"
        ));
    }
    Ok(())
}

pub(crate) fn valid_identifier(name: &str) -> bool {
    let mut chars = name.chars();
    matches!(chars.next(), Some(c) if c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// The `[solver]` table (single-mesh and drivetrain scenes alike).
pub(crate) fn solver(s: &SolverSpec) -> Result<SolverSettings> {
    let method = s
        .method
        .parse::<MethodChoice>()
        .map_err(|e| SceneError(format!("solver.method = {:?}: {e}", s.method)))?;
    let rk_method = s
        .rk_method
        .parse()
        .map_err(|e| SceneError(format!("solver.rk_method = {:?}: {e}", s.rk_method)))?;
    let stop_time = bounded("solver.stop_time", s.stop_time)?;
    let output_interval = match s.output_interval {
        Some(h) => bounded("solver.output_interval", h)?,
        None => stop_time / 500.0,
    };
    Ok(SolverSettings {
        method,
        rk_method,
        rtol: bounded("solver.rtol", s.rtol)?,
        atol: bounded("solver.atol", s.atol)?,
        stop_time,
        output_interval,
        work_budget: s
            .work_budget
            .map(|x| crate::simulation::budget::check_limit("solver.work_budget", x))
            .transpose()
            .map_err(SceneError)?,
        exact_memory: s.exact_memory_mb.map(exact_memory).transpose()?,
    })
}

/// `solver.exact_memory_mb` in bytes (its bounds, 1 MiB to 2^40 bytes, beside the field).
fn exact_memory(mb: f64) -> Result<usize> {
    let mb = bounded("solver.exact_memory_mb", mb)?;
    Ok((mb * (1u64 << 20) as f64) as usize)
}

/// `initial.dte`: `"static"` or a number in m (both scene formats).
pub(crate) fn initial_dte(spec: &InitialDteSpec) -> Result<InitialDte> {
    match spec {
        InitialDteSpec::Value(v) => Ok(InitialDte::Value(finite("initial.dte", *v)?)),
        InitialDteSpec::Keyword(k) if k == "static" => Ok(InitialDte::Static),
        InitialDteSpec::Keyword(k) => err(format!(
            "initial.dte = {k:?}: must be \"static\" or a number in m"
        )),
    }
}
