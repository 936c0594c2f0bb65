//! A drivetrain as an FMU kernel: [`TrainSimulation`] (the scene format of `docs/train.md`)
//! under the one adapter [`crate::fmu::Adapter`].
//!
//! The inputs are `operating.input_speed`, `operating.input_torque` and `operating.load_torque`; a change after
//! initialization re-anchors every mesh's phase clock ([`TrainSimulation::set_inputs`]).
//! Before initialization ends they are part of the initial operating point (the static
//! initial state uses them).

mod documentation;
pub mod state;
mod variables;

use crate::fmi::model::Variable;
use crate::fmu::checks::check;
use crate::fmu::kernel::{Kernel, KernelSnapshot};
use crate::model::train::{train_row, GearTrain, TrainInputs, TrainSimState, TrainSimulation};
use crate::scene::train::{PortEnd, TrainScene};
use crate::scene::SolverSettings;

pub use variables::*;

/// [`load_sign`] of the train's scene.
fn train_load_sign(train: &GearTrain) -> f64 {
    if train.has_output_port() {
        -1.0
    } else {
        1.0
    }
}

/// The drivetrain kernel.
pub struct Drivetrain;

/// The scene's operating point as the inputs, in `INPUTS` order.
fn start_inputs(scene: &TrainScene) -> [f64; 3] {
    let op = &scene.operating;
    [
        op.input_speed,
        op.input_torque,
        op.load_torque * load_sign(scene),
    ]
}

/// The third input is `operating.load_torque`, or with a torque port on the output gear that port's
/// `<port>.torque` = −operating.load_torque (the neighbour's torque on the wheel shaft, `docs/ports.md`).
fn load_sign(scene: &TrainScene) -> f64 {
    if scene.ports.iter().any(|p| p.end == PortEnd::Output) {
        -1.0
    } else {
        1.0
    }
}

fn inputs_array(u: TrainInputs, load_sign: f64) -> [f64; 3] {
    [u.input_speed, u.input_torque, u.load_torque * load_sign]
}

impl Kernel for Drivetrain {
    type Model = GearTrain;
    type Settings = TrainScene;
    type Extra = ();
    type SimState = TrainSimState;

    const FALLBACK_DESCRIPTION: &'static str = "Drivetrain of gears, shafts and meshes: per-mesh dynamic transmission error, mesh force and contact loss (geardyn)";
    const DOCUMENTATION: &'static str = documentation::DOCUMENTATION;
    const START_DOCUMENTATION: &'static str = documentation::START;
    const INPUTS: [u32; 3] = variables::INPUTS.vrs;
    const OUTPUT0: u32 = VR_OUTPUT0;

    fn load(text: &str, origin: &str) -> Result<TrainScene, String> {
        let scene = TrainScene::from_toml_str(text, origin).map_err(|e| e.to_string())?;
        scene.profiles.refuse_in_fmu()?;
        Ok(scene)
    }

    fn header(scene: &TrainScene) -> (&str, &str, &SolverSettings) {
        (&scene.name, &scene.description, &scene.solver)
    }

    fn build(scene: &TrainScene) -> Result<TrainSimulation, String> {
        // The first mesh carries the phase parameter; validation already requires one.
        if scene.meshes.is_empty() {
            return Err("the drivetrain has no mesh".into());
        }
        if let Some(b) = scene.elements.bodies.first() {
            // The monolithic drivetrain is the native oracle of a system of element FMUs
            // (docs/ports.md); as one FMU it would have no ports to its neighbours.
            return Err(format!(
                "scene {:?} has elements ({:?}, ...): a drivetrain with [[motor]], [[load]] or \
                 [[inertia]] runs natively (`geardyn simulate`); build the elements as their \
                 own FMUs (docs/elements.md)",
                scene.name, b.name
            ));
        }
        TrainSimulation::new(scene)
    }

    fn variables(scene: &TrainScene, sim: &TrainSimulation) -> Result<Vec<Variable>, String> {
        variables::variables(scene, sim.output_names())
    }

