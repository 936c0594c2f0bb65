//! Drivetrain elements coupled to a train with carried rotation (`docs/ports.md`, "Elements
//! in the scene"): motors, loads and toothless inertias as bodies of their own, joined to the
//! train's input and output gears and to each other by torsional shafts.
//!
//! The element physics is that of `crate::model::elements` (the same functions as the
//! element FMUs). Each element body adds three states after `[ξ, ξ', η, η']`: its angle and
//! speed relative to its reference rotation `w_e Ω_ref t` (`w_e` the nominal ratio of the
//! train body it is coupled to, so the error control sees the deviation, as for η) and the
//! motor's PI integral (rate 0 for other bodies). The shafts are stateless; the torques they
//! apply to the input and output gears replace the port torques of the train.

use crate::model::elements::{MotorInputs, MotorState};
use crate::scene::train::elements::{ElementKind, Elements, ShaftEnd};

/// A shaft end in the model: a body of the carried train or an element body.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum End {
    Train(usize),
    Element(usize),
}

#[derive(Debug, Clone)]
pub(super) struct Attached {
    elements: Elements,
    /// Per element body: nominal speed over `Ω_ref`.
    ratio: Vec<f64>,
    ends: Vec<[End; 2]>,
    /// Carried bodies of the input and output gear.
    input_body: usize,
    output_body: usize,
    /// First element state (`2m + 2r`).
    base: usize,
}

/// Motion of every body at `(t, y)`: train bodies through the carried rotation.
pub(super) trait TrainMotion {
    fn train_motion(&self, b: usize, t: f64, y: &[f64]) -> (f64, f64);
    fn train_ratio(&self, b: usize) -> f64;
    fn reference_speed(&self) -> f64;
}

impl Attached {
    /// `body_of_gear` maps a scene gear to its carried body.
    pub(super) fn new(
        elements: &Elements,
        body_of_gear: &dyn Fn(usize) -> usize,
        input_gear: usize,
        output_gear: usize,
        rot: &dyn TrainMotion,
        base: usize,
    ) -> Attached {
        let ends: Vec<[End; 2]> = (elements.shafts.iter())
            .map(|s| {
                s.ends.map(|e| match e {
                    ShaftEnd::Gear(g) => End::Train(body_of_gear(g)),
                    ShaftEnd::Element(i) => End::Element(i),
                })
            })
            .collect();
        // Nominal ratios: a shaft keeps the speed (validation ensures every element body is
        // reached from the train).
        let mut ratio = vec![f64::NAN; elements.bodies.len()];
        let mut changed = true;
        while changed {
            changed = false;
            for e in &ends {
                for (x, y) in [(e[0], e[1]), (e[1], e[0])] {
                    let known = match x {
                        End::Train(b) => Some(rot.train_ratio(b)),
                        End::Element(i) => Some(ratio[i]).filter(|r| !r.is_nan()),
                    };
                    if let (Some(r), End::Element(j)) = (known, y) {
                        if ratio[j].is_nan() {
                            ratio[j] = r;
                            changed = true;
                        }
                    }
                }
            }
        }
        Attached {
            elements: elements.clone(),
            ratio,
            ends,
            input_body: body_of_gear(input_gear),
            output_body: body_of_gear(output_gear),
            base,
        }
    }

    pub(super) fn dim(&self) -> usize {
        3 * self.elements.bodies.len()
    }

    fn motion(&self, end: End, t: f64, y: &[f64], rot: &dyn TrainMotion) -> (f64, f64) {
        match end {
            End::Train(b) => rot.train_motion(b, t, y),
            End::Element(i) => {
                let w = self.ratio[i] * rot.reference_speed();
                let k = self.base + 3 * i;
                (w * t + y[k], w + y[k + 1])
            }
        }
    }

    /// Torque τ of every shaft, `k(θ_a − θ_b) + c(ω_a − ω_b)`.
    fn shaft_torques(&self, t: f64, y: &[f64], rot: &dyn TrainMotion) -> Vec<f64> {
        (self.elements.shafts.iter().zip(&self.ends))
            .map(|(s, e)| {
                let (a, wa) = self.motion(e[0], t, y, rot);
                let (b, wb) = self.motion(e[1], t, y, rot);
                s.spec.torque(a, b, wa, wb)
            })
            .collect()
    }

    /// Sum of the shaft torques on an end (`−τ` on end a, `+τ` on end b).
    fn torque_on(&self, end: End, tau: &[f64]) -> f64 {
        (self.ends.iter().zip(tau))
            .map(|(e, &t)| {
                let (on_a, on_b) = (e[0] == end, e[1] == end);
                f64::from(u8::from(on_b)) * t - f64::from(u8::from(on_a)) * t
            })
            .sum()
    }

