//! The variable table of an element FMU (FMI 2.0.x §2.2.7): parameters from value reference
//! [`VR_PARAM0`], continuous inputs from [`VR_INPUT0`], continuous outputs from
//! [`VR_OUTPUT0`], each with its unit, bounds and description. Names follow `docs/fmu.md`:
//! parameters and inputs are the key paths inside the scene's `[element]` table
//! (`controller.kp`, `controller.speed_reference`) or `[initial]` (`initial.speed`); outputs
//! are `<owner>.<quantity>`, the owner a port (`flange.angle`, `flange_a.torque`) or the
//! element by its kind (`motor.electric_torque`, `shaft.torque`, `load.resisting_torque`).

use crate::fmi::model::{Causality, Variability, Variable};
use crate::fmu::table::{output, param};
use crate::model::elements::ElementSpec;

use super::scene::ElementScene;

pub const VR_PARAM0: u32 = 0;
pub const VR_INPUT0: u32 = 100;
pub const VR_OUTPUT0: u32 = 200;

/// A parameter: name, unit, lower bound (inclusive; a strict `> 0` is the model's check),
/// description.
struct Param {
    name: &'static str,
    unit: &'static str,
    min: Option<f64>,
    description: &'static str,
}

const fn p(
    name: &'static str,
    unit: &'static str,
    min: Option<f64>,
    description: &'static str,
) -> Param {
    Param {
        name,
        unit,
        min,
        description,
    }
}

const INITIAL: [Param; 2] = [
    p("initial.angle", "rad", None, "Angle at the start time"),
    p("initial.speed", "rad/s", None, "Speed at the start time"),
];

/// The parameters of a scene's element, in value-reference order.
fn params(spec: &ElementSpec) -> Vec<Param> {
    let mut v = match spec {
        ElementSpec::Inertia(_) => vec![
            p(
                "inertia",
                "kg.m2",
                Some(0.0),
                "Polar moment of inertia J (> 0)",
            ),
            p(
                "damping",
                "N.m.s/rad",
                Some(0.0),
                "Viscous damping to ground d (>= 0)",
            ),
        ],
        ElementSpec::Shaft(_) => vec![
            p(
                "stiffness",
                "N.m/rad",
                Some(0.0),
                "Torsional stiffness k (> 0)",
            ),
            p(
                "damping",
                "N.m.s/rad",
                Some(0.0),
                "Torsional damping c (>= 0)",
            ),
        ],
        ElementSpec::Motor(m) => {
            let mut v = vec![
                p("inertia", "kg.m2", Some(0.0), "Rotor inertia J_m (> 0)"),
                p(
                    "damping",
                    "N.m.s/rad",
                    Some(0.0),
                    "Rotor damping to ground d_m (>= 0)",
                ),
            ];
            if m.controller.is_some() {
                v.push(p(
                    "controller.kp",
                    "N.m.s/rad",
                    Some(0.0),
                    "PI proportional gain (>= 0)",
                ));
                v.push(p(
                    "controller.ki",
                    "N.m/rad",
                    Some(0.0),
                    "PI integral gain (>= 0)",
                ));
            }
            v
        }
        ElementSpec::Load(_) => vec![
            p("inertia", "kg.m2", Some(0.0), "Load inertia J_L (> 0)"),
            p(
                "torque",
                "N.m",
                Some(0.0),
                "Constant resisting torque T_0 (>= 0)",
            ),
            p(
                "viscous",
                "N.m.s/rad",
                Some(0.0),
                "Viscous resistance c_v (>= 0)",
            ),
            p(
                "drag",
                "N.m.s2/rad2",
                Some(0.0),
                "Quadratic drag c_d (>= 0): c_d w|w|",
            ),
        ],
    };
    if !matches!(spec, ElementSpec::Shaft(_)) {
        v.extend(INITIAL);
    }
    v
}