    fn apply(scene: &mut TrainScene, name: &str, vr: u32, x: f64) -> Result<(), String> {
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
                scene.operating.load_torque = x * load_sign(scene);
            }
            _ => {
                if let Some(g) = block_index(vr, VR_GEAR_INERTIA0, scene.gears.len()) {
                    check(name, x, x > 0.0, "a finite number > 0 kg.m2")?;
                    scene.gears[g].inertia = x;
                } else if let Some(n) = block_index(vr, VR_MESH_DAMPING0, scene.meshes.len()) {
                    nonnegative("N.s/m")?;
                    scene.meshes[n].damping = x;
                } else {
                    return Err(format!("no settable variable with value reference {vr}"));
                }
            }
        }
        Ok(())
    }

    fn parameter(scene: &TrainScene, _: &GearTrain, vr: u32) -> Option<f64> {
        let (gears, meshes) = (scene.gears.len(), scene.meshes.len());
        Some(match vr {
            VR_MODAL_DAMPING => scene.modal_damping_ratio,
            VR_INITIAL_PHASE => scene.meshes[0].initial_phase,
            _ => {
                if let Some(g) = block_index(vr, VR_GEAR_INERTIA0, gears) {
                    scene.gears[g].inertia
                } else if let Some(n) = block_index(vr, VR_MESH_DAMPING0, meshes) {
                    scene.meshes[n].damping
                } else {
                    scene.meshes[block_index(vr, VR_MEAN_STIFFNESS0, meshes)?].mean_stiffness()
                }
            }
        })
    }

    fn start_inputs(scene: &TrainScene) -> [f64; 3] {
        start_inputs(scene)
    }

    fn inputs(train: &GearTrain) -> [f64; 3] {
        inputs_array(train.inputs(), train_load_sign(train))
    }

    /// A Model-2 mesh may refuse a load it cannot carry.
    fn set_inputs(sim: &mut TrainSimulation, u: [f64; 3]) -> Result<(), String> {
        let [input_speed, input_torque, load] = u;
        sim.set_inputs(TrainInputs {
            input_speed,
            input_torque,
            load_torque: load * train_load_sign(sim.model()),
        })
    }

    fn outputs(sim: &TrainSimulation, out: &mut Vec<f64>) {
        train_row(sim, out);
    }

    fn extra(_: &TrainScene) {}

    fn set_extra(_: &mut TrainScene, _: &()) {}

    fn sim_state(sim: &TrainSimulation) -> TrainSimState {
        sim.snapshot()
    }

    /// With ports: the angles and speeds of the ports and bodies, whose rates are the speed
    /// and acceleration outputs (`docs/ports.md`).
    fn output_derivatives(scene: &TrainScene) -> bool {
        !scene.ports.is_empty()
    }

    fn output_rate(sim: &TrainSimulation, k: usize, outputs: &[f64]) -> Result<f64, String> {
        let names = sim.output_names();
        let name = &names[k];
        let rate = [("angle", "speed"), ("speed", "acceleration")]
            .iter()
            .find_map(|(q, r)| {
                let stem = name.strip_suffix(q)?;
                let target = format!("{stem}{r}");
                names.iter().position(|n| *n == target)
            });
        match rate {
            Some(j) if sim.model().carries_rotation() => Ok(outputs[j]),
            _ => Err(format!(
                "'{name}': output derivatives are provided for the port and body angles and \
                 speeds (their rates are the speed and acceleration outputs), not for this \
                 output"
            )),
        }
    }

    /// The `<port>.torque` inputs of torque ports (`docs/ports.md`); `operating.input_speed` and the
    /// torques of a train without ports stay held.
    fn rate_inputs(scene: &TrainScene) -> [bool; 3] {
        let port = |end| scene.ports.iter().any(|p| p.end == end);
        [false, port(PortEnd::Input), port(PortEnd::Output)]
    }

    fn input_rates(train: &GearTrain) -> [f64; 3] {
        let ([rate_in, rate_load], _) = train.torque_rates();
        [0.0, rate_in, rate_load * train_load_sign(train)]
    }

    fn set_input_rates(sim: &mut TrainSimulation, du: [f64; 3]) -> Result<(), String> {
        let sign = train_load_sign(sim.model());
        sim.change_model(|train, t| train.set_torque_rates(t, [du[1], du[2] * sign]))
    }

    fn sim_inputs(scene: &TrainScene, state: &TrainSimState) -> [f64; 3] {
        inputs_array(state.train.inputs, load_sign(scene))
    }

    fn restore_sim(sim: &mut TrainSimulation, state: &TrainSimState) -> Result<(), String> {
        sim.restore(state)
    }

    fn encode(s: &KernelSnapshot<Drivetrain>) -> Vec<u8> {
        state::encode(s)
    }

    fn decode(bytes: &[u8]) -> Result<KernelSnapshot<Drivetrain>, String> {
        state::decode(bytes)
    }
}
