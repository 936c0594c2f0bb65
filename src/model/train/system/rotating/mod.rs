//! The carried rigid-body rotation of a drivetrain with mechanical ports (`docs/ports.md`,
//! issue 18 point 1).
//!
//! The state grows from `[ξ, ξ']` to `[ξ, ξ', η, η']`: the elastic coordinates ξ of
//! [`super::super::assembly::Reduction`] (mesh deflections, m) and the `M`-orthonormal
//! rigid-body coordinates η with their rates. The physical rotation of body b is
//!
//! `θ_b(t) = w_b Ω_ref t + (Q ξ + R η)_b / ρ_b`,
//!
//! `w_b` the nominal speed ratio of the body (rolling on the base circles) and `Ω_ref` the
//! scene's `operating.input_speed`: η is carried relative to the reference rotation
//! `w Ω_ref t`, which is itself a rigid-body mode. So η stays of the size of the speed
//! deviation times the time, not of the total angle, and the RK error control of the small
//! elastic coordinates (µm) is not swamped by angles of thousands of radians; the reference
//! adds no force because it is a rigid mode at constant speed (`K v = 0`, `C v = 0`,
//! `v'' = 0`). ξ and η stay separate states: the rigid motion obeys `η'' = Rᵀ F_T` (R is
//! M-orthonormal and `Rᵀ M Q = 0`, so the mesh, shaft and bearing forces, which all lie in the
//! span of `Mq`'s elastic part, do not enter it; Liu 2007 eq. 3.2's split).
//!
//! The phase of mesh n follows the actual angle of its pinion's body b,
//! `p_n = p_n0 + z_n θ_b / 2π`, phase rate `z_n θ'_b / 2π`. Stiffness and gap knots are then
//! state events on `p_n − knot` in both directions (a reversing shaft goes back a segment),
//! like the contact changes; the force is the nominal form's `mesh_force_at` with this phase.

mod attached;
pub mod coupling;
mod lti;

use std::f64::consts::TAU;

use attached::{Attached, TrainMotion};
use coupling::Coupling;
pub use coupling::Neighbour;

use super::super::assembly::Reduction;
use super::{GearTrain, SlotContact, Stiffness};
use crate::scene::train::PortEnd;
use crate::scene::Scene;
use crate::solve::HybridSystem;

/// Angle of one body as a row over the state.
#[derive(Debug, Clone)]
struct BodyRow {
    /// Nominal speed over the input speed.
    ratio: f64,
    /// `∂θ_b/∂ξ` (rad/m) and `∂θ_b/∂η`.
    xi: Vec<f64>,
    eta: Vec<f64>,
    name: String,
}

/// A port in the model: which body, which end of the train, and with speed causality its
/// coupling to the neighbour.
#[derive(Debug, Clone)]
struct PortRt {
    name: String,
    body: usize,
    end: PortEnd,
    coupling: Option<Coupling>,
}

/// The carried rotation (see the module documentation).
#[derive(Debug, Clone)]
pub(crate) struct Carried {
    m: usize,
    r: usize,
    /// `Ω_ref`, rad/s.
    omega: f64,
    bodies: Vec<BodyRow>,
    /// Per mesh: pinion body, pinion teeth, phase at θ = 0.
    mesh_body: Vec<usize>,
    mesh_teeth: Vec<f64>,
    mesh_p0: Vec<f64>,
    /// Per mesh of a planetary stage: its carrier's body and the carrier angle's coefficient;
    /// the phase follows the pinion's angle relative to the carrier ([`stage_phase_terms`]).
    mesh_carrier: Vec<Option<(usize, f64)>>,
    /// Meshes whose stiffness or gaps have knots: two guards each (end, start of the
    /// current interval).
    knot_meshes: Vec<usize>,
    ports: Vec<PortRt>,
    /// Elements coupled to the train (`[[motor]]`, `[[load]]`, `[[inertia]]`).
    attached: Option<Attached>,
}

impl TrainMotion for Carried {
    fn train_motion(&self, b: usize, t: f64, y: &[f64]) -> (f64, f64) {
        self.body_motion(b, t, y)
    }
    fn train_ratio(&self, b: usize) -> f64 {
        self.bodies[b].ratio
    }
    fn reference_speed(&self) -> f64 {
        self.omega
    }
}

