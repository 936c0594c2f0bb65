//! Drivetrain elements in a drivetrain scene (`[[motor]]`, `[[load]]`, `[[inertia]]` and
//! `[[shaft]]`s that reach them; `docs/ports.md`, "Elements in the scene"; issue 18 point 2's
//! native side and the oracle of point 5).
//!
//! Each element is a body of its own (the motor's rotor, the load's inertia, a toothless
//! inertia) with the physics of `src/model/elements/` (one set of equations for the element
//! FMUs and the monolithic scene). Bodies are coupled to the gear train and to each other by
//! torsional shafts written like the coaxial shafts of the train (`[[shaft]] gears = [a, b]`,
//! stiffness and damping), with the element shaft law `τ = k(θ_a − θ_b) + c(ω_a − ω_b)`, `−τ`
//! on body a and `+τ` on body b. A shaft that reaches an element is an element shaft; it must
//! not be rigid.

use crate::model::elements::{InertiaSpec, LoadSpec, MotorSpec, ShaftSpec};
use crate::scene::spec::{
    InertiaBodySpec, LoadBodySpec, MotorBodySpec, ShaftSpec as TrainShaftSpec,
};
use crate::scene::SceneError;

/// The physics of an element body.
#[derive(Debug, Clone, PartialEq)]
pub enum ElementKind {
    Motor(MotorSpec),
    Load(LoadSpec),
    Inertia(InertiaSpec),
}

/// A validated element body.
#[derive(Debug, Clone, PartialEq)]
pub struct ElementBody {
    pub name: String,
    pub kind: ElementKind,
}

/// One end of an element shaft: a gear of the train or an element body.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ShaftEnd {
    /// Gear index of the scene (its input or output gear).
    Gear(usize),
    /// Index into [`Elements::bodies`].
    Element(usize),
}

/// A validated element shaft.
#[derive(Debug, Clone, PartialEq)]
pub struct ElementShaft {
    /// Output column prefix: `name`, or `<gears[0]>_<gears[1]>`.
    pub name: String,
    pub ends: [ShaftEnd; 2],
    pub spec: ShaftSpec,
    /// Start torque τ0 (N·m): the static torque it carries at the start operating point; its
    /// pre-twist is τ0/k.
    pub start_torque: f64,
}

/// Every element of a scene; empty: a plain gear train.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Elements {
    pub bodies: Vec<ElementBody>,
    pub shafts: Vec<ElementShaft>,
}

impl Elements {
    pub fn is_empty(&self) -> bool {
        self.bodies.is_empty()
    }
}

fn err<T>(msg: String) -> Result<T, SceneError> {
    Err(SceneError(msg))
}

/// Names of the element bodies in the order motors, loads, inertias (the body order of
/// [`Elements::bodies`]).
pub(crate) fn body_names(
    motors: &[MotorBodySpec],
    loads: &[LoadBodySpec],
    inertias: &[InertiaBodySpec],
) -> Vec<String> {
    (motors.iter().map(|m| m.name.clone()))
        .chain(loads.iter().map(|l| l.name.clone()))
        .chain(inertias.iter().map(|i| i.name.clone()))
        .collect()
}

/// `(<table>[i], name)` of every element body, in the order of [`body_names`].
pub(crate) fn body_tables(
    motors: &[MotorBodySpec],
    loads: &[LoadBodySpec],
    inertias: &[InertiaBodySpec],
) -> Vec<(String, String)> {
    let tagged = |table: &str, names: Vec<&String>| -> Vec<(String, String)> {
        (names.into_iter().enumerate())
            .map(|(i, n)| (format!("{table}[{i}]"), n.clone()))
            .collect()
    };
    let mut out = tagged("motor", motors.iter().map(|m| &m.name).collect());
    out.extend(tagged("load", loads.iter().map(|l| &l.name).collect()));
    out.extend(tagged(
        "inertia",
        inertias.iter().map(|b| &b.name).collect(),
    ));
    out
}

