//! The compliant coupling of a speed port (`docs/ports.md`, "Speed causality"): the gear is
//! tied to its neighbour's flange by a torsional spring-damper, the standard co-simulation
//! coupling of a component that takes a motion and returns a torque. The torque on the gear
//! is `k(φ − θ_g) + c(ω − ω_g)` (the shaft law of `docs/elements.md` with the neighbour at
//! end a), `φ, ω` the neighbour's angle and speed and `θ_g, ω_g` the gear's carried motion;
//! `k → ∞` is the rigid limit (and a stiff problem).
//!
//! Between communication points the neighbour moves as the FMU's inputs say (FMI 2.0.x
//! §4.2.1): its speed `ω_c + ω'·s` (s = t − t_c; ω' the input derivative, 0 when held), its
//! angle `φ_c + φ'·s` when the master gives the angle's rate φ', and otherwise the integral
//! of that speed, `φ_c + ω_c s + ω' s²/2`. A held angle with a held speed would strain the
//! coupling by `k·ω·s` within every step while the gear turns on; integrating the speed keeps
//! the neighbour's angle consistent with its speed (natively: `φ0 + ω t`). With input
//! derivatives of orders 2 and 3 (a master's cubic Hermite input, `docs/cosimulation.md`)
//! both are the cubic Taylor polynomials, and a held angle integrates the speed's cubic.

/// The neighbour's motion over the current step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Neighbour {
    /// Angle and speed at `anchor` (the FMU inputs), rad and rad/s.
    pub angle: f64,
    pub speed: f64,
    /// Input derivatives from `anchor` on (0: held; a held angle follows the speed).
    pub angle_rate: f64,
    pub speed_rate: f64,
    pub anchor: f64,
    /// The rates of the ramp that ended at `anchor` (angle, speed): the slope of the
    /// neighbour's motion at the communication point for the output derivatives until new
    /// rates are set (reading the reset rates would drop `c·ω'` from the torque's derivative,
    /// an O(1) error in a master's extrapolation slope; `docs/elements.md` does the same).
    pub ended: [f64; 2],
    /// Input derivatives of orders 2 and 3 from `anchor` on, `[φ'', φ''', ω'', ω''']` (all 0:
    /// the motion above is at most a ramp, evaluated as before them).
    pub higher: [f64; 4],
}

impl Neighbour {
    /// Angle, speed and their rates at `t`.
    pub fn at(&self, t: f64) -> [f64; 4] {
        let s = t - self.anchor;
        if self.higher != [0.0; 4] {
            return self.cubic_at(s);
        }
        let speed = self.speed + self.speed_rate * s;
        if self.angle_rate != 0.0 {
            [
                self.angle + self.angle_rate * s,
                speed,
                self.angle_rate,
                self.speed_rate,
            ]
        } else {
            [
                self.angle + (self.speed + 0.5 * self.speed_rate * s) * s,
                speed,
                speed,
                self.speed_rate,
            ]
        }
    }

    /// [`Neighbour::at`] with derivatives of orders 2–3, `s` after the anchor: the Taylor
    /// cubics of angle and speed (Horner), or for a held angle (no angle derivative) the
    /// integral of the speed's cubic, a quartic.
    fn cubic_at(&self, s: f64) -> [f64; 4] {
        let [a2, a3, w2, w3] = self.higher;
        let w1 = self.speed_rate;
        let speed = self.speed + s * (w1 + s * (w2 / 2.0 + s * w3 / 6.0));
        let acceleration = w1 + s * (w2 + s * w3 / 2.0);
        if (self.angle_rate, a2, a3) != (0.0, 0.0, 0.0) {
            let a1 = self.angle_rate;
            [
                self.angle + s * (a1 + s * (a2 / 2.0 + s * a3 / 6.0)),
                speed,
                a1 + s * (a2 + s * a3 / 2.0),
                acceleration,
            ]
        } else {
            let w0 = self.speed;
            [
                self.angle + s * (w0 + s * (w1 / 2.0 + s * (w2 / 6.0 + s * w3 / 24.0))),
                speed,
                speed,
                acceleration,
            ]
        }
    }
}

/// The spring-damper of one speed port.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Coupling {
    pub stiffness: f64,
    pub damping: f64,
    pub neighbour: Neighbour,
}

impl Coupling {
    /// Torque on the gear, `k(φ − θ_g) + c(ω − ω_g)`, N·m, with the gear's angle and speed.
    pub fn torque_on_gear(&self, t: f64, gear: (f64, f64)) -> f64 {
        let [phi, omega, _, _] = self.neighbour.at(t);
        self.stiffness * (phi - gear.0) + self.damping * (omega - gear.1)
    }

    /// `d/dt` of [`Coupling::torque_on_gear`] with the gear's speed and acceleration; held
    /// rates read those of the ramp that ended at the anchor.
    pub fn torque_rate(&self, t: f64, gear_speed: f64, gear_acceleration: f64) -> f64 {
        let mut n = self.neighbour;
        if (n.angle_rate, n.speed_rate) == (0.0, 0.0) && n.higher == [0.0; 4] {
            [n.angle_rate, n.speed_rate] = n.ended;
        }
        let [_, _, phi_rate, omega_rate] = n.at(t);
        self.stiffness * (phi_rate - gear_speed) + self.damping * (omega_rate - gear_acceleration)
    }
}
