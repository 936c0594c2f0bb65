//! A drivetrain as an FMI co-simulation model: adapts [`TrainSimulation`] to [`CoSimModel`],
//! with the structure of the single-mesh adapter [`crate::fmu::pair`] (shared pieces in
//! [`crate::fmu::checks`]). The FMI layer (`src/fmi/`) knows no gear physics.
//!
//! Time: the scene's `t = 0` is the experiment's `startTime` (FMI 2.0.x §2.1.6), so the model
//! integrates in local time `τ = t − startTime`.
//!
//! Inputs (`input_speed`, `input_torque`, `load_torque`) are held constant over a
//! communication step (`canInterpolateInputs = false`); a change re-anchors every mesh's
//! phase clock at the current time ([`TrainSimulation::set_inputs`]). Before initialization
//! ends they are part of the initial operating point (the static initial state uses them).
//!
//! Parameters are `fixed` (FMI 2.0.x §2.2.7): they change the equations, so they may be set
//! before `fmi2ExitInitializationMode` only; every accepted change rebuilds the simulation, so
//! outputs read in initialization mode are consistent.

mod documentation;
mod state;
mod variables;

use crate::fmi::model::{CoSimModel, Lifecycle, ModelInfo, StepFailure, Variable};
use crate::fmu::checks::{
    check, check_initial_outputs, check_snapshot_values, model_info, name_of, settable_reals,
};
use crate::model::train::{TrainInputs, TrainSimulation};
use crate::scene::train::TrainScene;

use documentation::DOCUMENTATION;
pub use state::{decode, encode, TrainSnapshot, FORMAT_VERSION};
pub use variables::*;

/// The drivetrain behind an FMU instance.
pub struct TrainModel {
    vars: Vec<Variable>,
    /// The scene as loaded (restored by `fmi2Reset`).
    base: TrainScene,
    /// The scene with the parameter and start-input values set so far.
    scene: TrainScene,
    sim: TrainSimulation,
    /// The outputs at the current time, in output-name order: refreshed after every change,
    /// so a `fmi2GetReal` of many outputs evaluates the mesh forces once.
    outputs: Vec<f64>,
    /// Start time and initialization stage (FMI life cycle).
    lifecycle: Lifecycle,
}

/// Applies one parameter or start-input value to a scene (validated, nothing clamped).
fn apply(scene: &mut TrainScene, name: &str, vr: u32, x: f64) -> Result<(), String> {
    let index = |base: u32, len: usize| {
        vr.checked_sub(base)
            .map(|i| i as usize)
            .filter(|&i| i < len.min(BLOCK))
    };
    let nonnegative =
        |unit: &str| check(name, x, x >= 0.0, &format!("a finite number >= 0 {unit}"));
    match vr {
        VR_MODAL_DAMPING => {
            nonnegative("")?;
            scene.modal_damping_ratio = x;
        }
        VR_INITIAL_PHASE => {
            crate::model::check_phase(&format!("parameter '{name}'"), x)?;
            scene.meshes[0].initial_phase = x;
        }
        VR_INPUT_SPEED => {
            nonnegative("rad/s")?;
            scene.operating.input_speed = x;
        }
        VR_INPUT_TORQUE => {
            check(name, x, true, "finite")?;
            scene.operating.input_torque = x;
        }
        VR_LOAD_TORQUE => {
            check(name, x, true, "finite")?;
            scene.operating.load_torque = x;
        }
        _ => {
            if let Some(g) = index(VR_GEAR_INERTIA0, scene.gears.len()) {
                check(name, x, x > 0.0, "a finite number > 0 kg.m2")?;
                scene.gears[g].inertia = x;
            } else if let Some(n) = index(VR_MESH_DAMPING0, scene.meshes.len()) {
                nonnegative("N.s/m")?;
                scene.meshes[n].damping = x;
            } else {
                return Err(format!("no settable variable with value reference {vr}"));
            }
        }
    }
    Ok(())
}

impl TrainModel {
    /// Builds the model of a validated drivetrain scene and its description data.
    pub fn new(scene: TrainScene, guid: String) -> Result<(TrainModel, ModelInfo), String> {
        // The first mesh carries the phase parameter; validation already requires one.
        if scene.meshes.is_empty() {
            return Err("the drivetrain has no mesh".into());
        }
        let sim = TrainSimulation::new(&scene)?;
        let info = model_info(
            &scene.name,
            &scene.description,
            "Drivetrain of gears, shafts and meshes: per-mesh dynamic transmission error, mesh force and contact loss (geardyn)",
            &scene.solver,
            guid,
            DOCUMENTATION,
        );
        let vars = variables(&scene, sim.output_names())?;
        let mut model = TrainModel {
            vars,
            base: scene.clone(),
            scene,
            sim,
            outputs: Vec::new(),
            lifecycle: Lifecycle::default(),
        };
        model.refresh();
        Ok((model, info))
    }

    fn refresh(&mut self) {
        self.sim.outputs(&mut self.outputs);
    }

    /// Applies a parameter or start-input value and rebuilds the simulation; on failure
    /// nothing changes.
    fn set_before_init(&mut self, vr: u32, x: f64) -> Result<(), String> {
        let name = name_of(&self.vars, vr).to_string();
        let mut scene = self.scene.clone();
        apply(&mut scene, &name, vr, x)?;
        let sim = TrainSimulation::new(&scene)
            .map_err(|e| format!("'{name}' = {x:?}: the model cannot be built: {e}"))?;
        let mut outputs = Vec::new();
        sim.outputs(&mut outputs);
        check_initial_outputs(&name, x, sim.output_names(), &outputs)?;
        self.scene = scene;
        self.sim = sim;
        self.refresh();
        Ok(())
    }