/// A continuous input: name, unit, bounds, description.
type Input = (&'static str, &'static str, Option<(f64, f64)>, &'static str);

/// The inputs, in value-reference order.
fn inputs(spec: &ElementSpec) -> Vec<Input> {
    match spec {
        ElementSpec::Inertia(_) => vec![
            (
                "flange_a.torque",
                "N.m",
                None,
                "Torque applied to the inertia at flange a",
            ),
            (
                "flange_b.torque",
                "N.m",
                None,
                "Torque applied to the inertia at flange b",
            ),
        ],
        ElementSpec::Shaft(_) => vec![
            ("flange_a.angle", "rad", None, "Angle of the body at end a"),
            (
                "flange_a.speed",
                "rad/s",
                None,
                "Speed of the body at end a",
            ),
            ("flange_b.angle", "rad", None, "Angle of the body at end b"),
            (
                "flange_b.speed",
                "rad/s",
                None,
                "Speed of the body at end b",
            ),
        ],
        ElementSpec::Motor(m) => {
            let first = (
                "flange.torque",
                "N.m",
                None,
                "Torque applied to the rotor by the driven side",
            );
            if m.controller.is_some() {
                vec![
                    first,
                    (
                        "controller.speed_reference",
                        "rad/s",
                        None,
                        "Speed reference of the PI controller",
                    ),
                ]
            } else {
                vec![
                    first,
                    (
                        "torque_fraction",
                        "1",
                        Some((0.0, 1.0)),
                        "Fraction of the full-load torque T_max(w) commanded (open loop)",
                    ),
                ]
            }
        }
        ElementSpec::Load(_) => vec![(
            "flange.torque",
            "N.m",
            None,
            "Torque applied to the load by the driving side",
        )],
    }
}

/// An output: name, unit, description, the positions of the inputs it depends on directly.
type Output = (&'static str, &'static str, &'static str, &'static [usize]);

/// Every input (the outputs of a body see all its torques; the shaft all its motions).
const ALL: &[usize] = &[0, 1, 2, 3];

fn body_outputs(port: &'static str) -> [Output; 3] {
    // `port` is one of the static flange names below.
    let (angle, speed, accel) = match port {
        "flange_a" => ("flange_a.angle", "flange_a.speed", "flange_a.acceleration"),
        "flange_b" => ("flange_b.angle", "flange_b.speed", "flange_b.acceleration"),
        _ => ("flange.angle", "flange.speed", "flange.acceleration"),
    };
    [
        (angle, "rad", "Angle of the flange", &[]),
        (speed, "rad/s", "Speed of the flange", &[]),
        (accel, "rad/s2", "Angular acceleration of the flange", ALL),
    ]
}

/// The outputs, in value-reference order.
fn outputs(spec: &ElementSpec) -> Vec<Output> {
    match spec {
        ElementSpec::Inertia(_) => {
            let mut v = body_outputs("flange_a").to_vec();
            v.extend(body_outputs("flange_b"));
            v
        }
        ElementSpec::Shaft(_) => vec![
            (
                "flange_a.torque",
                "N.m",
                "Torque the shaft exerts ON the body at end a (-tau)",
                ALL,
            ),
            (
                "flange_b.torque",
                "N.m",
                "Torque the shaft exerts ON the body at end b (+tau)",
                ALL,
            ),
            (
                "shaft.torque",
                "N.m",
                "Shaft torque tau = k (phi_a - phi_b) + c (w_a - w_b)",
                ALL,
            ),
        ],
        ElementSpec::Motor(_) => {
            let mut v = body_outputs("flange").to_vec();
            v.push((
                "motor.electric_torque",
                "N.m",
                "Electromagnetic torque T_e (curve or PI, clamped)",
                &[1],
            ));
            v.push((
                "motor.ripple_torque",
                "N.m",
                "Ripple torque T_r = sum a cos(o theta + phi)",
                &[],
            ));
            v
        }
        ElementSpec::Load(_) => {
            let mut v = body_outputs("flange").to_vec();
            v.push((
                "load.resisting_torque",
                "N.m",
                "T_0 + c_v w + c_d w|w|",
                &[],
            ));
            v
        }
    }
}

/// Names of the parameters, in value-reference order from [`VR_PARAM0`].
pub fn param_names(spec: &ElementSpec) -> Vec<&'static str> {
    params(spec).iter().map(|p| p.name).collect()
}

/// Number of inputs and outputs.
pub fn counts(spec: &ElementSpec) -> (usize, usize) {
    (inputs(spec).len(), outputs(spec).len())
}

/// The variable table, with start values from the scene and the start inputs `u0`.
pub fn variables(scene: &ElementScene, u0: &[f64]) -> Vec<Variable> {
    let spec = &scene.element;
    let mut vars = Vec::new();
    for (i, q) in params(spec).into_iter().enumerate() {
        let start = super::parameter(scene, q.name).unwrap_or(0.0);
        let mut v = param(
            q.name,
            VR_PARAM0 + i as u32,
            start,
            Some(q.unit),
            q.description,
        );
        v.min = q.min;
        vars.push(v);
    }
    let input_vrs: Vec<u32> = (0..inputs(spec).len() as u32)
        .map(|i| VR_INPUT0 + i)
        .collect();
    for (i, (name, unit, bounds, desc)) in inputs(spec).into_iter().enumerate() {
        let mut v = Variable::real(
            name,
            input_vrs[i],
            Causality::Input,
            Variability::Continuous,
            None,
            Some(u0[i]),
            (unit != "1").then_some(unit),
            desc,
        );
        if let Some((lo, hi)) = bounds {
            v.min = Some(lo);
            v.max = Some(hi);
        }
        vars.push(v);
    }
    for (i, (name, unit, desc, feedthrough)) in outputs(spec).into_iter().enumerate() {
        let mut v = output(name, VR_OUTPUT0 + i as u32, Some(unit), desc, false);
        v.depends_on = feedthrough
            .iter()
            .filter_map(|&k| input_vrs.get(k).copied())
            .collect();
        vars.push(v);
    }
    vars
}
