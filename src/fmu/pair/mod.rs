//! The gear pair as an FMI co-simulation model: adapts [`Simulation`] to
//! [`CoSimModel`]. The FMI layer (`src/fmi/`) knows no gear physics; this module is the only
//! place where the two meet.
//!
//! Time: the scene's `t = 0` is the experiment's `startTime` (FMI 2.0.x §2.1.6,
//! `fmi2SetupExperiment`), so the model integrates in local time `τ = t − startTime`, which
//! for the usual `startTime = 0` is the host's time bit for bit.
//!
//! Inputs (`pinion_speed`, `input_torque`, `load_torque`) are held constant over a
//! communication step (`canInterpolateInputs = false`); a change re-anchors the mesh-phase
//! clock at the current time ([`Simulation::set_inputs`]), so the phase stays continuous.
//! Before initialization is finished the inputs are part of the initial operating point: the
//! static initial DTE is computed from them.
//!
//! Parameters are `fixed` (FMI 2.0.x §2.2.7): they change the equations, so they may be set
//! before `fmi2ExitInitializationMode` only; every accepted change rebuilds the simulation so
//! outputs read in initialization mode are consistent.

mod documentation;
mod state;
mod variables;

use crate::fmi::model::{CoSimModel, Lifecycle, ModelInfo, StepFailure, Variable};
use crate::fmu::checks::{
    check, check_initial_outputs, check_snapshot_values, model_info, name_of, settable_reals,
};
use crate::model::Inputs;
use crate::scene::{ContactLaw, InitialDte, Scene};
use crate::simulation::Simulation;
use std::cell::OnceCell;

use documentation::DOCUMENTATION;
pub use state::{decode, encode, ModelSnapshot};
use variables::variables;
pub use variables::*;

/// The gear pair behind an FMU instance.
pub struct GearModel {
    vars: Vec<Variable>,
    /// The scene as loaded (restored by `fmi2Reset`).
    base: Scene,
    /// The scene with the parameter and start-input values set so far.
    scene: Scene,
    /// `initial.static_dte` and `initial.dte`, kept apart from `scene.initial_dte` so that a
    /// value set for `initial.dte` survives while the static choice is on.
    static_dte: bool,
    initial_dte: f64,
    sim: Simulation,
    /// Start time and initialization stage (FMI life cycle).
    lifecycle: Lifecycle,
    /// The outputs of the current state, evaluated on the first read: a host reads them one
    /// value reference at a time (and the FMI layer checks them after every step), and each
    /// evaluation computes all of them. Emptied by every change of the simulation or its
    /// parameters: all of those go through `&mut self` (see [`GearModel::sim_mut`]).
    outputs: OnceCell<[f64; 7]>,
}

impl GearModel {
    /// Builds the model of a validated scene and its description data.
    pub fn new(scene: Scene, guid: String) -> Result<(GearModel, ModelInfo), String> {
        let sim = Simulation::new(&scene)?;
        let info = model_info(
            &scene.name,
            &scene.description,
            "Single-mesh gear pair: dynamic transmission error, mesh force and contact loss (geardyn)",
            &scene.solver,
            guid,
            DOCUMENTATION,
        );
        let vars = variables(&scene);
        let initial_dte = vars
            .iter()
            .find(|v| v.value_reference == VR_INITIAL_DTE)
            .and_then(|v| v.start)
            .unwrap_or(0.0);
        let model = GearModel {
            vars,
            static_dte: scene.initial_dte == InitialDte::Static,
            initial_dte,
            base: scene.clone(),
            scene,
            sim,
            lifecycle: Lifecycle::default(),
            outputs: OnceCell::new(),
        };
        Ok((model, info))
    }

