//! The run-time state of a [`GearTrain`]: what, besides `(t, ξ, ξ')` and the scene it was
//! assembled from, determines how it continues. Taken and restored bit for bit so an FMU
//! state (FMI 2.0.x §2.1.8) replays identically; the drivetrain counterpart of
//! `GearPair::pair_state`.

use super::{GearTrain, Neighbour, SlotContact, TrainInputs};
use crate::model::PhaseClock;
use crate::scene::train::PortEnd;
use crate::scene::ContactLaw;

/// Discrete mode and clock of one mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshRunState {
    /// Kept as the anchor itself (re-deriving it from a phase would change rounding).
    pub clock: PhaseClock,
    /// Integer-valued cycle of the shifted phase and the interval index within it.
    pub cycle: f64,
    pub interval: usize,
    /// Contact flag of every tooth-pair slot.
    pub flags: Vec<SlotContact>,
    /// Contact-loss bookkeeping: time with total loss so far, and since when it is lost now.
    pub loss_total: f64,
    pub loss_since: Option<f64>,
}

/// Snapshot of a [`GearTrain`]'s run-time state.
#[derive(Debug, Clone, PartialEq)]
pub struct TrainRunState {
    pub inputs: TrainInputs,
    /// Start of the contact-loss bookkeeping.
    pub loss_start: f64,
    pub meshes: Vec<MeshRunState>,
    /// Rates of the input and load torque (N·m/s) and the time they start from
    /// ([`GearTrain::set_torque_rates`]); `[0, 0]` and 0 when the torques are held.
    pub torque_rates: [f64; 2],
    pub torque_anchor: f64,
    /// Second and third derivatives `[[T'', T'''] input, load]` from the same anchor
    /// ([`GearTrain::set_torque_derivatives`]); all 0 for a ramp or held torques.
    pub torque_higher: [[f64; 2]; 2],
    /// The neighbours' motion at the speed ports, input port first (`docs/ports.md`); empty
    /// without speed ports.
    pub neighbours: Vec<Neighbour>,
}

impl SlotContact {
    /// The flag's code in [`SlotContact`]'s discriminants (stable: used in FMU states).
    pub fn code(self) -> u8 {
        self as u8
    }

    pub fn from_code(code: u8) -> Option<SlotContact> {
        [
            SlotContact::Inactive,
            SlotContact::Drive,
            SlotContact::Separated,
            SlotContact::Back,
            SlotContact::Wedged,
        ]
        .into_iter()
        .find(|f| f.code() == code)
    }
}

impl GearTrain {
    /// Snapshot of the run-time state ([`TrainRunState`]).
    pub fn run_state(&self) -> TrainRunState {
        TrainRunState {
            inputs: self.inputs,
            loss_start: self.loss_start,
            meshes: self
                .meshes
                .iter()
                .zip(&self.loss)
                .map(|(m, &(loss_total, loss_since))| MeshRunState {
                    clock: m.clock,
                    cycle: m.cycle,
                    interval: m.interval,
                    flags: m.flags.clone(),
                    loss_total,
                    loss_since,
                })
                .collect(),
            torque_rates: self.torque_rates,
            torque_higher: self.torque_higher,
            // The anchor means nothing for held torques: one canonical value.
            torque_anchor: if self.torque_rates == [0.0; 2] && !self.cubic_torques() {
                0.0
            } else {
                self.f_anchor
            },
            neighbours: [PortEnd::Input, PortEnd::Output]
                .into_iter()
                .filter_map(|end| self.neighbour(end))
                .collect(),
        }
    }