impl Carried {
    pub(crate) fn new(
        scene: &Scene,
        train: &GearTrain,
        red: &Reduction,
    ) -> Result<Carried, String> {
        let asm = &train.asm;
        let r = red.rigid_dim();
        if r == 0 {
            let grounded: Vec<&str> = scene
                .gears
                .iter()
                .filter(|g| g.ground_stiffness > 0.0)
                .map(|g| g.name.as_str())
                .collect();
            return Err(format!(
                "[[port]]: the train is grounded (ground_stiffness on {}), so it has no rigid-body \
                 rotation to carry; ports need a freely turning train",
                grounded.join(", ")
            ));
        }
        for (n, (mesh, sm)) in train.meshes.iter().zip(&scene.meshes).enumerate() {
            let why = if mesh.friction.is_some() {
                Some("tooth friction ([mesh.friction])")
            } else if !mesh.errors.is_empty() {
                Some("gear runout or pitch errors")
            } else if mesh.model2.is_some() {
                Some("model = \"loaded_ste\" (its excitation is built from a constant load)")
            } else {
                None
            };
            if let Some(why) = why {
                return Err(format!(
                    "[[port]] with mesh[{n}] ({:?}): {why} is not available with carried \
                     rotation yet (docs/ports.md)",
                    sm.name
                ));
            }
        }
        let omega = scene.operating.input_speed;
        let v = super::nominal_rotation(scene, asm);
        let m = train.m;
        let bodies = (0..asm.body_radius.len())
            .map(|b| {
                let dof = asm.body_dof[b];
                let rho = asm.body_radius[b];
                let first = (0..scene.gears.len())
                    .find(|&g| asm.body_of[g] == b)
                    .expect("every body has a gear");
                BodyRow {
                    ratio: v[dof] / rho,
                    xi: (0..m).map(|i| red.q[(dof, i)] / rho).collect(),
                    eta: (0..r).map(|k| red.r[(dof, k)] / rho).collect(),
                    name: scene.gears[first].name.clone(),
                }
            })
            .collect();
        let stage_terms: Vec<_> = (0..scene.meshes.len())
            .map(|n| stage_phase_terms(scene, n))
            .collect();
        let knot_meshes = (0..train.meshes.len())
            .filter(|&n| match &train.meshes[n].stiffness {
                Stiffness::Table(t) => t.has_stops(),
                Stiffness::Smooth { .. } => false,
            })
            .collect();
        let mut carried = Carried {
            m,
            r,
            omega,
            bodies,
            mesh_body: scene
                .meshes
                .iter()
                .map(|sm| asm.body_of[sm.pinion])
                .collect(),
            mesh_teeth: (scene.meshes.iter().zip(&stage_terms))
                .map(|(sm, stage)| match stage {
                    Some((teeth, _)) => *teeth,
                    None => f64::from(scene.gears[sm.pinion].teeth),
                })
                .collect(),
            mesh_carrier: (stage_terms.iter())
                .map(|stage| stage.map(|(_, (carrier, c))| (asm.body_of[carrier], c)))
                .collect(),
            mesh_p0: train
                .meshes
                .iter()
                .map(|mt| mt.clock.phase_at(0.0))
                .collect(),
            knot_meshes,
            ports: scene
                .ports
                .iter()
                .map(|p| PortRt {
                    name: p.name.clone(),
                    body: asm.body_of[p.gear],
                    end: p.end,
                    coupling: p.coupling.map(|c| Coupling {
                        stiffness: c.stiffness,
                        damping: c.damping,
                        // Set with the initial state (the gear's start angle).
                        neighbour: Neighbour::default(),
                    }),
                })
                .collect(),
            attached: None,
        };
        if !scene.elements.is_empty() {
            let attached = Attached::new(
                &scene.elements,
                &|g| asm.body_of[g],
                scene.input_gear,
                scene.output_gear,
                &carried,
                2 * m + 2 * r,
            );
            carried.attached = Some(attached);
        }
        Ok(carried)
    }

    /// States beyond `[ξ, ξ']`: `[η, η']` and the elements' states.
    pub(crate) fn extra_dim(&self) -> usize {
        2 * self.r + self.attached.as_ref().map_or(0, Attached::dim)
    }

    /// The train's input and load torque at `(t, y)` from the element shafts or the speed
    /// ports' couplings (a torque port keeps its torque from `given`); `None`: the train
    /// takes both torques from its inputs (torque ports).
    pub(crate) fn train_torques(&self, t: f64, y: &[f64], given: (f64, f64)) -> Option<(f64, f64)> {
        if let Some(a) = &self.attached {
            return Some(a.train_torques(t, y, self));
        }
        let mut torques = None;
        for p in &self.ports {
            if let Some(c) = &p.coupling {
                let (t_in, t_load) = torques.get_or_insert(given);
                let tau = c.torque_on_gear(t, self.body_motion(p.body, t, y));
                match p.end {
                    PortEnd::Input => *t_in = tau,
                    PortEnd::Output => *t_load = -tau,
                }
            }
        }
        torques
    }

