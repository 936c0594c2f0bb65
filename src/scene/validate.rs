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
    let mut gears = Vec::with_capacity(2);
    for (i, g) in spec.gear.iter().enumerate() {
        let field = |f: &str| format!("gear[{i}].{f}");
        if g.name.is_empty() {
            return err(format!("{} = \"\": must not be empty", field("name")));
        }
        if g.teeth < 1 || g.teeth > 100_000 {
            return err(format!(
                "{} = {}: must be an integer >= 1",
                field("teeth"),
                g.teeth
            ));
        }
        gears.push(Gear {
            name: g.name.clone(),
            teeth: g.teeth as u32,
            base_radius: positive(&field("base_radius"), g.base_radius)?,
            inertia: positive(&field("inertia"), g.inertia)?,
        });
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
    let m = &spec.mesh;
    let pinion = find("mesh.pinion", &m.pinion)?;
    let gear = find("mesh.gear", &m.gear)?;
    if pinion.name == gear.name {
        return err(format!(
            "mesh.gear = {:?}: the same gear as mesh.pinion",
            m.gear
        ));
    }

    let stiffness = match &m.stiffness {
        StiffnessSpec::Geometry { .. } => {
            super::geometry::stiffness(&m.stiffness, &spec.operating, &pinion, &gear)?
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
            finite_list("mesh.ste.cos", &series.cos)?;
            finite_list("mesh.ste.sin", &series.sin)?;
            PhaseSeries::new(&series.cos, &series.sin)
        }
        None => PhaseSeries::default(),
    };

    let op = &spec.operating;
    let pinion_speed = non_negative("operating.pinion_speed", op.pinion_speed)?;
    let input_torque = finite("operating.input_torque", op.input_torque)?;
    let load_torque = match op.load_torque {
        Some(t) => finite("operating.load_torque", t)?,
        None => input_torque * gear.base_radius / pinion.base_radius,
    };

    let initial_dte = match &spec.initial.dte {
        InitialDteSpec::Value(v) => InitialDte::Value(finite("initial.dte", *v)?),
        InitialDteSpec::Keyword(k) if k == "static" => InitialDte::Static,
        InitialDteSpec::Keyword(k) => {
            return err(format!(
                "initial.dte = {k:?}: must be \"static\" or a number in m"
            ))
        }
    };

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
            finite_list("mesh.stiffness.cos", cos)?;
            finite_list("mesh.stiffness.sin", sin)?;
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
