//! A scene on the single-pair kernel ([`crate::scene::kernel`]): one mesh between two gears,
//! validated into the pair kernel's [`PairScene`] (ranges, consistency, defaults). Every message
//! names the field as a TOML path and its value; nothing is clamped.

use super::checks::{
    err, finite, gear_compliance, harmonic_list, initial_dte, non_negative, solver, teeth,
    valid_identifier,
};
use super::stiffness::{stiffness, stiffness_kind};
use crate::mesh::PhaseSeries;
use crate::scene::kernel::{
    choose, equivalent_mass, KernelChoice, PairGear, PairMesh, PairOperating, PairScene,
};
use crate::scene::spec::{ParsedScene, StiffnessSpec};
use crate::scene::{ContactLaw, MethodChoice, SceneError, SmoothTerms};

type Result<T> = std::result::Result<T, SceneError>;

pub(crate) fn validate(parsed: ParsedScene, source: &str) -> Result<PairScene> {
    if let KernelChoice::Drivetrain(why) = choose(&parsed) {
        return err(format!(
            "{why}: only the drivetrain kernel carries this; read the scene as a drivetrain \
             (geardyn does so for every command)"
        ));
    }
    let spec = parsed.spec;
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
    let Some(m) = spec.mesh.first() else {
        return err("mesh: no mesh given".into());
    };
    let Some(m_stiffness) = &m.stiffness else {
        return err("mesh: missing field `stiffness`".into());
    };
    // A geometry stiffness defines what the gear bodies need (docs/model.md, "Gears: base
    // radius and inertia from the geometry").
    let bodies = super::geometry::bodies(m_stiffness, "mesh.stiffness")?;
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
        let gear = PairGear {
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
        // All-zero errors stay on this kernel (`docs/errors.md`); they are still checked.
        super::errors::gear_errors(&field, &g.name, gear.teeth, g)?;
        gear_compliance(&format!("gear[{i}]"), gear.base_radius, gear.inertia)?;
        gears.push(gear);
    }
    if gears[0].name == gears[1].name {
        return err(format!(
            "gear[1].name = {:?}: duplicates gear[0].name",
            gears[1].name
        ));
    }
    let find = |field: &str, name: &str| -> Result<PairGear> {
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

    let profiles = crate::scene::profile::profiles(
        &spec.operating.speed_profile,
        &spec.operating.torque_profile,
    )?;
    let pinion_speed = crate::scene::profile::resolve(
        "operating.pinion_speed",
        spec.operating.input_speed,
        "operating.speed_profile",
        profiles.speed.as_ref(),
    )?;
    let input_torque = crate::scene::profile::resolve(
        "operating.input_torque",
        spec.operating.input_torque,
        "operating.torque_profile",
        profiles.torque.as_ref(),
    )?;

    let stiffness = match m_stiffness {
        StiffnessSpec::Geometry { .. } => {
            fn body<'a>(which: &str, g: &'a PairGear) -> super::geometry::MeshGear<'a> {
                super::geometry::MeshGear {
                    which: which.to_owned(),
                    name: &g.name,
                    teeth: g.teeth,
                    base_radius: g.base_radius,
                }
            }
            super::geometry::stiffness(
                m_stiffness,
                "mesh.stiffness",
                [body("mesh.pinion", &pinion), body("mesh.gear", &gear)],
                ("operating.input_torque", input_torque),
            )?
        }
        StiffnessSpec::Helical { .. } => super::helical::stiffness(m_stiffness, &pinion, &gear)?,
        other => stiffness(other)?,
    };
    let (k_min, s_min) = stiffness.minimum();
    if !(k_min > 0.0) {
        return err(format!(
            "mesh.stiffness: the stiffness reaches {k_min:e} N/m at shifted phase {s_min}; it must stay > 0"
        ));
    }
    let k_mean = stiffness.mean();

    let field = |key: &str| format!("mesh.{key}");
    let contact = super::mesh::contact_law(&field, m)?;
    let m_e = equivalent_mass(&pinion, &gear);
    let damping = super::mesh::damping(&field, m, k_mean, stiffness.maximum(), m_e)?;

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
            stiffness_kind(m_stiffness)
        ));
    }

    Ok(PairScene {
        name: spec.name,
        description: spec.description,
        pinion,
        gear,
        mesh: PairMesh {
            contact,
            stiffness,
            ste,
            damping,
            damping_always,
            smooth,
            initial_phase: finite("mesh.initial_phase", m.initial_phase.unwrap_or(0.0))?,
        },
        operating: PairOperating {
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