    /// The neighbour of the speed port at `end`, if the port there has speed causality.
    pub(crate) fn neighbour(&self, end: PortEnd) -> Option<Neighbour> {
        let p = self.ports.iter().find(|p| p.end == end)?;
        p.coupling.as_ref().map(|c| c.neighbour)
    }

    /// Sets the neighbour's motion of the speed port at `end` (`false`: no speed port there).
    pub(crate) fn set_neighbour(&mut self, end: PortEnd, motion: Neighbour) -> bool {
        let coupling = (self.ports.iter_mut())
            .find(|p| p.end == end)
            .and_then(|p| p.coupling.as_mut());
        coupling.map(|c| c.neighbour = motion).is_some()
    }

    /// The speed port whose `<port>.torque` output is `name`: its gear and coupling.
    fn speed_port(&self, name: &str) -> Option<(usize, &Coupling)> {
        let port = name.strip_suffix(".torque")?;
        let p = self.ports.iter().find(|p| p.name == port)?;
        Some((p.body, p.coupling.as_ref()?))
    }

    /// Whether `name` is a speed port's `<port>.torque` output.
    pub(crate) fn is_port_torque(&self, name: &str) -> bool {
        self.speed_port(name).is_some()
    }

    /// A speed port's `<port>.torque` output at `(t, y)` on its own (the value of
    /// [`Carried::outputs`]); `None` if `name` is not one.
    pub(crate) fn port_torque(&self, name: &str, t: f64, y: &[f64]) -> Option<f64> {
        let (body, c) = self.speed_port(name)?;
        Some(port_torque(c, t, self.body_motion(body, t, y)))
    }

    /// `d/dt` of a speed port's `<port>.torque` output at `(t, y)`, `dy` the state
    /// derivative there; `None` if `name` is not one.
    pub(crate) fn port_torque_rate(
        &self,
        name: &str,
        t: f64,
        y: &[f64],
        dy: &[f64],
    ) -> Option<f64> {
        let (body, c) = self.speed_port(name)?;
        let speed = self.body_motion(body, t, y).1;
        Some(-c.torque_rate(t, speed, self.body_acceleration(body, dy)))
    }

    /// `θ_b''` from the state derivative (the reference rotation has no acceleration).
    fn body_acceleration(&self, b: usize, dy: &[f64]) -> f64 {
        let (m, r) = (self.m, self.r);
        let row = &self.bodies[b];
        (0..m).map(|i| row.xi[i] * dy[m + i]).sum::<f64>()
            + (0..r).map(|k| row.eta[k] * dy[2 * m + r + k]).sum::<f64>()
    }

    /// Angle (rad) and speed (rad/s) of body b, positive in its nominal rotation sense.
    pub(crate) fn body_motion(&self, b: usize, t: f64, y: &[f64]) -> (f64, f64) {
        let (m, r) = (self.m, self.r);
        let row = &self.bodies[b];
        let mut angle = row.ratio * self.omega * t;
        let mut speed = row.ratio * self.omega;
        for i in 0..m {
            angle += row.xi[i] * y[i];
            speed += row.xi[i] * y[m + i];
        }
        for k in 0..r {
            angle += row.eta[k] * y[2 * m + k];
            speed += row.eta[k] * y[2 * m + r + k];
        }
        (angle, speed)
    }

    /// Phase (cycles) and phase rate (1/s) of mesh n from its pinion's carried angle (in a
    /// planetary stage, relative to the carrier's).
    pub(crate) fn mesh_phase(&self, n: usize, t: f64, y: &[f64]) -> (f64, f64) {
        let (angle, speed) = self.body_motion(self.mesh_body[n], t, y);
        let z = self.mesh_teeth[n];
        match self.mesh_carrier[n] {
            None => (self.mesh_p0[n] + z * angle / TAU, z * speed / TAU),
            Some((carrier, zc)) => {
                let (angle_c, speed_c) = self.body_motion(carrier, t, y);
                (
                    self.mesh_p0[n] + (z * angle + zc * angle_c) / TAU,
                    (z * speed + zc * speed_c) / TAU,
                )
            }
        }
    }

