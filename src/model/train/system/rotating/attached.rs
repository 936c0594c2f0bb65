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

/// The elements as rows of the piecewise-LTI system ([`super::lti`]).
impl Attached {
    /// Why the elements are not linear in the state, or `None`.
    pub(super) fn not_lti_reason(&self) -> Option<String> {
        self.elements.bodies.iter().find_map(|b| match &b.kind {
            ElementKind::Motor(_) => Some(format!(
                "[[motor]] '{}': its speed-torque curve T_max(ω) (with its ripple and PI controller) \
                 is not linear in the state",
                b.name
            )),
            ElementKind::Load(l) if l.drag != 0.0 => Some(format!(
                "[[load]] '{}': its drag c_d ω|ω| (drag = {:?}) is not linear in the speed",
                b.name, l.drag
            )),
            _ => None,
        })
    }

    /// Adds `k θ + c θ'` of a shaft end to `row` (see [`super::Carried::add_body_rows`]).
    fn add_end_rows(&self, end: End, k: f64, c: f64, rot: &super::Carried, row: &mut [f64]) {
        match end {
            End::Train(b) => rot.add_body_rows(b, k, c, row),
            End::Element(i) => {
                let j = self.base + 3 * i;
                row[j] += k;
                row[j + 1] += c;
                let last = row.len() - 1;
                row[last] += c * self.ratio[i] * rot.reference_speed();
            }
        }
    }

    /// Every shaft torque τ as a row over the lifted state (`nz` entries, constant last). The
    /// reference rotations `w Ω_ref t` of its two ends cancel: a shaft keeps the nominal ratio.
    fn shaft_rows(&self, rot: &super::Carried, nz: usize) -> Vec<Vec<f64>> {
        (self.elements.shafts.iter().zip(&self.ends))
            .map(|(s, e)| {
                let mut row = vec![0.0; nz];
                let (k, c) = (s.spec.stiffness, s.spec.damping);
                self.add_end_rows(e[0], k, c, rot, &mut row);
                self.add_end_rows(e[1], -k, -c, rot, &mut row);
                row
            })
            .collect()
    }

    /// The torque on `end` (see [`Attached::torque_on`]) as a row.
    fn torque_on_row(&self, end: End, rows: &[Vec<f64>], nz: usize) -> Vec<f64> {
        let mut out = vec![0.0; nz];
        for (e, row) in self.ends.iter().zip(rows) {
            let sign = f64::from(u8::from(e[1] == end)) - f64::from(u8::from(e[0] == end));
            if sign != 0.0 {
                for (o, v) in out.iter_mut().zip(row) {
                    *o += sign * v;
                }
            }
        }
        out
    }

    /// The train's input and load torque (see [`Attached::train_torques`]) as rows.
    pub(super) fn train_torque_rows(&self, rot: &super::Carried, nz: usize) -> [Vec<f64>; 2] {
        let rows = self.shaft_rows(rot, nz);
        let input = self.torque_on_row(End::Train(self.input_body), &rows, nz);
        let mut load = self.torque_on_row(End::Train(self.output_body), &rows, nz);
        for v in &mut load {
            *v = -*v;
        }
        [input, load]
    }

    /// Rows of the element states: angle' = speed, speed' = `(T_on − T_0 − c ω)/J` with
    /// `ω = w Ω_ref + speed` (a load: `T_0` its torque, `c` its viscous coefficient; an
    /// inertia: its damping), integral' = 0. Motors and drag are refused before
    /// ([`Attached::not_lti_reason`]).
    pub(super) fn lti_rows(&self, rot: &super::Carried, a: &mut nalgebra::DMatrix<f64>) {
        let nz = a.ncols();
        let last = nz - 1;
        let rows = self.shaft_rows(rot, nz);
        for (i, body) in self.elements.bodies.iter().enumerate() {
            let k = self.base + 3 * i;
            let (inertia, viscous, torque) = match &body.kind {
                ElementKind::Load(l) => (l.inertia, l.viscous, l.torque),
                ElementKind::Inertia(s) => (s.inertia, s.damping, 0.0),
                ElementKind::Motor(_) => continue,
            };
            let on = self.torque_on_row(End::Element(i), &rows, nz);
            a[(k, k + 1)] = 1.0;
            for (col, v) in on.iter().enumerate() {
                a[(k + 1, col)] = v / inertia;
            }
            a[(k + 1, k + 1)] -= viscous / inertia;
            let nominal = self.ratio[i] * rot.reference_speed();
            a[(k + 1, last)] -= (torque + viscous * nominal) / inertia;
        }
    }

    /// `max_b 2 Σ_s k_s / J_b` over the bodies the shafts join (Gershgorin on `J⁻¹K` of the
    /// shafts), square-rooted; `train_inertia(b)` the inertia of carried body b.
    pub(super) fn shaft_frequency_bound(&self, train_inertia: &dyn Fn(usize) -> f64) -> f64 {
        self.gershgorin(train_inertia, |s| s.stiffness).sqrt()
    }

    /// `max_b 2 Σ_s c_s / J_b` (Gershgorin on `J⁻¹C` of the shafts): the fastest decay rate
    /// the shaft dampers give, rad/s (issue 34: a shaft damping of 1e15 N.m.s/rad was
    /// invisible to the run limits and ground the RK path to a halt).
    pub(super) fn shaft_damping_bound(&self, train_inertia: &dyn Fn(usize) -> f64) -> f64 {
        self.gershgorin(train_inertia, |s| s.damping)
    }

    /// `max_b 2 Σ_s coefficient(s) / J_b` over the bodies the shafts join.
    fn gershgorin(
        &self,
        train_inertia: &dyn Fn(usize) -> f64,
        coefficient: impl Fn(&crate::model::elements::ShaftSpec) -> f64,
    ) -> f64 {
        let inertia = |end: End| match end {
            End::Train(b) => train_inertia(b),
            End::Element(i) => match &self.elements.bodies[i].kind {
                ElementKind::Motor(s) => s.inertia,
                ElementKind::Load(s) => s.inertia,
                ElementKind::Inertia(s) => s.inertia,
            },
        };
        let mut ends: Vec<End> = self.ends.iter().flatten().copied().collect();
        ends.dedup();
        ends.iter()
            .map(|&end| {
                let sum: f64 = (self.elements.shafts.iter().zip(&self.ends))
                    .filter(|(_, e)| e.contains(&end))
                    .map(|(s, _)| coefficient(&s.spec))
                    .sum();
                2.0 * sum / inertia(end)
            })
            .fold(0.0, f64::max)
    }
}
