//! A rigid inertia with two flanges: `J ω' = T_a + T_b − d ω` (`docs/elements.md`).

use schemars::JsonSchema;
use serde::Deserialize;

use super::{kinetic_energy, non_negative, positive};

/// `kind = "inertia"`: one rigid body between `flange_a` and `flange_b`, both torque
/// causality, with optional viscous damping to ground.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct InertiaSpec {
    /// Polar moment of inertia J, kg·m² (> 0).
    #[schemars(transform = crate::scene::schema::positive, extend("x-unit" = "kg.m^2"))]
    pub inertia: f64,
    /// Viscous damping to ground d, N·m·s/rad (>= 0, default 0).
    #[schemars(transform = crate::scene::schema::non_negative, extend("x-unit" = "N.m.s/rad"))]
    #[serde(default)]
    pub damping: f64,
}

impl InertiaSpec {
    /// Checks every field; messages name `<prefix>.<field>` and the value.
    pub fn validate(&self, prefix: &str) -> Result<(), String> {
        positive(prefix, "inertia", self.inertia, "kg.m2")?;
        non_negative(prefix, "damping", self.damping, "N.m.s/rad")
    }

    /// `ω' = (T_a + T_b − d ω) / J` for the flange torques applied to the body.
    pub fn acceleration(&self, speed: f64, torque_a: f64, torque_b: f64) -> f64 {
        (torque_a + torque_b - self.damping * speed) / self.inertia
    }

    /// `ω'' = (T_a' + T_b' − d ω') / J`: the rate of the acceleration given the torque rates.
    pub fn jerk(&self, acceleration: f64, torque_rate_a: f64, torque_rate_b: f64) -> f64 {
        (torque_rate_a + torque_rate_b - self.damping * acceleration) / self.inertia
    }

    /// Stored kinetic energy `½ J ω²`, J.
    pub fn kinetic_energy(&self, speed: f64) -> f64 {
        kinetic_energy(self.inertia, speed)
    }

    /// Power dissipated by the damping to ground, `d ω²`, W.
    pub fn dissipated_power(&self, speed: f64) -> f64 {
        self.damping * speed * speed
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn validation_names_field_and_value() {
        let s = InertiaSpec {
            inertia: -0.5,
            damping: 0.0,
        };
        let e = s.validate("element").unwrap_err();
        assert!(e.contains("element.inertia") && e.contains("-0.5"), "{e}");
        let s = InertiaSpec {
            inertia: 1.0,
            damping: f64::NAN,
        };
        assert!(s.validate("").unwrap_err().contains("damping = NaN"));
    }

    /// Power balance: input power − dissipation = d/dt(½ J ω²) at any state.
    #[test]
    fn power_balance_is_exact() {
        let s = InertiaSpec {
            inertia: 0.3,
            damping: 0.02,
        };
        let (w, ta, tb) = (12.0, 5.0, -2.0);
        let a = s.acceleration(w, ta, tb);
        let stored_rate = s.inertia * w * a;
        let net = super::super::port_power(ta, w) + super::super::port_power(tb, w)
            - s.dissipated_power(w);
        assert!((stored_rate - net).abs() < 1e-12 * net.abs().max(1.0));
    }
}