    /// `[ξ0, ξ0']` extended by η0 (the input body at angle 0) and η0' = 0 (every body at its
    /// nominal speed `w_b Ω_ref`). Each speed port's neighbour starts at `start[i]` (angle,
    /// speed), by default pre-twisted by the port's start torque from the gear's start angle
    /// and at the gear's nominal speed: the coupling carries the start torque.
    pub(crate) fn initial_state(
        &mut self,
        elastic: &[f64],
        start: &[(f64, Option<f64>, Option<f64>)],
    ) -> Vec<f64> {
        let (m, r) = (self.m, self.r);
        let mut y = elastic.to_vec();
        y.resize(2 * m + 2 * r, 0.0);
        let input = self
            .ports
            .iter()
            .find(|p| p.end == PortEnd::Input)
            .map_or(self.mesh_body[0], |p| p.body);
        let row = &self.bodies[input];
        let k = (0..r)
            .max_by(|&a, &b| row.eta[a].abs().total_cmp(&row.eta[b].abs()))
            .expect("a carried rotation has a rigid mode");
        if row.eta[k] != 0.0 {
            let elastic_angle: f64 = (0..m).map(|i| row.xi[i] * y[i]).sum();
            y[2 * m + k] = -elastic_angle / row.eta[k];
        }
        if let Some(a) = &self.attached {
            y.resize(2 * m + 2 * r + a.dim(), 0.0);
            a.initial_state(&mut y, self);
        }
        let motion: Vec<(f64, f64)> = (self.ports.iter())
            .map(|p| self.body_motion(p.body, 0.0, &y))
            .collect();
        for ((p, (angle, speed)), &(torque, given_speed, given_angle)) in
            self.ports.iter_mut().zip(motion).zip(start)
        {
            if let Some(c) = &mut p.coupling {
                c.neighbour = Neighbour {
                    angle: given_angle.unwrap_or(angle + torque / c.stiffness),
                    speed: given_speed.unwrap_or(speed),
                    ..Neighbour::default()
                };
            }
        }
        y
    }

    /// `η' = η'`, `η'' = Rᵀ F_T` (M-orthonormal rigid modes) into `dy[2m..]` under the input
    /// and load torques `torques`, and the elements' state derivatives.
    pub(crate) fn rigid_rhs(
        &self,
        train: &GearTrain,
        t: f64,
        y: &[f64],
        dy: &mut [f64],
        torques: (f64, f64),
    ) {
        let (m, r) = (self.m, self.r);
        let (t_in, t_load) = torques;
        for k in 0..r {
            dy[2 * m + k] = y[2 * m + r + k];
            dy[2 * m + r + k] = train.rigid_in[k] * t_in + train.rigid_out[k] * t_load;
        }
        if let Some(a) = &self.attached {
            a.rhs(t, y, dy, self, None);
        }
    }

    /// Number of knot guards.
    pub(crate) fn knot_count(&self) -> usize {
        2 * self.knot_meshes.len()
    }

    /// Knot guards `end − p` and `p − start` of every mesh's current interval (phases of the
    /// interval ends in the clock's phase, cycles).
    pub(crate) fn knot_guards(&self, train: &GearTrain, t: f64, y: &[f64], g: &mut [f64]) {
        for (i, &n) in self.knot_meshes.iter().enumerate() {
            let mesh = &train.meshes[n];
            let p = self.mesh_phase(n, t, y).0;
            let (start, end) = mesh.current().map_or((0.0, 1.0), |iv| (iv.start, iv.end));
            let base = mesh.cycle - mesh.offset;
            g[2 * i] = (base + end) - p;
            g[2 * i + 1] = p - (base + start);
        }
    }

