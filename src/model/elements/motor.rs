//! A motor: a torque source with a rotor, a full-load curve, torque ripple at shaft orders and
//! an optional PI speed controller (`docs/elements.md`):
//!
//! `J_m ω' = T_e + T_r + T_flange − d_m ω`, `T_r = Σ a_k cos(o_k θ + φ_k)`,
//! open loop `T_e = f · T_max(ω)`, with a controller `e = ω_ref − ω`, `T_cmd = k_p e + k_i I`,
//! `T_e = clamp(T_cmd, −T_max(ω), T_max(ω))`, `I' = e` except when `T_e` is saturated and
//! `e` pushes further into saturation (conditional-integration anti-windup), then `I' = 0`.

use schemars::JsonSchema;
use serde::Deserialize;

use super::{field, kinetic_energy, non_negative, positive, require, TorqueCurve};

/// `kind = "motor"`: flange `flange`, torque causality.
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MotorSpec {
    /// Rotor inertia J_m, kg·m² (> 0).
    #[schemars(transform = crate::scene::schema::positive, extend("x-unit" = "kg.m^2"))]
    pub inertia: f64,
    /// Viscous rotor damping to ground d_m, N·m·s/rad (>= 0, default 0).
    #[schemars(transform = crate::scene::schema::non_negative, extend("x-unit" = "N.m.s/rad"))]
    #[serde(default)]
    pub damping: f64,
    /// Full-load curve T_max(ω).
    pub curve: TorqueCurve,
    /// PI speed controller; without it the motor runs open loop at `torque_fraction`.
    #[serde(default)]
    pub controller: Option<ControllerSpec>,
    /// Torque ripple components.
    #[serde(default)]
    pub ripple: Vec<RippleSpec>,
    /// Open-loop fraction f of the full-load torque, in [0, 1] (default 1; an FMU input).
    #[schemars(transform = crate::scene::schema::fraction, extend("x-unit" = "1"))]
    #[serde(default = "one")]
    pub torque_fraction: f64,
}

fn one() -> f64 {
    1.0
}

/// `[element.controller]`: PI on the speed error.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ControllerSpec {
    /// Proportional gain k_p, N·m·s/rad (>= 0).
    #[schemars(transform = crate::scene::schema::non_negative, extend("x-unit" = "N.m.s/rad"))]
    pub kp: f64,
    /// Integral gain k_i, N·m/rad (>= 0).
    #[schemars(transform = crate::scene::schema::non_negative, extend("x-unit" = "N.m/rad"))]
    pub ki: f64,
    /// Speed reference ω_ref, rad/s (the start value of the FMU input).
    #[schemars(extend("x-unit" = "rad/s"))]
    pub speed_reference: f64,
}

/// One ripple component `a cos(o θ + φ)`.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RippleSpec {
    /// Order o per revolution of the rotor (> 0).
    #[schemars(transform = crate::scene::schema::positive, extend("x-unit" = "1"))]
    pub order: f64,
    /// Amplitude a, N·m (>= 0).
    #[schemars(transform = crate::scene::schema::non_negative, extend("x-unit" = "N.m"))]
    pub amplitude: f64,
    /// Phase φ, rad (default 0).
    #[schemars(extend("x-unit" = "rad"))]
    #[serde(default)]
    pub phase: f64,
}

/// What drives the motor besides its state: the flange torque from the driven side and the
/// two FMU inputs (`torque_fraction` acts open loop only, `speed_reference` with a
/// controller only). Also used for the rates of the inputs.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct MotorInputs {
    pub flange_torque: f64,
    pub torque_fraction: f64,
    pub speed_reference: f64,
}

/// The motor's state: rotor angle θ, speed ω and the controller's integral I (rad; stays 0
/// without a controller).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct MotorState {
    pub angle: f64,
    pub speed: f64,
    pub integral: f64,
}

/// The electromagnetic torque at a state and why: `saturated` is `+1`/`−1` when the
/// controller's command is clamped at `±T_max(ω)`, 0 otherwise.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Drive {
    pub torque: f64,
    pub integral_rate: f64,
    pub saturated: i8,
}

impl MotorSpec {
    /// Checks every field; messages name `<prefix>.<field>` and the value.
    pub fn validate(&self, prefix: &str) -> Result<(), String> {
        positive(prefix, "inertia", self.inertia, "kg.m2")?;
        non_negative(prefix, "damping", self.damping, "N.m.s/rad")?;
        self.curve.validate(&field(prefix, "curve"))?;
        let f = self.torque_fraction;
        require(
            prefix,
            "torque_fraction",
            f,
            (0.0..=1.0).contains(&f),
            "in [0, 1]",
        )?;
        if let Some(c) = &self.controller {
            let p = field(prefix, "controller");
            non_negative(&p, "kp", c.kp, "N.m.s/rad")?;
            non_negative(&p, "ki", c.ki, "N.m/rad")?;
            require(
                &p,
                "speed_reference",
                c.speed_reference,
                true,
                "finite (rad/s)",
            )?;
        }
        for (i, r) in self.ripple.iter().enumerate() {
            let p = field(prefix, &format!("ripple[{i}]"));
            positive(&p, "order", r.order, "(per revolution)")?;
            non_negative(&p, "amplitude", r.amplitude, "N.m")?;
            require(&p, "phase", r.phase, true, "finite (rad)")?;
        }
        Ok(())
    }

