//! Mechanical ports of a drivetrain scene (`[[port]]`, `docs/ports.md`): the shafts through
//! which the gear stage exchanges power with its neighbours (issue 18, point 1; the port
//! conventions of the agreed element spec).
//!
//! A scene with ports carries the rigid-body rotation (the mesh phase follows the actual
//! pinion angle); one without runs the nominal-speed form of `docs/train.md`.

use schemars::JsonSchema;
use serde::Deserialize;

use crate::scene::schema::{non_negative, positive};

use crate::scene::SceneError;

/// `[[port]]` as written.
#[derive(Debug, Clone, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PortSpec {
    /// Port name: the FMU variables are `<name>.torque|angle|speed|acceleration`.
    pub name: String,
    /// Gear (body) the port acts on: the input or the output gear.
    pub gear: String,
    /// `"torque"` (takes a torque, returns the motion) or `"speed"`.
    #[serde(default = "PortSpec::default_causality")]
    pub causality: String,
    /// Start value of the port torque, N·m, positive along the body's nominal rotation (the
    /// torque the neighbour applies TO the gear stage at this shaft). With speed causality:
    /// the torque the coupling carries at the start (it pre-twists the coupling).
    #[serde(default)]
    #[schemars(extend("x-unit" = "N.m"))]
    pub torque: f64,
    /// Speed causality: torsional stiffness of the coupling to the neighbour, N·m/rad (> 0).
    #[schemars(transform = positive, extend("x-unit" = "N.m/rad"))]
    pub stiffness: Option<f64>,
    /// Speed causality: viscous damping of the coupling, N·m·s/rad (≥ 0).
    #[schemars(transform = non_negative, extend("x-unit" = "N.m.s/rad"))]
    pub damping: Option<f64>,
    /// Speed causality: the neighbour's speed, rad/s (default: the gear's nominal speed).
    #[schemars(extend("x-unit" = "rad/s"))]
    /// Natively the neighbour turns at it for the whole run; in the FMU it is the start value
    /// of `<name>.speed`.
    pub speed: Option<f64>,
    /// Speed causality: the neighbour's angle at the start, rad (default: the gear's start
    #[schemars(extend("x-unit" = "rad"))]
    /// angle plus `torque / stiffness`, so the coupling carries `torque`). The start value of
    /// `<name>.angle` in the FMU.
    pub angle: Option<f64>,
}

impl PortSpec {
    fn default_causality() -> String {
        "torque".into()
    }
}

/// Which end of the train a port sits on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PortEnd {
    /// The input gear: the port torque is the train's input torque.
    Input,
    /// The output gear: the port torque is minus the train's load torque.
    Output,
}

/// The compliant coupling of a speed port (`docs/ports.md`, "Speed causality"): the gear is
/// tied to the neighbour's flange by a torsional spring-damper, whose torque on the gear is
/// `k(φ − θ_g) + c(ω − ω_g)`; `k → ∞` is the rigid limit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpeedCoupling {
    /// N·m/rad.
    pub stiffness: f64,
    /// N·m·s/rad.
    pub damping: f64,
    /// The neighbour's (start) speed, rad/s; `None`: the gear's nominal speed.
    pub speed: Option<f64>,
    /// The neighbour's start angle, rad; `None`: pre-twisted by the start torque.
    pub angle: Option<f64>,
}

/// A validated port.
#[derive(Debug, Clone, PartialEq)]
pub struct Port {
    pub name: String,
    pub gear: usize,
    pub end: PortEnd,
    /// Start torque, N·m, along the body's nominal rotation (the neighbour's torque on the
    /// gear; with speed causality the coupling's torque at the start).
    pub torque: f64,
    /// `Some`: speed causality (the port takes the neighbour's angle and speed and returns
    /// the coupling torque); `None`: torque causality.
    pub coupling: Option<SpeedCoupling>,
}

fn err<T>(msg: String) -> Result<T, SceneError> {
    Err(SceneError(msg))
}

