//! The element's equations as the FMU integrates and reads them: the state vector, the
//! right-hand side with the inputs interpolated over the step, the outputs and their first
//! time derivatives. The physics is [`crate::model::elements`]; this module only maps it onto
//! the FMU's state, input and output vectors (orders as in [`super::variables`]).

use crate::fmi::model::input_polynomial;
use crate::model::elements::{ElementSpec, MotorInputs, MotorSpec, MotorState};
use crate::solve::HybridSystem;

/// Number of continuous states: angle and speed (and the PI integral of a motor with a
/// controller); none for the shaft.
pub fn dim(spec: &ElementSpec) -> usize {
    match spec {
        ElementSpec::Shaft(_) => 0,
        ElementSpec::Motor(m) if m.controller.is_some() => 3,
        _ => 2,
    }
}

fn motor_state(y: &[f64]) -> MotorState {
    MotorState {
        angle: y[0],
        speed: y[1],
        integral: y.get(2).copied().unwrap_or(0.0),
    }
}

/// The motor's inputs from the FMU inputs `[flange.torque, torque_fraction |
/// controller.speed_reference]`; the input the motor does not have keeps its scene value (a rate of 0).
fn motor_inputs(m: &MotorSpec, u: &[f64], base: MotorInputs) -> MotorInputs {
    if m.controller.is_some() {
        MotorInputs {
            flange_torque: u[0],
            speed_reference: u[1],
            ..base
        }
    } else {
        MotorInputs {
            flange_torque: u[0],
            torque_fraction: u[1],
            ..base
        }
    }
}

/// The state derivative at inputs `u`.
pub fn rhs(spec: &ElementSpec, y: &[f64], u: &[f64], dy: &mut [f64]) {
    match spec {
        ElementSpec::Inertia(s) => {
            dy[0] = y[1];
            dy[1] = s.acceleration(y[1], u[0], u[1]);
        }
        ElementSpec::Load(s) => {
            dy[0] = y[1];
            dy[1] = s.acceleration(y[1], u[0]);
        }
        ElementSpec::Motor(m) => {
            let d = m.derivative(&motor_state(y), &motor_inputs(m, u, m.start_inputs()));
            dy[0] = d.angle;
            dy[1] = d.speed;
            if let Some(slot) = dy.get_mut(2) {
                *slot = d.integral;
            }
        }
        ElementSpec::Shaft(_) => {}
    }
}

/// The outputs at state `y` and inputs `u`, in value-reference order (cleared first).
pub fn outputs(spec: &ElementSpec, y: &[f64], u: &[f64], out: &mut Vec<f64>) {
    out.clear();
    match spec {
        ElementSpec::Inertia(s) => {
            let a = s.acceleration(y[1], u[0], u[1]);
            out.extend_from_slice(&[y[0], y[1], a, y[0], y[1], a]);
        }
        ElementSpec::Shaft(s) => {
            let tau = s.torque(u[0], u[2], u[1], u[3]);
            let (on_a, on_b) = s.flange_torques(tau);
            out.extend_from_slice(&[on_a, on_b, tau]);
        }
        ElementSpec::Motor(m) => {
            let (st, mu) = (motor_state(y), motor_inputs(m, u, m.start_inputs()));
            let a = m.acceleration(&st, &mu);
            let t_e = m.drive(&st, &mu).torque;
            out.extend_from_slice(&[y[0], y[1], a, t_e, m.ripple_torque(y[0])]);
        }
        ElementSpec::Load(s) => {
            let a = s.acceleration(y[1], u[0]);
            out.extend_from_slice(&[y[0], y[1], a, s.resisting_torque(y[1])]);
        }
    }
}