    /// The start inputs the spec gives: no flange torque, its `torque_fraction` and its
    /// controller's `speed_reference` (0 without a controller).
    pub fn start_inputs(&self) -> MotorInputs {
        MotorInputs {
            flange_torque: 0.0,
            torque_fraction: self.torque_fraction,
            speed_reference: self.controller.map_or(0.0, |c| c.speed_reference),
        }
    }

    /// Electromagnetic torque `T_e` and the integral's rate.
    pub fn drive(&self, s: &MotorState, u: &MotorInputs) -> Drive {
        let t_max = self.curve.max_torque(s.speed);
        let Some(c) = &self.controller else {
            return Drive {
                torque: u.torque_fraction * t_max,
                integral_rate: 0.0,
                saturated: 0,
            };
        };
        let e = u.speed_reference - s.speed;
        let cmd = c.kp * e + c.ki * s.integral;
        if cmd > t_max {
            // Saturated high: integrate only an error that reduces the command.
            Drive {
                torque: t_max,
                integral_rate: if e > 0.0 { 0.0 } else { e },
                saturated: 1,
            }
        } else if cmd < -t_max {
            Drive {
                torque: -t_max,
                integral_rate: if e < 0.0 { 0.0 } else { e },
                saturated: -1,
            }
        } else {
            Drive {
                torque: cmd,
                integral_rate: e,
                saturated: 0,
            }
        }
    }

    /// Ripple torque `T_r = Σ a cos(o θ + φ)` at rotor angle θ.
    pub fn ripple_torque(&self, angle: f64) -> f64 {
        self.ripple
            .iter()
            .map(|r| r.amplitude * (r.order * angle + r.phase).cos())
            .sum()
    }

    /// `dT_r/dt = −Σ a o ω sin(o θ + φ)`.
    pub fn ripple_rate(&self, angle: f64, speed: f64) -> f64 {
        -self
            .ripple
            .iter()
            .map(|r| r.amplitude * r.order * speed * (r.order * angle + r.phase).sin())
            .sum::<f64>()
    }

    /// The state derivative `(θ', ω', I')`.
    pub fn derivative(&self, s: &MotorState, u: &MotorInputs) -> MotorState {
        let d = self.drive(s, u);
        MotorState {
            angle: s.speed,
            speed: self.acceleration_with(s, u, d.torque),
            integral: d.integral_rate,
        }
    }

    fn acceleration_with(&self, s: &MotorState, u: &MotorInputs, t_e: f64) -> f64 {
        (t_e + self.ripple_torque(s.angle) + u.flange_torque - self.damping * s.speed)
            / self.inertia
    }

    /// `ω'`, rad/s².
    pub fn acceleration(&self, s: &MotorState, u: &MotorInputs) -> f64 {
        self.acceleration_with(s, u, self.drive(s, u).torque)
    }

    /// `dT_e/dt` given the rates of the inputs, along the solution within the current
    /// saturation regime: open loop `f' T_max + f T_max'(ω) ω'`, in the linear range
    /// `k_p (ω_ref' − ω') + k_i I'`, saturated `± T_max'(ω) ω'`.
    pub fn drive_rate(&self, s: &MotorState, u: &MotorInputs, rates: &MotorInputs) -> f64 {
        let d = self.drive(s, u);
        let a = self.acceleration_with(s, u, d.torque);
        let slope = self.curve.slope(s.speed);
        match (&self.controller, d.saturated) {
            (None, _) => {
                rates.torque_fraction * self.curve.max_torque(s.speed)
                    + u.torque_fraction * slope * a
            }
            (Some(c), 0) => c.kp * (rates.speed_reference - a) + c.ki * d.integral_rate,
            (Some(_), sat) => f64::from(sat) * slope * a,
        }
    }

    /// `ω''` given the rates of the inputs (`rates.flange_torque` = dT_flange/dt, …): the
    /// derivative of the acceleration along the solution, within the current saturation
    /// regime.
    pub fn jerk(&self, s: &MotorState, u: &MotorInputs, rates: &MotorInputs) -> f64 {
        let a = self.acceleration(s, u);
        (self.drive_rate(s, u, rates) + self.ripple_rate(s.angle, s.speed) + rates.flange_torque
            - self.damping * a)
            / self.inertia
    }

    /// Power the motor converts into mechanical power at its air gap, `(T_e + T_r) ω`, W.
    pub fn source_power(&self, s: &MotorState, u: &MotorInputs) -> f64 {
        (self.drive(s, u).torque + self.ripple_torque(s.angle)) * s.speed
    }

    /// Stored kinetic energy of the rotor `½ J_m ω²`, J.
    pub fn kinetic_energy(&self, speed: f64) -> f64 {
        kinetic_energy(self.inertia, speed)
    }

