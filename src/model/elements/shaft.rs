//! A massless torsional shaft (spring-damper) between two speed-causality flanges:
//! `τ = k (φ_a − φ_b) + c (ω_a − ω_b)` (`docs/elements.md`).

use schemars::JsonSchema;
use serde::Deserialize;

use super::{non_negative, positive};

/// `kind = "shaft"`: stateless, direct feedthrough from the angles and speeds of its ends.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ShaftSpec {
    /// Torsional stiffness k, N·m/rad (> 0).
    #[schemars(transform = crate::scene::schema::positive, extend("x-unit" = "N.m/rad"))]
    pub stiffness: f64,
    /// Torsional damping c, N·m·s/rad (>= 0, default 0).
    #[schemars(transform = crate::scene::schema::non_negative, extend("x-unit" = "N.m.s/rad"))]
    #[serde(default)]
    pub damping: f64,
}

impl ShaftSpec {
    /// Checks every field; messages name `<prefix>.<field>` and the value.
    pub fn validate(&self, prefix: &str) -> Result<(), String> {
        positive(prefix, "stiffness", self.stiffness, "N.m/rad")?;
        non_negative(prefix, "damping", self.damping, "N.m.s/rad")
    }

    /// The shaft torque `τ = k (φ_a − φ_b) + c (ω_a − ω_b)`: positive when end a leads.
    pub fn torque(&self, angle_a: f64, angle_b: f64, speed_a: f64, speed_b: f64) -> f64 {
        self.stiffness * (angle_a - angle_b) + self.damping * (speed_a - speed_b)
    }

    /// The torques the shaft exerts ON its neighbours, `(−τ, +τ)` on the bodies at ends a and
    /// b: the body at a is held back, the body at b driven. These are the shaft FMU's outputs
    /// `flange_a.torque` and `flange_b.torque`, connected directly to the neighbours' torque
    /// inputs (the one place where an output torque is the torque exerted on the neighbour).
    pub fn flange_torques(&self, torque: f64) -> (f64, f64) {
        (-torque, torque)
    }

    /// `τ' = k (ω_a − ω_b) + c (ω_a' − ω_b')`: the rate of the shaft torque, from the speeds
    /// (the rates of the angles) and the accelerations of the ends.
    pub fn torque_rate(&self, speed_a: f64, speed_b: f64, accel_a: f64, accel_b: f64) -> f64 {
        self.stiffness * (speed_a - speed_b) + self.damping * (accel_a - accel_b)
    }

    /// Elastic energy `½ k (φ_a − φ_b)²`, J.
    pub fn potential_energy(&self, angle_a: f64, angle_b: f64) -> f64 {
        let twist = angle_a - angle_b;
        0.5 * self.stiffness * twist * twist
    }

    /// Power dissipated by the damping, `c (ω_a − ω_b)²`, W.
    pub fn dissipated_power(&self, speed_a: f64, speed_b: f64) -> f64 {
        let slip = speed_a - speed_b;
        self.damping * slip * slip
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The power the shaft takes from its neighbours (`−(T_on_a ω_a + T_on_b ω_b)`) is the
    /// rate of its elastic energy plus its dissipation.
    #[test]
    fn power_balance_is_exact() {
        let s = ShaftSpec {
            stiffness: 2e4,
            damping: 3.0,
        };
        let (pa, pb, wa, wb) = (0.01, 0.002, 100.0, 99.5);
        let tau = s.torque(pa, pb, wa, wb);
        let (on_a, on_b) = s.flange_torques(tau);
        let into_shaft = -(on_a * wa + on_b * wb);
        let elastic_rate = s.stiffness * (pa - pb) * (wa - wb);
        let rhs = elastic_rate + s.dissipated_power(wa, wb);
        assert!((into_shaft - rhs).abs() < 1e-9 * rhs.abs());
    }

    #[test]
    fn validation_names_field_and_value() {
        let s = ShaftSpec {
            stiffness: 0.0,
            damping: 1.0,
        };
        let e = s.validate("element").unwrap_err();
        assert!(e.contains("element.stiffness = 0"), "{e}");
        let s = ShaftSpec {
            stiffness: 1.0,
            damping: -1.0,
        };
        assert!(s.validate("").unwrap_err().contains("damping = -1"));
    }
}