    /// The train's input torque and load torque (`−` the torque on the output gear) from the
    /// shafts at `(t, y)`.
    pub(super) fn train_torques(&self, t: f64, y: &[f64], rot: &dyn TrainMotion) -> (f64, f64) {
        let tau = self.shaft_torques(t, y, rot);
        (
            self.torque_on(End::Train(self.input_body), &tau),
            -self.torque_on(End::Train(self.output_body), &tau),
        )
    }

    fn motor_state(&self, i: usize, t: f64, y: &[f64], rot: &dyn TrainMotion) -> MotorState {
        let (angle, speed) = self.motion(End::Element(i), t, y, rot);
        MotorState {
            angle,
            speed,
            integral: y[self.base + 3 * i + 2],
        }
    }

    /// Element state derivatives into `dy[base..]`; with them each body's source torque
    /// (`T_e + T_r` of a motor, 0 otherwise) when `sources` is given.
    pub(super) fn rhs(
        &self,
        t: f64,
        y: &[f64],
        dy: &mut [f64],
        rot: &dyn TrainMotion,
        mut sources: Option<&mut Vec<f64>>,
    ) {
        let tau = self.shaft_torques(t, y, rot);
        for (i, body) in self.elements.bodies.iter().enumerate() {
            let k = self.base + 3 * i;
            let on = self.torque_on(End::Element(i), &tau);
            let (_, speed) = self.motion(End::Element(i), t, y, rot);
            let (acc, rate, source) = match &body.kind {
                ElementKind::Motor(spec) => {
                    let s = self.motor_state(i, t, y, rot);
                    let u = MotorInputs {
                        flange_torque: on,
                        ..spec.start_inputs()
                    };
                    let d = spec.derivative(&s, &u);
                    let drive = spec.drive(&s, &u).torque + spec.ripple_torque(s.angle);
                    (d.speed, d.integral, drive)
                }
                ElementKind::Load(spec) => (spec.acceleration(speed, on), 0.0, 0.0),
                ElementKind::Inertia(spec) => (spec.acceleration(speed, on, 0.0), 0.0, 0.0),
            };
            // The reference rotation has no acceleration.
            dy[k] = y[k + 1];
            dy[k + 1] = acc;
            dy[k + 2] = rate;
            if let Some(s) = sources.as_deref_mut() {
                s.push(source);
            }
        }
    }

    /// Start states: every body at its nominal speed, the shafts pre-twisted by their start
    /// torques (`θ_a − θ_b = τ0/k`) from the train bodies' start angles outward.
    pub(super) fn initial_state(&self, y: &mut [f64], rot: &dyn TrainMotion) {
        let n = self.elements.bodies.len();
        let mut known = vec![false; n];
        let mut changed = true;
        while changed {
            changed = false;
            for (s, e) in self.elements.shafts.iter().zip(&self.ends) {
                let twist = s.start_torque / s.spec.stiffness;
                for (x, other, sign) in [(e[1], e[0], 1.0), (e[0], e[1], -1.0)] {
                    let known_x = match x {
                        End::Train(_) => true,
                        End::Element(i) => known[i],
                    };
                    if let (true, End::Element(j)) = (known_x, other) {
                        if !known[j] {
                            let angle = self.motion(x, 0.0, y, rot).0 + sign * twist;
                            y[self.base + 3 * j] = angle;
                            y[self.base + 3 * j + 1] = 0.0;
                            y[self.base + 3 * j + 2] = 0.0;
                            known[j] = true;
                            changed = true;
                        }
                    }
                }
            }
        }
    }

    /// Output names: per element body `<name>.angle`, `.speed`, `.acceleration`, per motor
    /// `<name>.drive_torque` (`T_e + T_r`), per shaft `<name>.torque` (τ).
    pub(super) fn names(&self) -> Vec<String> {
        let mut names = Vec::new();
        for b in &self.elements.bodies {
            for q in ["angle", "speed", "acceleration"] {
                names.push(format!("{}.{q}", b.name));
            }
            if matches!(b.kind, ElementKind::Motor(_)) {
                names.push(format!("{}.drive_torque", b.name));
            }
        }
        for s in &self.elements.shafts {
            names.push(format!("{}.torque", s.name));
        }
        names
    }

    /// Values of [`Attached::names`]; `dy` the state derivative at `(t, y)`.
    pub(super) fn outputs(
        &self,
        t: f64,
        y: &[f64],
        dy: &[f64],
        rot: &dyn TrainMotion,
        out: &mut Vec<f64>,
    ) {
        let mut sources = Vec::new();
        let mut scratch = dy.to_vec();
        self.rhs(t, y, &mut scratch, rot, Some(&mut sources));
        for (i, b) in self.elements.bodies.iter().enumerate() {
            let (angle, speed) = self.motion(End::Element(i), t, y, rot);
            out.extend([angle, speed, dy[self.base + 3 * i + 1]]);
            if matches!(b.kind, ElementKind::Motor(_)) {
                out.push(sources[i]);
            }
        }
        out.extend(self.shaft_torques(t, y, rot));
    }
}