    /// Power dissipated by the rotor damping `d_m ω²`, W.
    pub fn dissipated_power(&self, speed: f64) -> f64 {
        self.damping * speed * speed
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn motor(controller: Option<ControllerSpec>) -> MotorSpec {
        MotorSpec {
            inertia: 0.01,
            damping: 0.001,
            curve: TorqueCurve {
                speed: vec![0.0, 400.0, 1000.0],
                torque: vec![150.0, 150.0, 60.0],
            },
            controller,
            ripple: vec![RippleSpec {
                order: 6.0,
                amplitude: 3.0,
                phase: 0.2,
            }],
            torque_fraction: 1.0,
        }
    }

    #[test]
    fn open_loop_follows_the_curve_with_ripple() {
        let m = motor(None);
        let s = MotorState {
            angle: 0.3,
            speed: 700.0,
            integral: 0.0,
        };
        let u = MotorInputs {
            flange_torque: -90.0,
            torque_fraction: 0.5,
            speed_reference: 0.0,
        };
        let t_e = 0.5 * 105.0;
        let t_r = 3.0 * (6.0f64 * 0.3 + 0.2).cos();
        let want = (t_e + t_r - 90.0 - 0.001 * 700.0) / 0.01;
        let d = m.derivative(&s, &u);
        assert!((d.speed - want).abs() < 1e-9 * want.abs());
        assert_eq!(d.angle, 700.0);
        assert_eq!(d.integral, 0.0);
    }

    #[test]
    fn anti_windup_stops_integrating_into_saturation() {
        let m = motor(Some(ControllerSpec {
            kp: 10.0,
            ki: 100.0,
            speed_reference: 500.0,
        }));
        let u = m.start_inputs();
        // Far below the reference: the command exceeds T_max, the error pushes further.
        let s = MotorState {
            angle: 0.0,
            speed: 0.0,
            integral: 0.0,
        };
        let d = m.drive(&s, &u);
        assert_eq!((d.torque, d.integral_rate, d.saturated), (150.0, 0.0, 1));
        // Above the reference with a large integral: saturated high, but e < 0 unwinds.
        let s = MotorState {
            angle: 0.0,
            speed: 510.0,
            integral: 10.0,
        };
        let d = m.drive(&s, &u);
        assert_eq!(d.saturated, 1);
        assert_eq!(d.integral_rate, -10.0);
        // In the linear range: I' = e, T_e = kp e + ki I.
        let s = MotorState {
            angle: 0.0,
            speed: 499.0,
            integral: 0.5,
        };
        let d = m.drive(&s, &u);
        assert_eq!((d.torque, d.integral_rate, d.saturated), (60.0, 1.0, 0));
    }

    /// The jerk is the time derivative of the acceleration along the solution: compared with
    /// a central difference of the acceleration along `(θ', ω', I')` and the input rates.
    #[test]
    fn jerk_is_the_rate_of_the_acceleration() {
        for m in [
            motor(None),
            motor(Some(ControllerSpec {
                kp: 0.5,
                ki: 2.0,
                speed_reference: 600.0,
            })),
        ] {
            let s = MotorState {
                angle: 0.3,
                speed: 590.0,
                integral: 1.0,
            };
            let u = MotorInputs {
                flange_torque: -40.0,
                torque_fraction: 0.7,
                speed_reference: 600.0,
            };
            let r = MotorInputs {
                flange_torque: 30.0,
                torque_fraction: -0.1,
                speed_reference: 5.0,
            };
            let at = |dt: f64| {
                let d = m.derivative(&s, &u);
                let st = MotorState {
                    angle: s.angle + d.angle * dt,
                    speed: s.speed + d.speed * dt,
                    integral: s.integral + d.integral * dt,
                };
                let ut = MotorInputs {
                    flange_torque: u.flange_torque + r.flange_torque * dt,
                    torque_fraction: u.torque_fraction + r.torque_fraction * dt,
                    speed_reference: u.speed_reference + r.speed_reference * dt,
                };
                m.acceleration(&st, &ut)
            };
            let h = 1e-7;
            let fd = (at(h) - at(-h)) / (2.0 * h);
            let j = m.jerk(&s, &u, &r);
            assert!((fd - j).abs() < 1e-5 * j.abs().max(1.0), "{fd} vs {j}");
        }
    }

    #[test]
    fn validation_names_field_and_value() {
        let mut m = motor(None);
        m.ripple[0].order = 0.0;
        let e = m.validate("element").unwrap_err();
        assert!(e.contains("element.ripple[0].order = 0"), "{e}");
        let mut m = motor(Some(ControllerSpec {
            kp: -1.0,
            ki: 0.0,
            speed_reference: 1.0,
        }));
        assert!(m
            .validate("element")
            .unwrap_err()
            .contains("element.controller.kp = -1"));
        m.controller = None;
        m.torque_fraction = 1.5;
        assert!(m
            .validate("element")
            .unwrap_err()
            .contains("element.torque_fraction = 1.5"));
    }
}
