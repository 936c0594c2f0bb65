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

use std::cell::Ref;

use crate::fmi::model::Variable;
use crate::fmu::checks::check;
use crate::fmu::kernel::{Kernel, KernelSnapshot};
use crate::model::train::{
    train_row, GearTrain, Neighbour, TrainInputs, TrainSimState, TrainSimulation,
};
use crate::scene::train::PortEnd;
use crate::scene::Scene;
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

/// The ends of the train in the order of the speed ports' inputs (VR 33–36).
const ENDS: [PortEnd; 2] = [PortEnd::Input, PortEnd::Output];

/// The scene's operating point as the inputs, in `INPUTS` order: the three of every drivetrain
/// then the speed ports' neighbour angle and speed (input port, output port; 0 where the
/// port has no speed causality and the variable does not exist).
fn start_inputs(scene: &Scene) -> Vec<f64> {
    let op = &scene.operating;
    let mut u = vec![
        op.input_speed,
        op.input_torque,
        op.load_torque * load_sign(scene),
    ];
    for end in ENDS {
        let c = (scene.ports.iter())
            .find(|p| p.end == end)
            .and_then(|p| p.coupling);
        u.extend([
            c.and_then(|c| c.angle).unwrap_or(0.0),
            c.and_then(|c| c.speed).unwrap_or(0.0),
        ]);
    }
    u
}

/// The third input is `operating.load_torque`, or with a torque port on the output gear that port's
/// `<port>.torque` = −operating.load_torque (the neighbour's torque on the wheel shaft, `docs/ports.md`).
fn load_sign(scene: &Scene) -> f64 {
    if scene.ports.iter().any(|p| p.end == PortEnd::Output) {
        -1.0
    } else {
        1.0
    }
}

fn inputs_array(u: TrainInputs, load_sign: f64, neighbours: [Option<Neighbour>; 2]) -> Vec<f64> {
    // Sized once: a host sets inputs at every communication step (no regrowth on the hot path).
    let mut v = Vec::with_capacity(3 + 2 * neighbours.len());
    v.extend([u.input_speed, u.input_torque, u.load_torque * load_sign]);
    for n in neighbours {
        v.extend(n.map_or([0.0; 2], |n| [n.angle, n.speed]));
    }
    v
}

/// The scene's speed port on `end`, if any.
fn speed_port(scene: &Scene, end: PortEnd) -> Option<usize> {
    (scene.ports.iter()).position(|p| p.end == end && p.coupling.is_some())
}

/// Sets the speed ports' start motion in the scene to the neighbour's motion of a build of
/// it (pre-twisted by the start torque unless given), so the FMU's start values and its
/// snapshots hold numbers.
fn resolve_neighbours(scene: &mut Scene) -> Result<(), String> {
    if !ENDS.iter().any(|&e| speed_port(scene, e).is_some()) {
        return Ok(());
    }
    let sim = TrainSimulation::new(scene)?;
    for end in ENDS {
        if let (Some(i), Some(n)) = (speed_port(scene, end), sim.model().neighbour(end)) {
            let c = scene.ports[i].coupling.as_mut().expect("a speed port");
            c.angle = Some(n.angle);
            c.speed = Some(n.speed);
        }
    }
    Ok(())
}

impl Kernel for Drivetrain {
    type Model = GearTrain;
    type Settings = Scene;
    type Extra = ();
    type SimState = TrainSimState;

