//! A vehicle-like load: inertia with a constant resisting torque, viscous and quadratic drag,
//! `J_L ω' = T_flange − T_0 − c_v ω − c_d ω|ω|` (`docs/elements.md`).

use schemars::JsonSchema;
use serde::Deserialize;

use super::{kinetic_energy, non_negative, positive};

/// `kind = "load"`: one flange `flange`, torque causality.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct LoadSpec {
    /// Inertia J_L, kg·m² (> 0).
    #[schemars(transform = crate::scene::schema::positive, extend("x-unit" = "kg.m^2"))]
    pub inertia: f64,
    /// Constant resisting torque T_0, N·m (>= 0, default 0). It acts as written, whatever
    /// the speed (a rolling resistance that does not reverse; `docs/elements.md`).
    #[schemars(transform = crate::scene::schema::non_negative, extend("x-unit" = "N.m"))]
    #[serde(default)]
    pub torque: f64,
    /// Viscous coefficient c_v, N·m·s/rad (>= 0, default 0).
    #[schemars(transform = crate::scene::schema::non_negative, extend("x-unit" = "N.m.s/rad"))]
    #[serde(default)]
    pub viscous: f64,
    /// Quadratic drag coefficient c_d, N·m·s²/rad² (>= 0, default 0).
    #[schemars(transform = crate::scene::schema::non_negative, extend("x-unit" = "N.m.s^2/rad^2"))]
    #[serde(default)]
    pub drag: f64,
}

impl LoadSpec {
    /// Checks every field; messages name `<prefix>.<field>` and the value.
    pub fn validate(&self, prefix: &str) -> Result<(), String> {
        positive(prefix, "inertia", self.inertia, "kg.m2")?;
        non_negative(prefix, "torque", self.torque, "N.m")?;
        non_negative(prefix, "viscous", self.viscous, "N.m.s/rad")?;
        non_negative(prefix, "drag", self.drag, "N.m.s2/rad2")
    }

    /// The resisting torque `T_0 + c_v ω + c_d ω|ω|`, N·m.
    pub fn resisting_torque(&self, speed: f64) -> f64 {
        self.torque + self.viscous * speed + self.drag * speed * speed.abs()
    }

    /// `ω' = (T_flange − T_0 − c_v ω − c_d ω|ω|) / J_L`.
    pub fn acceleration(&self, speed: f64, flange_torque: f64) -> f64 {
        (flange_torque - self.resisting_torque(speed)) / self.inertia
    }

    /// `ω'' = (T_flange' − (c_v + 2 c_d |ω|) ω') / J_L`.
    pub fn jerk(&self, speed: f64, acceleration: f64, torque_rate: f64) -> f64 {
        let slope = self.viscous + 2.0 * self.drag * speed.abs();
        (torque_rate - slope * acceleration) / self.inertia
    }

    /// Stored kinetic energy `½ J_L ω²`, J.
    pub fn kinetic_energy(&self, speed: f64) -> f64 {
        kinetic_energy(self.inertia, speed)
    }

    /// Power taken by the resisting torque, `(T_0 + c_v ω + c_d ω|ω|) ω`, W (the work done
    /// against the load; negative for `T_0` when the load runs backwards).
    pub fn dissipated_power(&self, speed: f64) -> f64 {
        self.resisting_torque(speed) * speed
    }

    /// The speed at which a constant flange torque is balanced by the resistance (`None`
    /// when the torque does not exceed `T_0`): the positive root of
    /// `c_d ω² + c_v ω + T_0 − T = 0`.
    pub fn steady_speed(&self, flange_torque: f64) -> Option<f64> {
        let excess = flange_torque - self.torque;
        if excess <= 0.0 {
            return None;
        }
        if self.drag == 0.0 {
            return (self.viscous > 0.0).then(|| excess / self.viscous);
        }
        let (a, b) = (self.drag, self.viscous);
        // Stable form of (−b + √(b² + 4 a e)) / 2a.
        Some(2.0 * excess / (b + (b * b + 4.0 * a * excess).sqrt()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steady_speed_balances_the_drag() {
        let s = LoadSpec {
            inertia: 1.0,
            torque: 5.0,
            viscous: 0.1,
            drag: 0.002,
        };
        let w = s.steady_speed(200.0).unwrap();
        assert!(s.acceleration(w, 200.0).abs() < 1e-12, "{w}");
        assert!(s.steady_speed(4.0).is_none());
    }

    #[test]
    fn validation_names_field_and_value() {
        let s = LoadSpec {
            inertia: 1.0,
            torque: 0.0,
            viscous: 0.0,
            drag: -3.0,
        };
        let e = s.validate("element").unwrap_err();
        assert!(e.contains("element.drag = -3"), "{e}");
    }
}