/// Checks the `[[port]]` tables against the gears, the input and output gear, and the
/// operating torques they replace. `find` resolves a gear name; `input_torque` and
/// `load_torque` tell whether the file gave those keys.
pub(crate) fn ports(
    specs: &[PortSpec],
    find: &dyn Fn(&str, &str) -> Result<usize, SceneError>,
    input_gear: usize,
    output_gear: usize,
    input_torque_given: bool,
    load_torque_given: bool,
) -> Result<Vec<Port>, SceneError> {
    let mut out: Vec<Port> = Vec::with_capacity(specs.len());
    for (i, p) in specs.iter().enumerate() {
        let field = |f: &str| format!("port[{i}].{f}");
        let ident = !p.name.is_empty()
            && p.name
                .chars()
                .next()
                .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
            && p.name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_');
        if !ident {
            return err(format!(
                "{} = {:?}: must be an identifier ([A-Za-z_][A-Za-z0-9_]*), it names the FMU \
                 variables <name>.torque, <name>.angle, ...",
                field("name"),
                p.name
            ));
        }
        if let Some(j) = out.iter().position(|o| o.name == p.name) {
            return err(format!(
                "{} = {:?}: duplicates port[{j}].name",
                field("name"),
                p.name
            ));
        }
        if find(&field("name"), &p.name).is_ok() {
            // The port's outputs `<name>.angle`, … would repeat the gear's body outputs.
            return err(format!(
                "{} = {:?}: is also a gear's name; a port and a gear would own outputs of the \
                 same names (<name>.angle, <name>.speed, ...)",
                field("name"),
                p.name
            ));
        }
        let coupling = match p.causality.as_str() {
            "torque" => {
                for (key, given) in [
                    ("stiffness", p.stiffness.is_some()),
                    ("damping", p.damping.is_some()),
                    ("speed", p.speed.is_some()),
                    ("angle", p.angle.is_some()),
                ] {
                    if given {
                        return err(format!(
                            "{}: only a port with causality = \"speed\" has a coupling to \
                             its neighbour (this one takes a torque)",
                            field(key)
                        ));
                    }
                }
                None
            }
            "speed" => Some(coupling(p, &field)?),
            other => {
                return err(format!(
                    "{} = {other:?}: must be \"torque\" or \"speed\"",
                    field("causality")
                ))
            }
        };
        let gear = find(&field("gear"), &p.gear)?;
        let end = if gear == input_gear {
            PortEnd::Input
        } else if gear == output_gear {
            PortEnd::Output
        } else {
            return err(format!(
                "{} = {:?}: a port acts on the train's input or output gear \
                 (operating.input_gear / operating.output_gear)",
                field("gear"),
                p.gear
            ));
        };
        if let Some(j) = out.iter().position(|o| o.end == end) {
            return err(format!(
                "{} = {:?}: port[{j}] already acts on that gear",
                field("gear"),
                p.gear
            ));
        }
        match end {
            PortEnd::Input if input_torque_given => {
                return err(format!(
                    "operating.input_torque and port[{i}] ({:?} on gear {:?}) \
                     both give the input gear's torque: give it as port[{i}].torque",
                    p.name, p.gear
                ))
            }
            PortEnd::Output if load_torque_given => {
                return err(format!(
                    "operating.load_torque and port[{i}] ({:?} on gear {:?}) \
                     both give the output gear's torque: give it as port[{i}].torque \
                     (negative for a resisting load)",
                    p.name, p.gear
                ))
            }
            _ => {}
        }
        if !p.torque.is_finite() {
            return err(format!(
                "{} = {}: must be finite",
                field("torque"),
                p.torque
            ));
        }
        out.push(Port {
            name: p.name.clone(),
            gear,
            end,
            torque: p.torque,
            coupling,
        });
    }
    Ok(out)
}

/// The coupling of a speed port: `stiffness` > 0 and `damping` ≥ 0 are required (there is no
/// default compliance: it is part of the drivetrain), `speed` finite if given.
fn coupling(p: &PortSpec, field: &dyn Fn(&str) -> String) -> Result<SpeedCoupling, SceneError> {
    let stiffness = match p.stiffness {
        None => {
            return err(format!(
                "{}: required with causality = \"speed\" (the torsional stiffness of the \
                 coupling to the neighbour, N·m/rad, > 0; a very stiff one approaches a rigid \
                 connection)",
                field("stiffness")
            ))
        }
        Some(k) if !(k.is_finite() && k > 0.0) => {
            return err(format!(
                "{} = {k}: must be a finite number > 0 N·m/rad",
                field("stiffness")
            ))
        }
        Some(k) => k,
    };
    let damping = match p.damping {
        None => {
            return err(format!(
                "{}: required with causality = \"speed\" (the coupling's viscous damping, \
                 N·m·s/rad, >= 0)",
                field("damping")
            ))
        }
        Some(c) if !(c.is_finite() && c >= 0.0) => {
            return err(format!(
                "{} = {c}: must be a finite number >= 0 N·m·s/rad",
                field("damping")
            ))
        }
        Some(c) => c,
    };
    for (key, value) in [("speed", p.speed), ("angle", p.angle)] {
        if let Some(x) = value.filter(|x| !x.is_finite()) {
            return err(format!("{} = {x}: must be finite", field(key)));
        }
    }
    Ok(SpeedCoupling {
        stiffness,
        damping,
        speed: p.speed,
        angle: p.angle,
    })
}