    /// Applies a parameter or start-input value to the scene (validated, nothing clamped)
    /// and rebuilds the simulation; on failure nothing changes.
    fn set_before_init(&mut self, vr: u32, x: f64) -> Result<(), String> {
        let name = name_of(&self.vars, vr).to_string();
        let mut scene = self.scene.clone();
        let (mut static_dte, mut initial_dte) = (self.static_dte, self.initial_dte);
        let positive =
            |unit: &str| check(&name, x, x > 0.0, &format!("a finite number > 0 {unit}"));
        match vr {
            VR_PINION_INERTIA => {
                positive("kg.m2")?;
                scene.pinion.inertia = x;
            }
            VR_GEAR_INERTIA => {
                positive("kg.m2")?;
                scene.gear.inertia = x;
            }
            VR_PINION_BASE_RADIUS => {
                positive("m")?;
                scene.pinion.base_radius = x;
            }
            VR_GEAR_BASE_RADIUS => {
                positive("m")?;
                scene.gear.base_radius = x;
            }
            VR_DAMPING => {
                check(&name, x, x >= 0.0, "a finite number >= 0 N.s/m")?;
                scene.mesh.damping = x;
            }
            VR_BACKLASH => {
                positive("m")?;
                scene.mesh.contact = ContactLaw::Backlash { clearance: x };
            }
            VR_INITIAL_PHASE => {
                crate::model::check_phase(&format!("parameter '{name}'"), x)?;
                scene.mesh.initial_phase = x;
            }
            VR_INITIAL_DTE_RATE => {
                check(&name, x, true, "finite")?;
                scene.initial_dte_rate = x;
            }
            VR_INITIAL_DTE => {
                check(&name, x, true, "finite")?;
                initial_dte = x;
            }
            VR_INITIAL_STATIC => static_dte = x != 0.0,
            VR_PINION_SPEED => {
                check(&name, x, x >= 0.0, "a finite number >= 0 rad/s")?;
                scene.operating.pinion_speed = x;
            }
            VR_INPUT_TORQUE => scene.operating.input_torque = x,
            VR_LOAD_TORQUE => scene.operating.load_torque = x,
            _ => return Err(format!("no settable variable with value reference {vr}")),
        }
        scene.initial_dte = if static_dte {
            InitialDte::Static
        } else {
            InitialDte::Value(initial_dte)
        };
        let sim = Simulation::new(&scene)
            .map_err(|e| format!("'{name}' = {x:?}: the model cannot be built: {e}"))?;
        check_initial_outputs(&name, x, &crate::model::OUTPUT_NAMES, &sim.outputs())?;
        self.scene = scene;
        (self.static_dte, self.initial_dte) = (static_dte, initial_dte);
        self.sim = sim;
        // New parameters: the same state may now give other outputs.
        self.outputs = OnceCell::new();
        Ok(())
    }

    /// Parameters and start inputs by value reference: what, besides the run-time state,
    /// distinguishes this instance from a freshly instantiated one.
    fn snapshot(&self) -> ModelSnapshot {
        let op = &self.scene.operating;
        let params = settable_reals(&self.vars)
            .map(|v| {
                let x = match v.value_reference {
                    VR_PINION_SPEED => op.pinion_speed,
                    VR_INPUT_TORQUE => op.input_torque,
                    VR_LOAD_TORQUE => op.load_torque,
                    vr => self.get_real(vr).unwrap_or(f64::NAN),
                };
                (v.value_reference, x)
            })
            .collect();
        ModelSnapshot {
            params,
            static_dte: self.static_dte,
            initial_dte: self.initial_dte,
            start_time: self.lifecycle.start_time,
            initialized: self.lifecycle.initialized,
            sim: self.sim.snapshot(),
        }
    }

    /// Rebuilds the instance from a snapshot: the parameters go through the same checks as
    /// `fmi2SetReal`, then the run-time state is restored. On failure nothing changes.
    fn restore(&mut self, snap: &ModelSnapshot) -> Result<(), String> {
        let mut m = GearModel {
            vars: self.vars.clone(),
            base: self.base.clone(),
            scene: self.base.clone(),
            static_dte: snap.static_dte,
            initial_dte: snap.initial_dte,
            sim: Simulation::new(&self.base)?,
            lifecycle: Lifecycle {
                start_time: snap.start_time,
                initialized: false,
            },
            outputs: OnceCell::new(),
        };
        let u = snap.sim.pair.inputs;
        check_snapshot_values(
            &self.vars,
            &snap.params,
            &[
                (VR_PINION_SPEED, u.pinion_speed),
                (VR_INPUT_TORQUE, u.input_torque),
                (VR_LOAD_TORQUE, u.load_torque),
            ],
            snap.start_time,
        )?;
        for &(vr, x) in &snap.params {
            m.set_before_init(vr, x)?;
        }
        m.sim.restore(&snap.sim)?;
        m.lifecycle.initialized = snap.initialized;
        *self = m;
        Ok(())
    }