    /// The time at which the next stiffness knot of any knot mesh is reached if every mesh
    /// phase follows its quadratic Taylor polynomial at `(t, y)` (`dy` the state derivative
    /// there): the knots are state events on the carried angles (`knot_guards`), so their
    /// times are known only ahead of the motion; `+inf` when none is reached. The error is
    /// the phase's third-order term, `|p⃛|τ³/6` over `|ṗ|`.
    pub(crate) fn predicted_knot_time(
        &self,
        train: &GearTrain,
        t: f64,
        y: &[f64],
        dy: &[f64],
    ) -> f64 {
        // The smallest τ > 0 with `rate·τ + ½·accel·τ² = distance` (distance ≥ 0), in the form
        // that does not cancel (`PhaseClock::time_of`).
        let first = |distance: f64, rate: f64, accel: f64| {
            let disc = rate * rate + 2.0 * accel * distance;
            if distance < 0.0 || disc < 0.0 {
                return f64::INFINITY;
            }
            let denom = rate + disc.sqrt();
            if denom > 0.0 {
                2.0 * distance / denom
            } else {
                f64::INFINITY
            }
        };
        let mut soonest = f64::INFINITY;
        for &n in &self.knot_meshes {
            let mesh = &train.meshes[n];
            let (p, rate) = self.mesh_phase(n, t, y);
            let z = self.mesh_teeth[n];
            let mut accel = z * self.body_acceleration(self.mesh_body[n], dy);
            if let Some((carrier, zc)) = self.mesh_carrier[n] {
                accel += zc * self.body_acceleration(carrier, dy);
            }
            accel /= TAU;
            let (start, end) = mesh.current().map_or((0.0, 1.0), |iv| (iv.start, iv.end));
            let base = mesh.cycle - mesh.offset;
            let forward = first(base + end - p, rate, accel);
            let backward = first(p - (base + start), -rate, -accel);
            soonest = soonest.min(forward).min(backward);
        }
        t + soonest
    }

    /// Output names (`<owner>.<quantity>`, `docs/fmu.md`): per body `<gear>.angle`, `.speed`,
    /// `.acceleration`, then per port `<port>.angle`, `.speed`, `.acceleration`.
    pub(crate) fn names(&self) -> Vec<String> {
        let mut names = Vec::new();
        for b in &self.bodies {
            for q in ["angle", "speed", "acceleration"] {
                names.push(format!("{}.{q}", b.name));
            }
        }
        for p in &self.ports {
            if p.coupling.is_some() {
                // Speed port: its angle and speed are inputs; the gear's motion is in the
                // body columns.
                names.push(format!("{}.torque", p.name));
                continue;
            }
            for q in ["angle", "speed", "acceleration"] {
                names.push(format!("{}.{q}", p.name));
            }
        }
        if let Some(a) = &self.attached {
            names.extend(a.names());
        }
        names
    }

    /// The largest `|dfₙ/dt|` over the meshes, Hz/s, that the port torques give the rigid-body
    /// rotation (input port `input_torque`, output port `−load_torque`): body b accelerates at
    /// `Σₖ ηₖ(b) Σₚ Tₚ ηₖ(p)` (η mass-normalised), and a mesh's frequency is its pinion's
    /// teeth times its speed over 2π. Balanced torques give 0; the elastic motion oscillates
    /// about the rigid one.
    pub(crate) fn mesh_frequency_slope(&self, input_torque: f64, load_torque: f64) -> f64 {
        let torque = |p: &PortRt| match p.end {
            PortEnd::Input => input_torque,
            PortEnd::Output => -load_torque,
        };
        let signed = |b: usize| -> f64 {
            (0..self.r)
                .map(|k| {
                    let drive: f64 = (self.ports.iter())
                        .map(|p| torque(p) * self.bodies[p.body].eta[k])
                        .sum();
                    self.bodies[b].eta[k] * drive
                })
                .sum::<f64>()
        };
        let accel = |b: usize| signed(b).abs();
        (self
            .mesh_body
            .iter()
            .zip(&self.mesh_teeth)
            .zip(&self.mesh_carrier))
        .map(|((&b, z), carrier)| match carrier {
            None => z * accel(b) / std::f64::consts::TAU,
            Some((c, zc)) => (z * signed(b) + zc * signed(*c)).abs() / std::f64::consts::TAU,
        })
        .fold(0.0, f64::max)
    }

    /// Whether a port sits on the output gear (a torque port's torque is minus the load
    /// torque).
    pub(crate) fn output_port(&self) -> bool {
        self.ports.iter().any(|p| p.end == PortEnd::Output)
    }

    /// Values of [`Carried::names`]; `dy` the state derivative at `(t, y)`.
    pub(crate) fn outputs(&self, t: f64, y: &[f64], dy: &[f64], out: &mut Vec<f64>) {
        let start = out.len();
        for b in 0..self.bodies.len() {
            let (angle, speed) = self.body_motion(b, t, y);
            out.extend([angle, speed, self.body_acceleration(b, dy)]);
        }
        for p in &self.ports {
            let i = start + 3 * p.body;
            match &p.coupling {
                Some(c) => out.push(port_torque(c, t, (out[i], out[i + 1]))),
                None => out.extend_from_within(i..i + 3),
            }
        }
        if let Some(a) = &self.attached {
            a.outputs(t, y, dy, self, out);
        }
    }
}