    const FALLBACK_DESCRIPTION: &'static str = "Drivetrain of gears, shafts and meshes: per-mesh dynamic transmission error, mesh force and contact loss (geardyn)";
    const DOCUMENTATION: &'static str = documentation::DOCUMENTATION;
    const START_DOCUMENTATION: &'static str = documentation::START;
    /// Orders 1–3: the torques' cubic is a nilpotent chain of the exact propagator's lifted
    /// state ([`GearTrain::set_torque_derivatives`]), a speed port's neighbour moves on its
    /// cubic ([`Neighbour::at`]).
    const MAX_INPUT_DERIVATIVE_ORDER: u32 = 3;
    const INPUTS: &'static [u32] = &[
        VR_INPUT_SPEED,
        VR_INPUT_TORQUE,
        VR_LOAD_TORQUE,
        VR_INPUT_PORT_ANGLE,
        VR_INPUT_PORT_SPEED,
        VR_OUTPUT_PORT_ANGLE,
        VR_OUTPUT_PORT_SPEED,
    ];
    const OUTPUT0: u32 = VR_OUTPUT0;

    fn load(text: &str, origin: &str) -> Result<Scene, String> {
        let mut scene = Scene::from_toml_str(text, origin).map_err(|e| e.to_string())?;
        scene.profiles.refuse_in_fmu()?;
        if scene.elements.is_empty() && !scene.meshes.is_empty() {
            resolve_neighbours(&mut scene)?;
        }
        Ok(scene)
    }

    fn header(scene: &Scene) -> (&str, &str, &SolverSettings) {
        (&scene.name, &scene.description, &scene.solver)
    }

    fn solver_mut(scene: &mut Scene) -> &mut SolverSettings {
        &mut scene.solver
    }

    fn build(scene: &Scene) -> Result<TrainSimulation, String> {
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
        // The checks `simulate` makes when it reads the scene, for values set since.
        crate::scene::validate::drivetrain::recheck_gears(&scene.gears)?;
        TrainSimulation::new(scene)
    }

    fn variables(scene: &Scene, sim: &TrainSimulation) -> Result<Vec<Variable>, String> {
        variables::variables(scene, sim.output_names())
    }

    fn apply(scene: &mut Scene, name: &str, vr: u32, x: f64) -> Result<(), String> {
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
            VR_INPUT_PORT_ANGLE..=VR_OUTPUT_PORT_SPEED => {
                check(name, x, true, "finite")?;
                let k = (vr - VR_INPUT_PORT_ANGLE) as usize;
                let i = speed_port(scene, ENDS[k / 2])
                    .ok_or_else(|| format!("no settable variable with value reference {vr}"))?;
                let c = scene.ports[i].coupling.as_mut().expect("a speed port");
                *(if k.is_multiple_of(2) {
                    &mut c.angle
                } else {
                    &mut c.speed
                }) = Some(x);
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

    fn parameter(scene: &Scene, _: &GearTrain, vr: u32) -> Option<f64> {
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

    fn start_inputs(scene: &Scene) -> Vec<f64> {
        start_inputs(scene)
    }

    fn inputs(train: &GearTrain) -> Vec<f64> {
        let neighbours = ENDS.map(|end| train.neighbour(end));
        inputs_array(train.inputs(), train_load_sign(train), neighbours)
    }

    /// A Model-2 mesh may refuse a load it cannot carry. A speed port's neighbour is
    /// re-anchored at the current time with its angle and speed (its rates kept).
    fn set_inputs(sim: &mut TrainSimulation, u: &[f64]) -> Result<(), String> {
        let &[input_speed, input_torque, load, ..] = u else {
            return Err(format!(
                "{} inputs, expected {}",
                u.len(),
                Self::INPUTS.len()
            ));
        };
        sim.set_inputs(TrainInputs {
            input_speed,
            input_torque,
            load_torque: load * train_load_sign(sim.model()),
        })?;
        for (k, end) in ENDS.into_iter().enumerate() {
            let Some(old) = sim.model().neighbour(end) else {
                continue;
            };
            let (angle, speed) = (u[3 + 2 * k], u[4 + 2 * k]);
            if (old.angle, old.speed, old.anchor) != (angle, speed, sim.t()) {
                sim.change_model(|train, t| {
                    train.set_neighbour(
                        end,
                        Neighbour {
                            angle,
                            speed,
                            anchor: t,
                            ..old
                        },
                    )
                })?;
            }
        }
        Ok(())
    }

    fn outputs(sim: &TrainSimulation, out: &mut Vec<f64>) {
        train_row(sim, out);
    }

    fn output(sim: &TrainSimulation, k: usize) -> Option<f64> {
        sim.model()
            .port_torque(sim.output_names().get(k)?, sim.t(), sim.state())
    }

    fn extra(_: &Scene) {}

    fn set_extra(_: &mut Scene, _: &()) {}

    fn sim_state(sim: &TrainSimulation) -> TrainSimState {
        sim.snapshot()
    }

    /// With ports: the angles and speeds of the ports and bodies, whose rates are the speed
    /// and acceleration outputs (`docs/ports.md`).
    fn output_derivatives(scene: &Scene) -> bool {
        !scene.ports.is_empty()
    }

    fn output_rate(sim: &TrainSimulation, k: usize, outputs: &[f64]) -> Result<f64, String> {
        let names = sim.output_names();
        let name = &names[k];
        if let Some(rate) = sim.model().port_torque_rate(name, sim.t(), sim.state()) {
            return Ok(rate);
        }
        // `<stem>angle` → `<stem>speed`, `<stem>speed` → `<stem>acceleration`, found without
        // formatting a name (a host reads output derivatives at every communication step).
        let rate = [("angle", "speed"), ("speed", "acceleration")]
            .iter()
            .find_map(|(q, r)| {
                let stem = name.strip_suffix(q)?;
                names
                    .iter()
                    .position(|n| n.strip_prefix(stem).is_some_and(|rest| rest == *r))
            });
        match rate {
            Some(j) if sim.model().carries_rotation() => Ok(outputs[j]),
            _ => Err(format!(
                "'{name}': output derivatives are provided for the port and body angles and \
                 speeds (their rates are the speed and acceleration outputs) and the speed \
                 ports' torques, not for this output"
            )),
        }
    }

    /// The port torques' rates share the state derivative: it is evaluated once per call.
    fn output_rates<'a>(
        sim: &TrainSimulation,
        ks: &[usize],
        outputs: &dyn Fn() -> Ref<'a, [f64]>,
        out: &mut [f64],
    ) -> Result<(), String> {
        let names = sim.output_names();
        let mut dy: Option<Vec<f64>> = None;
        for (&k, slot) in ks.iter().zip(out.iter_mut()) {
            let (model, t, y) = (sim.model(), sim.t(), sim.state());
            if model.is_port_torque(&names[k]) {
                let dy = dy.get_or_insert_with(|| model.state_derivative(t, y));
                if let Some(rate) = model.port_torque_rate_with(&names[k], t, y, dy) {
                    *slot = rate;
                    continue;
                }
            }
            *slot = Self::output_rate(sim, k, &outputs())?;
        }
        Ok(())
    }

    /// The `<port>.torque` inputs of torque ports and the `<port>.angle`, `<port>.speed`
    /// inputs of speed ports (`docs/ports.md`); `operating.input_speed` and the torques of a train
    /// without ports stay held.
    fn rate_inputs(scene: &Scene) -> Vec<bool> {
        let torque_port = |end| (scene.ports.iter()).any(|p| p.end == end && p.coupling.is_none());
        let mut takes = vec![
            false,
            torque_port(PortEnd::Input),
            torque_port(PortEnd::Output),
        ];
        for end in ENDS {
            let speed = speed_port(scene, end).is_some();
            takes.extend([speed, speed]);
        }
        takes
    }

    fn input_rates(train: &GearTrain) -> Vec<[f64; 3]> {
        let [d_in, d_load] = train.torque_derivatives();
        let sign = train_load_sign(train);
        let mut du = Vec::with_capacity(3 + 2 * ENDS.len());
        du.extend([[0.0; 3], d_in, d_load.map(|d| d * sign)]);
        for end in ENDS {
            // No speed port there: held (the default neighbour's derivatives are 0).
            let n = train.neighbour(end).unwrap_or_default();
            let h = n.higher;
            du.extend([[n.angle_rate, h[0], h[1]], [n.speed_rate, h[2], h[3]]]);
        }
        du
    }

    /// A speed port's neighbour takes its derivatives from the current time on, re-anchored
    /// there.
    fn set_input_rates(sim: &mut TrainSimulation, du: &[[f64; 3]]) -> Result<(), String> {
        let sign = train_load_sign(sim.model());
        sim.change_model(|train, t| {
            train.set_torque_derivatives(t, [du[1], du[2].map(|d| d * sign)])
        })?;
        for (k, end) in ENDS.into_iter().enumerate() {
            let Some(n) = sim.model().neighbour(end) else {
                continue;
            };
            let (angle_d, speed_d) = (du[3 + 2 * k], du[4 + 2 * k]);
            let (angle_rate, speed_rate) = (angle_d[0], speed_d[0]);
            let higher = [angle_d[1], angle_d[2], speed_d[1], speed_d[2]];
            if (n.angle_rate, n.speed_rate, n.higher) == (angle_rate, speed_rate, higher) {
                continue;
            }
            sim.change_model(|train, t| {
                // The motion up to now stays: re-anchor at t before the derivatives change.
                let [angle, speed, angle_now, speed_now] = n.at(t);
                let reset = (angle_rate, speed_rate, higher) == (0.0, 0.0, [0.0; 4]);
                // The slope at the communication point for the output derivatives: a ramp's
                // rates (as before the higher orders), a cubic's derivatives at its end.
                let ended = match (reset, n.higher == [0.0; 4]) {
                    (false, _) => n.ended,
                    (true, true) => [n.angle_rate, n.speed_rate],
                    (true, false) => [angle_now, speed_now],
                };
                train.set_neighbour(
                    end,
                    Neighbour {
                        angle,
                        speed,
                        angle_rate,
                        speed_rate,
                        anchor: t,
                        ended,
                        higher,
                    },
                )
            })?;
        }
        Ok(())
    }

    /// A speed port's neighbour angle and speed where the model's motion puts them (its angle
    /// follows the speed unless the angle has a rate).
    /// A speed port's neighbour moves its angle over every step.
    fn inputs_held(train: &GearTrain) -> bool {
        train.torque_derivatives() == [[0.0; 3]; 2]
            && ENDS.iter().all(|&e| train.neighbour(e).is_none())
    }

    fn inputs_after(sim: &TrainSimulation, u: &[f64], du: &[[f64; 3]], dt: f64) -> Vec<f64> {
        let mut end: Vec<f64> = (u.iter().zip(du))
            .map(|(&u, &du)| crate::fmi::model::input_polynomial(u, du[0], [du[1], du[2]], dt))
            .collect();
        for (k, e) in ENDS.into_iter().enumerate() {
            if let Some(n) = sim.model().neighbour(e) {
                let [angle, speed, _, _] = n.at(n.anchor + dt);
                end[3 + 2 * k] = angle;
                end[4 + 2 * k] = speed;
            }
        }
        end
    }

    fn sim_inputs(scene: &Scene, state: &TrainSimState) -> Vec<f64> {
        let mut speed_ports = state.train.neighbours.iter();
        let neighbours =
            ENDS.map(|end| speed_port(scene, end).and_then(|_| speed_ports.next().copied()));
        inputs_array(state.train.inputs, load_sign(scene), neighbours)
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