    /// The inputs with one of them replaced.
    fn inputs_with(&self, vr: u32, x: f64) -> Inputs {
        let mut u = self.sim.model().inputs();
        match vr {
            VR_PINION_SPEED => u.pinion_speed = x,
            VR_INPUT_TORQUE => u.input_torque = x,
            _ => u.load_torque = x,
        }
        u
    }
}

/// The position of a Real output in [`Simulation::outputs`] (the contact state is an Integer).
#[inline]
fn output_position(vr: u32) -> Option<usize> {
    ((VR_OUTPUT0..VR_OUTPUT0 + 7).contains(&vr) && vr != VR_CONTACT_STATE)
        .then(|| (vr - VR_OUTPUT0) as usize)
}

/// The positions in [`Simulation::outputs`] of all Real outputs, in value-reference order.
const REAL_OUTPUT_POSITIONS: [usize; 6] = [0, 1, 2, 4, 5, 6];
/// Their value references: what a host that records every output asks for after every step
/// (and the FMI layer's read of the outputs after every step).
const REAL_OUTPUT_VRS: [u32; 6] = {
    let mut vrs = [0; 6];
    let mut i = 0;
    while i < 6 {
        vrs[i] = VR_OUTPUT0 + REAL_OUTPUT_POSITIONS[i] as u32;
        i += 1;
    }
    vrs
};

impl GearModel {
    /// The simulation's outputs, evaluated once per state.
    fn current_outputs(&self) -> &[f64; 7] {
        self.outputs.get_or_init(|| self.sim.outputs())
    }

    /// The simulation, for a change of its state or inputs: the cached outputs are dropped
    /// first, so no read after the change can see the outputs of the state before it.
    fn sim_mut(&mut self) -> &mut Simulation {
        self.outputs = OnceCell::new();
        &mut self.sim
    }
}

impl CoSimModel for GearModel {
    fn variables(&self) -> &[Variable] {
        &self.vars
    }

    fn get_real(&self, vr: u32) -> Result<f64, String> {
        if let Some(k) = output_position(vr) {
            return Ok(self.current_outputs()[k]);
        }
        let s = &self.scene;
        let pair = self.sim.model();
        let inputs = pair.inputs();
        Ok(match vr {
            VR_PINION_INERTIA => s.pinion.inertia,
            VR_GEAR_INERTIA => s.gear.inertia,
            VR_PINION_BASE_RADIUS => s.pinion.base_radius,
            VR_GEAR_BASE_RADIUS => s.gear.base_radius,
            VR_DAMPING => s.mesh.damping,
            VR_BACKLASH => match s.mesh.contact {
                ContactLaw::Backlash { clearance } => clearance,
                _ => return Err(format!("no Real variable with value reference {vr}")),
            },
            VR_INITIAL_PHASE => s.mesh.initial_phase,
            VR_INITIAL_DTE_RATE => s.initial_dte_rate,
            VR_INITIAL_DTE => self.initial_dte,
            VR_EQUIVALENT_MASS => pair.equivalent_mass(),
            VR_MEAN_STIFFNESS => pair.mean_stiffness(),
            VR_PINION_SPEED => inputs.pinion_speed,
            VR_INPUT_TORQUE => inputs.input_torque,
            VR_LOAD_TORQUE => inputs.load_torque,
            _ => return Err(format!("no Real variable with value reference {vr}")),
        })
    }

    /// The outputs without a call per value reference: a host reads them after every step.
    fn get_reals(&self, vrs: &[u32], out: &mut [f64]) -> Result<(), String> {
        if vrs == REAL_OUTPUT_VRS && out.len() == REAL_OUTPUT_VRS.len() {
            // The usual request: no search per value reference.
            let outputs = self.current_outputs();
            for (slot, &k) in out.iter_mut().zip(&REAL_OUTPUT_POSITIONS) {
                *slot = outputs[k];
            }
            return Ok(());
        }
        // Fetched once per call, not per value reference.
        let mut outputs: Option<&[f64; 7]> = None;
        for (&vr, slot) in vrs.iter().zip(out.iter_mut()) {
            *slot = match output_position(vr) {
                Some(k) => outputs.get_or_insert_with(|| self.current_outputs())[k],
                None => self.get_real(vr)?,
            };
        }
        Ok(())
    }