/// Validates the element bodies and the element shafts (`(index in [[shaft]], spec)`).
/// `gear` resolves a gear name (`None`: no gear of that name); the start torques of the
/// train (`input_torque` on the input gear, `load_torque` resisting at the output gear) give
/// the shafts' static torques.
#[allow(clippy::too_many_arguments)]
pub(crate) fn elements(
    motors: &[MotorBodySpec],
    loads: &[LoadBodySpec],
    inertias: &[InertiaBodySpec],
    shafts: &[(usize, &TrainShaftSpec)],
    gear: &dyn Fn(&str) -> Option<usize>,
    input_gear: usize,
    output_gear: usize,
    input_torque: f64,
    load_torque: f64,
) -> Result<Elements, SceneError> {
    let mut bodies = Vec::new();
    let mut add = |table: &str, i: usize, name: &str, kind: ElementKind| {
        let prefix = format!("{table}[{i}]");
        let ident = name
            .chars()
            .next()
            .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
            && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
        if !ident {
            return err(format!(
                "{prefix}.name = {name:?}: must be an identifier ([A-Za-z_][A-Za-z0-9_]*), it \
                 names the output columns <name>_angle, <name>_speed, ..."
            ));
        }
        if gear(name).is_some() {
            return err(format!(
                "{prefix}.name = {name:?}: a gear has that name already"
            ));
        }
        if bodies.iter().any(|b: &ElementBody| b.name == name) {
            return err(format!(
                "{prefix}.name = {name:?}: another element has that name already"
            ));
        }
        let check = match &kind {
            ElementKind::Motor(s) => s.validate(&prefix),
            ElementKind::Load(s) => s.validate(&prefix),
            ElementKind::Inertia(s) => s.validate(&prefix),
        };
        check.map_err(SceneError)?;
        bodies.push(ElementBody {
            name: name.to_owned(),
            kind,
        });
        Ok(())
    };
    for (i, m) in motors.iter().enumerate() {
        add("motor", i, &m.name, ElementKind::Motor(m.motor.clone()))?;
    }
    for (i, l) in loads.iter().enumerate() {
        add("load", i, &l.name, ElementKind::Load(l.load))?;
    }
    for (i, b) in inertias.iter().enumerate() {
        add("inertia", i, &b.name, ElementKind::Inertia(b.inertia))?;
    }
    let end = |i: usize, j: usize, name: &str| -> Result<ShaftEnd, SceneError> {
        if let Some(e) = bodies.iter().position(|b| b.name == name) {
            return Ok(ShaftEnd::Element(e));
        }
        match gear(name) {
            Some(g) if g == input_gear || g == output_gear => Ok(ShaftEnd::Gear(g)),
            Some(_) => err(format!(
                "shaft[{i}].gears[{j}] = {name:?}: an element shaft reaches the train at its \
                 input or output gear (operating.input_gear / operating.output_gear)"
            )),
            None => err(format!(
                "shaft[{i}].gears[{j}] = {name:?}: no gear or element of that name"
            )),
        }
    };
    let mut out: Vec<ElementShaft> = Vec::new();
    for &(i, s) in shafts {
        let ends = [end(i, 0, &s.gears[0])?, end(i, 1, &s.gears[1])?];
        if ends[0] == ends[1] {
            return err(format!(
                "shaft[{i}].gears = [{:?}, {:?}]: a shaft joins two different bodies",
                s.gears[0], s.gears[1]
            ));
        }
        if s.rigid {
            return err(format!(
                "shaft[{i}].rigid = true: a shaft to an element is a torsional spring-damper; \
                 give its stiffness"
            ));
        }
        let Some(k) = s.stiffness else {
            return err(format!(
                "shaft[{i}].stiffness: missing; give the torsional stiffness in N·m/rad"
            ));
        };
        let spec = ShaftSpec {
            stiffness: k,
            damping: s.damping,
        };
        spec.validate(&format!("shaft[{i}]")).map_err(SceneError)?;
        let name = s
            .name
            .clone()
            .unwrap_or_else(|| format!("{}_{}", s.gears[0], s.gears[1]));
        if out.iter().any(|o| o.name == name) {
            return err(format!(
                "shaft[{i}].name = {name:?}: another element shaft has that name (its torque \
                 column <name>_torque); give each a distinct name"
            ));
        }
        out.push(ElementShaft {
            name,
            ends,
            spec,
            start_torque: 0.0,
        });
    }
    // Start torques: the torque the train takes at a gear flows unchanged along the chain of
    // shafts and bodies from that gear (static equilibrium at the start speed; the speed-
    // dependent losses of intermediate bodies are not included).
    let mut known = vec![false; out.len()];
    let mut frontier: Vec<(ShaftEnd, f64)> = vec![
        (ShaftEnd::Gear(input_gear), input_torque),
        (ShaftEnd::Gear(output_gear), -load_torque),
    ];
    while let Some((at, torque_on_at)) = frontier.pop() {
        for (k, s) in out.iter_mut().enumerate() {
            if known[k] {
                continue;
            }
            // τ acts as −τ on end a and +τ on end b.
            let (tau, other) = if s.ends[1] == at {
                (torque_on_at, s.ends[0])
            } else if s.ends[0] == at {
                (-torque_on_at, s.ends[1])
            } else {
                continue;
            };
            known[k] = true;
            s.start_torque = tau;
            // The next shaft beyond `other` holds that body in balance: it applies the
            // opposite torque of this shaft's on `other`.
            let on_other = if s.ends[0] == other { tau } else { -tau };
            if let ShaftEnd::Element(_) = other {
                frontier.push((other, on_other));
            }
        }
    }
    for (e, b) in bodies.iter().enumerate() {
        if !out.iter().any(|s| s.ends.contains(&ShaftEnd::Element(e))) {
            return err(format!(
                "{:?}: the element is not coupled to the train; join it with a [[shaft]] \
                 gears = [..] to the input or output gear or to another element",
                b.name
            ));
        }
    }
    for (k, s) in out.iter().enumerate() {
        if !known[k] {
            return err(format!(
                "shaft {:?}: not connected to the train through other shafts",
                s.name
            ));
        }
    }
    Ok(Elements {
        bodies,
        shafts: out,
    })
}