/// The first time derivatives of the outputs at state `y`, inputs `u` and input rates `du`,
/// in value-reference order (cleared first): d/dt angle = speed, d/dt speed = acceleration,
/// d/dt acceleration from the element's jerk, d/dt of a torque from its law. For the shaft
/// the rate of a flange angle is that flange's speed input (port kinematics) and the rate of
/// a speed is its input rate.
pub fn output_rates(spec: &ElementSpec, y: &[f64], u: &[f64], du: &[f64], out: &mut Vec<f64>) {
    out.clear();
    match spec {
        ElementSpec::Inertia(s) => {
            let a = s.acceleration(y[1], u[0], u[1]);
            let j = s.jerk(a, du[0], du[1]);
            out.extend_from_slice(&[y[1], a, j, y[1], a, j]);
        }
        ElementSpec::Shaft(s) => {
            let rate = s.torque_rate(u[1], u[3], du[1], du[3]);
            out.extend_from_slice(&[-rate, rate, rate]);
        }
        ElementSpec::Motor(m) => {
            let (st, mu) = (motor_state(y), motor_inputs(m, u, m.start_inputs()));
            let rates = motor_inputs(m, du, MotorInputs::default());
            let a = m.acceleration(&st, &mu);
            out.extend_from_slice(&[
                y[1],
                a,
                m.jerk(&st, &mu, &rates),
                m.drive_rate(&st, &mu, &rates),
                m.ripple_rate(y[0], y[1]),
            ]);
        }
        ElementSpec::Load(s) => {
            let a = s.acceleration(y[1], u[0]);
            let slope = s.viscous + 2.0 * s.drag * y[1].abs();
            out.extend_from_slice(&[y[1], a, s.jerk(y[1], a, du[0]), slope * a]);
        }
    }
}

/// Entry `k` of [`output_rates`], bit for bit, computing only what it needs where that is
/// cheap: a body's angle rate (its speed) and speed rate (its acceleration), which a host
/// reads at every communication step, without the jerk and torque rates.
pub fn output_rate(spec: &ElementSpec, k: usize, y: &[f64], u: &[f64], du: &[f64]) -> f64 {
    match (spec, k) {
        (ElementSpec::Inertia(_), 0 | 3) | (ElementSpec::Motor(_) | ElementSpec::Load(_), 0) => {
            y[1]
        }
        (ElementSpec::Inertia(s), 1 | 4) => s.acceleration(y[1], u[0], u[1]),
        (ElementSpec::Motor(m), 1) => {
            let (st, mu) = (motor_state(y), motor_inputs(m, u, m.start_inputs()));
            m.acceleration(&st, &mu)
        }
        (ElementSpec::Load(s), 1) => s.acceleration(y[1], u[0]),
        _ => {
            let mut out = Vec::with_capacity(6);
            output_rates(spec, y, u, du, &mut out);
            out[k]
        }
    }
}

/// The derivative of [`input_polynomial`] at `dt`: `du + u''·dt + u⁽³⁾·dt²/2` (`du` itself without
/// higher derivatives).
pub fn input_rate_at(du: f64, higher: [f64; 2], dt: f64) -> f64 {
    if higher == [0.0; 2] {
        return du;
    }
    du + dt * (higher[0] + dt * higher[1] / 2.0)
}

/// The element over one communication step: the inputs follow [`input_polynomial`] (input
/// interpolation up to order 3, FMI 2.0.x §4.2.1; no derivatives is the zero-order hold), so
/// the integrator sees the polynomial.
pub struct StepSystem<'a> {
    pub spec: &'a ElementSpec,
    pub u: &'a [f64],
    pub du: &'a [f64],
    pub du_higher: &'a [[f64; 2]],
    pub t0: f64,
    /// Scratch for the interpolated inputs (interior mutability: `rhs` takes `&self`).
    pub scratch: std::cell::RefCell<Vec<f64>>,
}

impl HybridSystem for StepSystem<'_> {
    fn dim(&self) -> usize {
        dim(self.spec)
    }

    fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]) {
        let mut ut = self.scratch.borrow_mut();
        ut.clear();
        let dt = t - self.t0;
        let inputs = self.u.iter().zip(self.du).zip(self.du_higher);
        ut.extend(inputs.map(|((&u, &du), &higher)| input_polynomial(u, du, higher, dt)));
        rhs(self.spec, y, &ut, dy);
    }
}