    fn set_real(&mut self, vr: u32, value: f64) -> Result<(), String> {
        let is_input = matches!(vr, VR_PINION_SPEED | VR_INPUT_TORQUE | VR_LOAD_TORQUE);
        if self.lifecycle.initialized {
            if !is_input {
                // The layer's causality/variability check comes first; this is a safety net.
                return Err(format!(
                    "'{}' is fixed after initialization",
                    name_of(&self.vars, vr)
                ));
            }
            let u = self.inputs_with(vr, value);
            self.sim.model().check_inputs(&u)?;
            self.sim_mut().set_inputs(u);
            Ok(())
        } else {
            self.set_before_init(vr, value)
        }
    }

    fn get_integer(&self, vr: u32) -> Result<i32, String> {
        match vr {
            VR_CONTACT_STATE => Ok(self.sim.model().contact_state() as i32),
            _ => Err(format!("no Integer variable with value reference {vr}")),
        }
    }

    fn get_boolean(&self, vr: u32) -> Result<bool, String> {
        match vr {
            VR_INITIAL_STATIC => Ok(self.static_dte),
            _ => Err(format!("no Boolean variable with value reference {vr}")),
        }
    }

    fn set_boolean(&mut self, vr: u32, value: bool) -> Result<(), String> {
        match vr {
            VR_INITIAL_STATIC if !self.lifecycle.initialized => {
                self.set_before_init(vr, f64::from(u8::from(value)))
            }
            _ => Err(format!(
                "no settable Boolean variable with value reference {vr}"
            )),
        }
    }

    fn lifecycle_mut(&mut self) -> &mut Lifecycle {
        &mut self.lifecycle
    }

    fn do_step(&mut self, t: f64, h: f64) -> Result<(), StepFailure> {
        let start_time = self.lifecycle.start_time;
        crate::fmu::checks::do_step(self.sim_mut(), start_time, t, h)
    }

    fn reset(&mut self) -> Result<(), String> {
        let base = self.base.clone();
        self.sim = Simulation::new(&base)?;
        self.outputs = OnceCell::new();
        self.static_dte = base.initial_dte == InitialDte::Static;
        self.initial_dte = self
            .vars
            .iter()
            .find(|v| v.value_reference == VR_INITIAL_DTE)
            .and_then(|v| v.start)
            .unwrap_or(0.0);
        self.scene = base;
        self.lifecycle = Lifecycle::default();
        Ok(())
    }

    fn save_state(&mut self) -> Vec<u8> {
        self.sim.forget_recurrences();
        encode(&self.snapshot())
    }

    fn load_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        self.restore(&decode(bytes)?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fast path of `get_reals` reads the same positions as the per-reference path, and
    /// covers every Real output.
    #[test]
    fn real_output_table_agrees_with_output_position() {
        let real_outputs: Vec<u32> = (0..VR_OUTPUT0 + 100)
            .filter(|&vr| output_position(vr).is_some())
            .collect();
        assert_eq!(real_outputs, REAL_OUTPUT_VRS);
        for (&vr, k) in REAL_OUTPUT_VRS.iter().zip(REAL_OUTPUT_POSITIONS) {
            assert_eq!(output_position(vr), Some(k), "vr {vr}");
        }
    }

    /// The FMI layer reads the Real outputs in table order after every step: that must be
    /// the fast path's list, and the fast path must agree with reading them one by one.
    #[test]
    fn the_layers_output_read_takes_the_fast_path() {
        use crate::fmi::model::{Causality, VarKind};
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/fmu/spur_pair/scene.toml");
        let text = std::fs::read_to_string(path).unwrap();
        let scene = Scene::from_toml_str(&text, path).unwrap();
        let (model, _) = GearModel::new(scene, "{test}".into()).unwrap();
        let asked: Vec<u32> = model
            .variables()
            .iter()
            .filter(|v| v.kind == VarKind::Real && v.causality == Causality::Output)
            .map(|v| v.value_reference)
            .collect();
        assert_eq!(asked, REAL_OUTPUT_VRS);
        let mut fast = [0.0; 6];
        model.get_reals(&asked, &mut fast).unwrap();
        for (&vr, x) in asked.iter().zip(fast) {
            assert_eq!(model.get_real(vr), Ok(x), "vr {vr}");
        }
    }
}
