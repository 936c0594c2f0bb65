//! Mechanical ports of a drivetrain scene (`[[port]]`, `docs/ports.md`): the shafts through
//! which the gear stage exchanges power with its neighbours (issue 18, point 1; the port
//! conventions of the agreed element spec).
//!
//! A scene with ports carries the rigid-body rotation (the mesh phase follows the actual
//! pinion angle); one without runs the nominal-speed form of `docs/train.md`.

use serde::Deserialize;

use crate::scene::SceneError;

/// `[[port]]` as written.
#[derive(Debug, Clone, Deserialize)]
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
    /// torque the neighbour applies TO the gear stage at this shaft).
    #[serde(default)]
    pub torque: f64,
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

/// A validated port (torque causality).
#[derive(Debug, Clone, PartialEq)]
pub struct Port {
    pub name: String,
    pub gear: usize,
    pub end: PortEnd,
    /// Start torque, N·m, along the body's nominal rotation.
    pub torque: f64,
}

fn err<T>(msg: String) -> Result<T, SceneError> {
    Err(SceneError(msg))
}

/// Checks the `[[port]]` tables against the gears, the input and output gear, and the
/// operating torques they replace. `find` resolves a gear name; `input_torque` and
/// `load_torque` tell whether the file gave those keys.
pub(super) fn ports(
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
                "{} = {:?}: is also a gear's name; a port and a gear own outputs of the same                  names (<name>.angle, <name>.speed, ...)",
                field("name"),
                p.name
            ));
        }
        match p.causality.as_str() {
            "torque" => {}
            "speed" => {
                return err(format!(
                    "{} = \"speed\": speed causality is not available yet (docs/ports.md); \
                     use \"torque\"",
                    field("causality")
                ))
            }
            other => {
                return err(format!(
                    "{} = {other:?}: must be \"torque\" or \"speed\"",
                    field("causality")
                ))
            }
        }
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
                    "operating.input_torque and port[{i}] ({:?}, torque causality on gear {:?}) \
                     both give the input gear's torque: give it as port[{i}].torque",
                    p.name, p.gear
                ))
            }
            PortEnd::Output if load_torque_given => {
                return err(format!(
                    "operating.load_torque and port[{i}] ({:?}, torque causality on gear {:?}) \
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
        });
    }
    Ok(out)
}
