//! Turns a parsed [`SceneSpec`] into a validated [`Scene`]: ranges, consistency, defaults.
//! Every message names the field as a TOML path and its value; nothing is clamped.

use super::spec::{ContactLawSpec, InitialDteSpec, SceneSpec, StiffnessSpec};
use super::SmoothTerms;
use super::{
    ContactLaw, Gear, InitialDte, Mesh, MethodChoice, Operating, Scene, SceneError, SolverSettings,
};
use crate::mesh::{MeshStiffness, PhaseSeries};

type Result<T> = std::result::Result<T, SceneError>;

pub(super) fn err<T>(msg: String) -> Result<T> {
    Err(SceneError(msg))
}

/// `field = value: must be finite and > 0`.
pub(super) fn positive(field: &str, value: f64) -> Result<f64> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        err(format!("{field} = {value}: must be a finite number > 0"))
    }
}

pub(super) fn non_negative(field: &str, value: f64) -> Result<f64> {
    if value.is_finite() && value >= 0.0 {
        Ok(value)
    } else {
        err(format!("{field} = {value}: must be a finite number >= 0"))
    }
}

pub(super) fn finite(field: &str, value: f64) -> Result<f64> {
    if value.is_finite() {
        Ok(value)
    } else {
        err(format!("{field} = {value}: must be a finite number"))
    }
}