    /// Parameters and start inputs by value reference (from the scene: the start inputs
    /// fixed the initial state; the current inputs are in the run-time state).
    fn snapshot(&self) -> TrainSnapshot {
        let op = &self.scene.operating;
        let params = settable_reals(&self.vars)
            .map(|v| {
                let x = match v.value_reference {
                    VR_INPUT_SPEED => op.input_speed,
                    VR_INPUT_TORQUE => op.input_torque,
                    VR_LOAD_TORQUE => op.load_torque,
                    vr => self.get_real(vr).unwrap_or(f64::NAN),
                };
                (v.value_reference, x)
            })
            .collect();
        TrainSnapshot {
            params,
            start_time: self.lifecycle.start_time,
            initialized: self.lifecycle.initialized,
            sim: self.sim.snapshot(),
        }
    }

    /// Rebuilds the instance from a snapshot: the parameters go through the same checks as
    /// `fmi2SetReal` (applied to the loaded scene, one rebuild), then the run-time state is
    /// restored. On failure nothing changes.
    fn restore(&mut self, snap: &TrainSnapshot) -> Result<(), String> {
        let u = snap.sim.train.inputs;
        check_snapshot_values(
            &self.vars,
            &snap.params,
            &[
                (VR_INPUT_SPEED, u.input_speed),
                (VR_INPUT_TORQUE, u.input_torque),
                (VR_LOAD_TORQUE, u.load_torque),
            ],
            snap.start_time,
        )?;
        let mut scene = self.base.clone();
        for &(vr, x) in &snap.params {
            apply(&mut scene, name_of(&self.vars, vr), vr, x)?;
        }
        let mut sim = TrainSimulation::new(&scene)
            .map_err(|e| format!("the state's parameters do not build a model: {e}"))?;
        sim.restore(&snap.sim)?;
        self.scene = scene;
        self.sim = sim;
        self.lifecycle.start_time = snap.start_time;
        self.lifecycle.initialized = snap.initialized;
        self.refresh();
        Ok(())
    }

    /// Index into the outputs of an output value reference.
    fn output_index(&self, vr: u32) -> Option<usize> {
        vr.checked_sub(VR_OUTPUT0)
            .map(|i| i as usize)
            .filter(|&i| i < self.outputs.len())
    }
}

impl CoSimModel for TrainModel {
    fn variables(&self) -> &[Variable] {
        &self.vars
    }

    fn get_real(&self, vr: u32) -> Result<f64, String> {
        let s = &self.scene;
        let u = self.sim.model().inputs();
        let per = |base: u32, len: usize| {
            vr.checked_sub(base)
                .map(|i| i as usize)
                .filter(|&i| i < len.min(BLOCK))
        };
        Ok(match vr {
            VR_MODAL_DAMPING => s.modal_damping_ratio,
            VR_INITIAL_PHASE => s.meshes[0].initial_phase,
            VR_INPUT_SPEED => u.input_speed,
            VR_INPUT_TORQUE => u.input_torque,
            VR_LOAD_TORQUE => u.load_torque,
            _ => {
                if let Some(g) = per(VR_GEAR_INERTIA0, s.gears.len()) {
                    s.gears[g].inertia
                } else if let Some(n) = per(VR_MESH_DAMPING0, s.meshes.len()) {
                    s.meshes[n].damping
                } else if let Some(n) = per(VR_MEAN_STIFFNESS0, s.meshes.len()) {
                    s.meshes[n].mean_stiffness()
                } else if let Some(i) = self.output_index(vr) {
                    self.outputs[i]
                } else {
                    return Err(format!("no Real variable with value reference {vr}"));
                }
            }
        })
    }

    fn set_real(&mut self, vr: u32, value: f64) -> Result<(), String> {
        if !self.lifecycle.initialized {
            return self.set_before_init(vr, value);
        }
        let mut u = self.sim.model().inputs();
        match vr {
            VR_INPUT_SPEED => {
                check(
                    "input_speed",
                    value,
                    value >= 0.0,
                    "a finite number >= 0 rad/s",
                )?;
                u.input_speed = value;
            }
            VR_INPUT_TORQUE => u.input_torque = value,
            VR_LOAD_TORQUE => u.load_torque = value,
            // The layer's causality/variability check comes first; this is a safety net.
            _ => {
                return Err(format!(
                    "'{}' is fixed after initialization",
                    name_of(&self.vars, vr)
                ))
            }
        }
        self.apply_inputs(u)
    }

    fn get_integer(&self, vr: u32) -> Result<i32, String> {
        match self.output_index(vr) {
            Some(i)
                if self.vars.iter().any(|v| {
                    v.value_reference == vr && v.kind == crate::fmi::model::VarKind::Integer
                }) =>
            {
                Ok(self.outputs[i] as i32)
            }
            _ => Err(format!("no Integer variable with value reference {vr}")),
        }
    }

    fn lifecycle_mut(&mut self) -> &mut Lifecycle {
        &mut self.lifecycle
    }

    /// The outputs are refreshed also after a failed step: they then show the last good
    /// state the propagator holds.
    fn do_step(&mut self, t: f64, h: f64) -> Result<(), StepFailure> {
        let result = crate::fmu::checks::do_step(&mut self.sim, self.lifecycle.start_time, t, h);
        self.refresh();
        result
    }

    fn reset(&mut self) -> Result<(), String> {
        let base = self.base.clone();
        self.sim = TrainSimulation::new(&base)?;
        self.scene = base;
        self.lifecycle = Lifecycle::default();
        self.refresh();
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

impl TrainModel {
    /// New inputs after initialization (a Model-2 mesh may refuse a load it cannot carry).
    fn apply_inputs(&mut self, u: TrainInputs) -> Result<(), String> {
        self.sim.set_inputs(u)?;
        self.refresh();
        Ok(())
    }
}