    /// Restores a [`TrainRunState`] taken from a train assembled from the same scene.
    /// Everything is checked before anything changes: a state from another scene (mesh or
    /// slot count, interval index, a flag the contact law or the slot's engagement excludes,
    /// a non-finite number) is rejected with a message naming the mesh and the value, so the
    /// force evaluation can rely on an engaged slot having a stiffness law.
    pub fn restore_run_state(&mut self, s: &TrainRunState) -> Result<(), String> {
        let i = s.inputs;
        let finite = [i.input_speed, i.input_torque, i.load_torque, s.loss_start];
        if !finite.iter().all(|v| v.is_finite()) || i.input_speed < 0.0 {
            return Err(format!(
                "inputs {i:?} / loss start {} are not finite or the speed is negative",
                s.loss_start
            ));
        }
        if s.meshes.len() != self.meshes.len() {
            return Err(format!(
                "the state has {} meshes, this train {}",
                s.meshes.len(),
                self.meshes.len()
            ));
        }
        // The inputs first: a Model-2 mesh rebuilds its table for the torques, which fixes
        // the interval and slot counts the mode is checked against.
        let mut train = self.clone();
        train.apply_inputs(0.0, s.inputs)?;
        let higher = s.torque_higher != [[0.0; 2]; 2];
        if s.torque_rates != [0.0; 2]
            || train.torque_rates != [0.0; 2]
            || higher
            || train.cubic_torques()
        {
            if !s.torque_anchor.is_finite() {
                return Err(format!(
                    "torque rate anchor {} is not finite",
                    s.torque_anchor
                ));
            }
            let (r, h) = (s.torque_rates, s.torque_higher);
            train.set_torque_derivatives(
                s.torque_anchor,
                [[r[0], h[0][0], h[0][1]], [r[1], h[1][0], h[1][1]]],
            )?;
        }
        for (n, (mesh, ms)) in train.meshes.iter_mut().zip(&s.meshes).enumerate() {
            let (t0, p0) = ms.clock.anchor();
            let numbers = [t0, p0, ms.clock.mesh_frequency(), ms.cycle, ms.loss_total];
            if !numbers.iter().all(|v| v.is_finite())
                || ms.cycle.fract() != 0.0
                || !ms.loss_since.is_none_or(f64::is_finite)
            {
                return Err(format!(
                    "mesh {n}: clock/cycle/loss values {numbers:?}, {:?} are not valid",
                    ms.loss_since
                ));
            }
            let intervals = mesh.table().map_or(1, |t| t.intervals.len());
            if ms.interval >= intervals || ms.flags.len() != mesh.flags.len() {
                return Err(format!(
                    "mesh {n}: interval {} of {intervals} with {} slots (this mesh has {})",
                    ms.interval,
                    ms.flags.len(),
                    mesh.flags.len()
                ));
            }
            // The anchor within the phase limit, the frequency the restored inputs give.
            ms.clock
                .check_restored(mesh.clock.mesh_frequency())
                .map_err(|e| format!("mesh {n}: {e}"))?;
            mesh.clock = ms.clock;
            mesh.cycle = ms.cycle;
            mesh.interval = ms.interval;
            for (j, &flag) in ms.flags.iter().enumerate() {
                let engaged = mesh.law(j).is_some();
                let allowed = match (engaged, flag, mesh.contact) {
                    (false, f, _) => f == SlotContact::Inactive,
                    (true, SlotContact::Inactive, _) => false,
                    (true, f, ContactLaw::Linear) => f == SlotContact::Drive,
                    (true, f, ContactLaw::ContactLoss) => !f.touches_back(),
                    (true, f, ContactLaw::Backlash { .. }) => {
                        f != SlotContact::Wedged || mesh.can_wedge()
                    }
                };
                if !allowed {
                    return Err(format!(
                        "mesh {n}, slot {j}: contact flag {flag:?} is impossible here \
                         (engaged: {engaged}, contact law {:?})",
                        mesh.contact
                    ));
                }
            }
            mesh.flags.clone_from(&ms.flags);
        }
        train.loss = s
            .meshes
            .iter()
            .map(|m| (m.loss_total, m.loss_since))
            .collect();
        train.loss_start = s.loss_start;
        let ends: Vec<PortEnd> = [PortEnd::Input, PortEnd::Output]
            .into_iter()
            .filter(|&end| train.neighbour(end).is_some())
            .collect();
        if ends.len() != s.neighbours.len() {
            return Err(format!(
                "the state has {} speed-port neighbours, this train {}",
                s.neighbours.len(),
                ends.len()
            ));
        }
        for (&end, n) in ends.iter().zip(&s.neighbours) {
            if !(n.anchor.is_finite() && n.ended.iter().all(|x| x.is_finite())) {
                return Err(format!("neighbour anchor / rates {n:?} are not finite"));
            }
            train.set_neighbour(end, *n)?;
        }
        train.refresh_guards();
        *self = train;
        Ok(())
    }
}