fn finite_list(field: &str, values: &[f64]) -> Result<()> {
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

fn valid_identifier(name: &str) -> bool {
    let mut chars = name.chars();
    matches!(chars.next(), Some(c) if c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

pub(super) fn validate(spec: SceneSpec, source: &str) -> Result<Scene> {
    if !valid_identifier(&spec.name) {
        return err(format!(
            "name = {:?}: must be an identifier ([A-Za-z_][A-Za-z0-9_]*), it names the FMU",
            spec.name
        ));
    }
    if spec.gear.len() != 2 {
        return err(format!(
            "gear: {} [[gear]] tables given; a single-mesh scene needs exactly 2",
            spec.gear.len()
        ));
    }
    let m = &spec.mesh;
    // A geometry stiffness defines what the gear bodies need (docs/model.md, "Gears: base
    // radius and inertia from the geometry").
    let bodies = super::geometry::bodies(&m.stiffness, "mesh.stiffness")?;
    let mut gears = Vec::with_capacity(2);
    for (i, g) in spec.gear.iter().enumerate() {
        let field = |f: &str| format!("gear[{i}].{f}");
        if g.name.is_empty() {
            return err(format!("{} = \"\": must not be empty", field("name")));
        }
        let table = format!("gear[{i}]");
        let derived = bodies.as_ref().and_then(|[p, q]| {
            if g.name == m.pinion {
                Some(p)
            } else if g.name == m.gear {
                Some(q)
            } else {
                None
            }
        });
        let gear = Gear {
            name: g.name.clone(),
            teeth: teeth(&field("teeth"), g.teeth)?,
            base_radius: super::geometry::base_radius(&table, g.base_radius, derived)?,
            inertia: super::geometry::body_value(
                &table,
                "inertia",
                g.inertia,
                derived.map(|d| (d, d.inertia)),
            )?,
        };
        let errors = crate::scene::train::validate::gear_errors(
            &field,
            &g.name,
            gear.teeth,
            crate::scene::train::validate::ErrorKeys {
                runout: &g.runout,
                pitch_errors: &g.pitch_errors,
                cumulative_pitch_errors: &g.cumulative_pitch_errors,
            },
        )?;
        if !errors.is_zero() {
            // Only a caller that bypasses the format detection gets here.
            return err(format!(
                "{}: gear {:?} has non-zero runout or pitch errors, which the drivetrain kernel \
                 carries: read the scene as a drivetrain (geardyn does so for every command)",
                field("runout"),
                g.name
            ));
        }
        gear_compliance(&format!("gear[{i}]"), gear.base_radius, gear.inertia)?;
        gears.push(gear);
    }
    if gears[0].name == gears[1].name {
        return err(format!(
            "gear[1].name = {:?}: duplicates gear[0].name",
            gears[1].name
        ));
    }
    let find = |field: &str, name: &str| -> Result<Gear> {
        gears
            .iter()
            .find(|g| g.name == name)
            .cloned()
            .ok_or_else(|| {
                SceneError(format!(
                    "{field} = {name:?}: no gear of that name (gears: {:?}, {:?})",
                    gears[0].name, gears[1].name
                ))
            })
    };
    let pinion = find("mesh.pinion", &m.pinion)?;
    let gear = find("mesh.gear", &m.gear)?;
    if pinion.name == gear.name {
        return err(format!(
            "mesh.gear = {:?}: the same gear as mesh.pinion",
            m.gear
        ));
    }

    let profiles = super::profile::profiles(
        &spec.operating.speed_profile,
        &spec.operating.torque_profile,
    )?;
    let pinion_speed = super::profile::resolve(
        "operating.pinion_speed",
        spec.operating.pinion_speed,
        "operating.speed_profile",
        profiles.speed.as_ref(),
    )?;
    let input_torque = super::profile::resolve(
        "operating.input_torque",
        spec.operating.input_torque,
        "operating.torque_profile",
        profiles.torque.as_ref(),
    )?;

    let stiffness = match &m.stiffness {
        StiffnessSpec::Geometry { .. } => {
            fn body<'a>(which: &str, g: &'a Gear) -> super::geometry::MeshGear<'a> {
                super::geometry::MeshGear {
                    which: which.to_owned(),
                    name: &g.name,
                    teeth: g.teeth,
                    base_radius: g.base_radius,
                }
            }
            super::geometry::stiffness(
                &m.stiffness,
                "mesh.stiffness",
                [body("mesh.pinion", &pinion), body("mesh.gear", &gear)],
                ("operating.input_torque", input_torque),
            )?
        }
        StiffnessSpec::Helical { .. } => super::helical::stiffness(&m.stiffness, &pinion, &gear)?,
        other => stiffness(other)?,
    };
    let (k_min, s_min) = stiffness.minimum();
    if !(k_min > 0.0) {
        return err(format!(
            "mesh.stiffness: the stiffness reaches {k_min:e} N/m at shifted phase {s_min}; it must stay > 0"
        ));
    }
    let k_mean = stiffness.mean();

    let contact =
        match (m.contact, m.backlash) {
            (ContactLawSpec::Backlash, Some(b)) => ContactLaw::Backlash {
                clearance: non_negative("mesh.backlash", b)?,
            },
            (ContactLawSpec::Backlash, None) => return err(
                "mesh.backlash: missing; contact = \"backlash\" needs the total clearance 2b in m"
                    .into(),
            ),
            (other, Some(b)) => {
                return err(format!(
            "mesh.backlash = {b}: only allowed with contact = \"backlash\" (contact is {other:?})"
        ))
            }
            (ContactLawSpec::Linear, None) => ContactLaw::Linear,
            (ContactLawSpec::ContactLoss, None) => ContactLaw::ContactLoss,
        };

    let m_e = super::equivalent_mass(&pinion, &gear);
    let damping = match (m.damping, m.damping_ratio) {
        (Some(c), None) => non_negative("mesh.damping", c)?,
        (None, Some(zeta)) => {
            2.0 * non_negative("mesh.damping_ratio", zeta)? * (k_mean * m_e).sqrt()
        }
        (None, None) => 0.0,
        (Some(_), Some(_)) => {
            return err("mesh.damping and mesh.damping_ratio: give one of them, not both".into())
        }
    };
    let damping_field = if m.damping.is_some() {
        "mesh.damping"
    } else {
        "mesh.damping_ratio"
    };
    let k_max = stiffness.maximum();
    mesh_rates("mesh.stiffness", k_max, damping_field, damping, m_e)?;
    damping_ratio_range(damping_field, damping, k_mean, m_e)?;

    let damping_always = match m.damping_acts.as_deref() {
        None | Some("in_contact") => false,
        Some("always") => true,
        Some(other) => {
            return err(format!(
                "mesh.damping_acts = \"{other}\": expected \"in_contact\" or \"always\""
            ))
        }
    };

    let smooth = SmoothTerms {
        cubic_factor: match &m.cubic {
            Some(c) => non_negative("mesh.cubic.stiffness_factor", c.stiffness_factor)?,
            None => 0.0,
        },
        cubic_spring: match &m.cubic {
            Some(c) => non_negative("mesh.cubic.spring", c.spring)?,
            None => 0.0,
        },
        damping_variation: match m.damping_variation {
            Some(v) => {
                let v = finite("mesh.damping_variation", v)?;
                if v.abs() > damping {
                    return err(format!(
                        "mesh.damping_variation = {v}: |c̃| must not exceed the damping {damping} \
                         N·s/m (the damping would turn negative)"
                    ));
                }
                v
            }
            None => 0.0,
        },
        torque_ripple: match spec.operating.torque_ripple {
            Some(t) => finite("operating.torque_ripple", t)?,
            None => 0.0,
        },
    };
    if (m.cubic.is_some() || m.damping_variation.is_some()) && contact != ContactLaw::Linear {
        return err(format!(
            "mesh.cubic / mesh.damping_variation: only with contact = \"linear\" (the cubic \
             spring models the backlash, Bugaru 2006); contact is {contact:?}"
        ));
    }

    let ste = match &m.ste {
        Some(series) => {
            harmonic_list("mesh.ste.cos", &series.cos)?;
            harmonic_list("mesh.ste.sin", &series.sin)?;
            PhaseSeries::new(&series.cos, &series.sin)
        }
        None => PhaseSeries::default(),
    };

    let op = &spec.operating;
    let pinion_speed = non_negative("operating.pinion_speed", pinion_speed)?;
    let input_torque = finite("operating.input_torque", input_torque)?;
    let load_torque = match op.load_torque {
        Some(t) => finite("operating.load_torque", t)?,
        None => input_torque * gear.base_radius / pinion.base_radius,
    };
    let mut profiles = profiles;
    if op.load_torque.is_none() && profiles.torque.is_some() {
        profiles.load_ratio = Some(gear.base_radius / pinion.base_radius);
    }

    // A static deflection of a whole tooth means the load or the stiffness is not physical
    // (and a cubic spring would stiffen the mesh without bound).
    let ripple = smooth.torque_ripple.abs();
    // A profile's extremes are at its knots: the bound holds at every torque it reaches.
    let (t_abs, load_abs) = match (&profiles.torque, profiles.load_ratio) {
        (Some(p), ratio) => {
            let t = p.values().iter().fold(0.0f64, |a, v| a.max(v.abs()));
            (t, ratio.map_or(load_torque.abs(), |r| t * r))
        }
        (None, _) => (input_torque.abs(), load_torque.abs()),
    };
    let force = ((t_abs + ripple) / pinion.base_radius).max(load_abs / gear.base_radius);
    let deflection = force / k_mean;
    let base_pitch = std::f64::consts::TAU * pinion.base_radius / f64::from(pinion.teeth);
    if !(deflection <= base_pitch) {
        return err(format!(
            "operating.input_torque = {input_torque:e} N·m (torque_ripple {ripple:e} N·m), load torque \
             {load_torque:e} N·m: the static mesh deflection {deflection:e} m (mesh force {force:e} N on the mean stiffness \
             {k_mean:e} N/m, base radii {:e} and {:e} m) exceeds the base pitch {base_pitch:e} m, a \
             whole tooth",
            pinion.base_radius, gear.base_radius
        ));
    }

    let initial_dte = initial_dte(&spec.initial.dte)?;

    let solver = solver(&spec.solver)?;
    if solver.method == MethodChoice::Exact && !stiffness.is_piecewise_constant() {
        return err(format!(
            "solver.method = \"exact\": the {} stiffness is not piecewise constant, so its segments are not \
             time-invariant; use \"rk\" or \"auto\"",
            stiffness_kind(&m.stiffness)
        ));
    }

    Ok(Scene {
        name: spec.name,
        description: spec.description,
        pinion,
        gear,
        mesh: Mesh {
            contact,
            stiffness,
            ste,
            damping,
            damping_always,
            smooth,
            initial_phase: finite("mesh.initial_phase", m.initial_phase)?,
        },
        operating: Operating {
            pinion_speed,
            input_torque,
            load_torque,
        },
        profiles,
        initial_dte,
        initial_dte_rate: finite("initial.dte_rate", spec.initial.dte_rate)?,
        solver,
        source: source.to_owned(),
    })
}

/// The `[solver]` table (single-mesh and drivetrain scenes alike).
pub(super) fn solver(s: &super::spec::SolverSpec) -> Result<SolverSettings> {
    let method = s
        .method
        .parse::<MethodChoice>()
        .map_err(|e| SceneError(format!("solver.method = {:?}: {e}", s.method)))?;
    let rk_method = s
        .rk_method
        .parse()
        .map_err(|e| SceneError(format!("solver.rk_method = {:?}: {e}", s.rk_method)))?;
    let stop_time = positive("solver.stop_time", s.stop_time)?;
    let output_interval = match s.output_interval {
        Some(h) => positive("solver.output_interval", h)?,
        None => stop_time / 500.0,
    };
    let rtol = positive("solver.rtol", s.rtol)?;
    if rtol >= 1.0 {
        return err(format!("solver.rtol = {rtol}: must be < 1"));
    }
    Ok(SolverSettings {
        method,
        rk_method,
        rtol,
        atol: positive("solver.atol", s.atol)?,
        stop_time,
        output_interval,
        work_budget: s
            .work_budget
            .map(|x| crate::simulation::budget::check_limit("solver.work_budget", x))
            .transpose()
            .map_err(SceneError)?,
    })
}

fn stiffness_kind(spec: &StiffnessSpec) -> &'static str {
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
    positive("mesh.stiffness.mean", mean)?;
    non_negative("mesh.stiffness.peak_to_peak_ratio", ratio)?;
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
            MeshStiffness::constant(positive("mesh.stiffness.value", *value)?)
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
            positive("mesh.stiffness.mean", *mean)?;
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
                positive(&format!("mesh.stiffness.values[{i}]"), k)?;
            }
            MeshStiffness::table(phase_points, values, phase(*p)?)
        }
        StiffnessSpec::Geometry { .. } => unreachable!("resolved by scene::geometry"),
        StiffnessSpec::Helical { .. } => unreachable!("resolved by scene::helical"),
    })
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