/// A speed port's `<port>.torque` output: the torque the stage applies to the neighbour (its
/// `flange.torque` input), from the gear's angle and speed.
fn port_torque(c: &Coupling, t: f64, gear: (f64, f64)) -> f64 {
    -c.torque_on_gear(t, gear)
}

/// The phase terms of mesh `n` if it belongs to a planetary stage: `(z, (carrier, z_c))` with
/// `p = p0 + (z θ_pinion + z_c θ_carrier)/2π`, angles in the bodies' nominal senses. A stage
/// mesh's tooth pairs pass at the pinion's rotation relative to the carrier (the sun's for a
/// sun mesh, the planet's for a ring mesh; `docs/planetary.md`), counted in the sense that
/// makes the phase grow: `z = Z ς ρ_pinion`, `z_c = −Z ς ρ_carrier` with ς the sense of the
/// pinion's nominal rotation relative to the carrier.
fn stage_phase_terms(scene: &Scene, n: usize) -> Option<(f64, (usize, f64))> {
    let mesh = &scene.meshes[n];
    let st = scene.planetary.iter().find(|st| {
        st.planets
            .iter()
            .any(|p| p.sun_mesh == n || p.ring_mesh == n)
    })?;
    // The planets turn against the sun relative to the carrier (eq. P2).
    let sense = if mesh.pinion == st.sun {
        st.relative_sense
    } else {
        -st.relative_sense
    };
    let z = f64::from(scene.gears[mesh.pinion].teeth) * sense;
    Some((
        z * scene.rotation[mesh.pinion],
        (st.carrier, -z * scene.rotation[st.carrier]),
    ))
}

impl GearTrain {
    /// The predicted time of the next stiffness knot of a rotating train
    /// ([`Carried::predicted_knot_time`]); `+inf` without a rotation (its knots are stops of
    /// the nominal clock, [`HybridSystem::next_stop`]).
    pub fn predicted_knot_time(&self, t: f64, y: &[f64]) -> f64 {
        let Some(rot) = &self.rotation else {
            return f64::INFINITY;
        };
        if rot.knot_meshes.is_empty() {
            return f64::INFINITY;
        }
        let mut dy = vec![0.0; y.len()];
        self.rhs(t, y, &mut dy);
        rot.predicted_knot_time(self, t, y, &dy)
    }

    /// A stiffness knot of mesh `knot_meshes[k / 2]` crossed: forward (even k) or backward.
    /// Intervals of zero width are passed at once, as the nominal form's stops do.
    pub(super) fn knot_event(&mut self, t: f64, y: &[f64], k: usize) {
        let rot = self
            .rotation
            .as_ref()
            .expect("knot events need the rotation");
        let n = rot.knot_meshes[k / 2];
        let forward = k.is_multiple_of(2);
        let count = self.meshes[n].table().map_or(1, |tb| tb.intervals.len());
        for _ in 0..count {
            if forward {
                self.on_mesh_stop(n, t, Some(y));
            } else {
                self.on_mesh_stop_back(n, t, y);
            }
            if self.meshes[n].current().is_none_or(|iv| iv.end > iv.start) {
                break;
            }
        }
        self.book_loss(n, t);
        self.refresh_guards();
    }

    /// The reverse of `on_mesh_stop`: mesh n enters the interval before the current one (a
    /// reversing shaft); on a wrap with shifting slots a pair re-enters at slot 0.
    fn on_mesh_stop_back(&mut self, n: usize, t: f64, y: &[f64]) {
        let mesh = &mut self.meshes[n];
        let Stiffness::Table(table) = &mesh.stiffness else {
            return;
        };
        let count = table.intervals.len();
        let shift = table.shift_on_wrap;
        let wrapped = mesh.interval == 0;
        if wrapped {
            mesh.interval = count - 1;
            mesh.cycle -= 1.0;
        } else {
            mesh.interval -= 1;
        }
        let old = mesh.flags.clone();
        for j in 0..old.len() {
            mesh.flags[j] = if wrapped && shift {
                if j == 0 {
                    SlotContact::Inactive
                } else {
                    old[j - 1]
                }
            } else {
                old[j]
            };
        }
        for j in 0..old.len() {
            let engaged = self.meshes[n].law(j).is_some();
            let flag = self.meshes[n].flags[j];
            self.meshes[n].flags[j] = match (engaged, flag) {
                (false, _) => SlotContact::Inactive,
                (true, SlotContact::Inactive) => self.classify(n, j, t, y),
                (true, f) => f,
            };
        }
    }
}
