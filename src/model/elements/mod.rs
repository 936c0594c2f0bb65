//! Drivetrain elements as plain physics: an inertia, a torsional shaft (spring-damper), a
//! motor (torque source with rotor, full-load curve, ripple and an optional PI speed
//! controller) and a vehicle-like load (inertia with drag).
//!
//! Each element has a serde spec (SI units, unknown keys rejected), a `validate` whose
//! messages name the field and its value, and its equations as pure functions of a state and
//! inputs: the derivative, the stored kinetic (or elastic) energy and the dissipated power.
//! The same functions serve the element FMUs (`src/fmu/element/`) and the monolithic native
//! drivetrain built from the same elements, so both integrate one set of equations.
//!
//! # Conventions (`docs/elements.md`)
//!
//! Angles in rad, speeds in rad/s, torques in N·m, all positive along the shaft's positive
//! rotation sense. A *flange torque* is the torque applied TO the element at that flange by
//! its neighbour, so the power flowing into an element at a flange is
//! [`port_power`]`(T_flange, ω_flange) = T_flange · ω_flange`. The one exception is the
//! shaft, a pure coupling: its outputs are the torques it exerts ON its neighbours
//! ([`shaft::ShaftSpec::flange_torques`]), so they connect directly to the neighbours' torque
//! inputs.

pub mod curve;
pub mod inertia;
pub mod load;
pub mod motor;
pub mod shaft;

pub use curve::TorqueCurve;
pub use inertia::InertiaSpec;
pub use load::LoadSpec;
pub use motor::{ControllerSpec, MotorInputs, MotorSpec, MotorState, RippleSpec};
pub use shaft::ShaftSpec;

use schemars::JsonSchema;
use serde::Deserialize;

/// One element of any kind, as written in a scene (`kind = "inertia" | "shaft" | "motor" |
/// "load"`, the element's fields beside it).
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum ElementSpec {
    Inertia(InertiaSpec),
    Shaft(ShaftSpec),
    Motor(MotorSpec),
    Load(LoadSpec),
}

impl ElementSpec {
    /// The kind as written in a scene.
    pub fn kind(&self) -> &'static str {
        match self {
            ElementSpec::Inertia(_) => "inertia",
            ElementSpec::Shaft(_) => "shaft",
            ElementSpec::Motor(_) => "motor",
            ElementSpec::Load(_) => "load",
        }
    }

    /// Checks every field; the message names the field (`<prefix>.<field>`) and its value.
    pub fn validate(&self, prefix: &str) -> Result<(), String> {
        match self {
            ElementSpec::Inertia(s) => s.validate(prefix),
            ElementSpec::Shaft(s) => s.validate(prefix),
            ElementSpec::Motor(s) => s.validate(prefix),
            ElementSpec::Load(s) => s.validate(prefix),
        }
    }
}

/// Rigid-body state of a rotating element: rotor angle (rad) and speed (rad/s).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Rotation {
    pub angle: f64,
    pub speed: f64,
}

/// Power flowing INTO an element at a flange (W): the flange torque applied to the element
/// times the flange speed.
pub fn port_power(flange_torque: f64, flange_speed: f64) -> f64 {
    flange_torque * flange_speed
}

/// Kinetic energy `½ J ω²` (J) of a body of inertia `J` at speed `ω`.
pub fn kinetic_energy(inertia: f64, speed: f64) -> f64 {
    0.5 * inertia * speed * speed
}

/// `<prefix>.<field>` (or `<field>` without a prefix): how messages name a field.
pub(crate) fn field(prefix: &str, name: &str) -> String {
    if prefix.is_empty() {
        name.to_string()
    } else {
        format!("{prefix}.{name}")
    }
}

/// `value` must be finite and satisfy `ok`; otherwise the message names the field, the value
/// and the rule.
pub(crate) fn require(
    prefix: &str,
    name: &str,
    value: f64,
    ok: bool,
    rule: &str,
) -> Result<(), String> {
    if value.is_finite() && ok {
        Ok(())
    } else {
        Err(format!("{} = {value}: must be {rule}", field(prefix, name)))
    }
}

/// A strictly positive finite value.
pub(crate) fn positive(prefix: &str, name: &str, value: f64, unit: &str) -> Result<(), String> {
    require(
        prefix,
        name,
        value,
        value > 0.0,
        &format!("a finite number > 0 {unit}"),
    )
}

/// A non-negative finite value.
pub(crate) fn non_negative(prefix: &str, name: &str, value: f64, unit: &str) -> Result<(), String> {
    require(
        prefix,
        name,
        value,
        value >= 0.0,
        &format!("a finite number >= 0 {unit}"),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_keys_and_kinds_are_rejected() {
        let bad: Result<ElementSpec, _> =
            toml::from_str("kind = \"inertia\"\ninertia = 1.0\nmass = 2.0");
        assert!(bad.unwrap_err().to_string().contains("mass"));
        let bad: Result<ElementSpec, _> = toml::from_str("kind = \"spring\"\nstiffness = 1.0");
        assert!(bad.unwrap_err().to_string().contains("spring"));
        let ok: ElementSpec = toml::from_str("kind = \"shaft\"\nstiffness = 1e4").unwrap();
        assert_eq!(ok.kind(), "shaft");
        ok.validate("element").unwrap();
    }
}
