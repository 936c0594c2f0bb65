//! The single-mesh gear pair as an FMU kernel: [`Simulation`] (the scene format of
//! `docs/model.md`) under the one adapter [`crate::fmu::Adapter`].
//!
//! The inputs are `operating.pinion_speed`, `operating.input_torque` and `operating.load_torque`; a change after
//! initialization re-anchors the mesh-phase clock ([`Simulation::set_inputs`]). Before
//! initialization they are part of the initial operating point: the static initial DTE is
//! computed from them.

mod documentation;
pub mod state;
mod variables;

use crate::fmu::checks::check;
use crate::fmu::kernel::{Kernel, KernelSnapshot};
use crate::model::{GearPair, Inputs};
use crate::scene::{ContactLaw, InitialDte, PairScene, SolverSettings};
use crate::simulation::{pair_row, SimState, Simulation};

pub use variables::*;

/// The single-mesh kernel.
pub struct Pair;

/// `initial.static_dte` and `initial.dte`: kept apart from the scene's `initial_dte` so that a
/// value set for `initial.dte` survives while the static choice is on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InitialDteChoice {
    pub static_dte: bool,
    pub initial_dte: f64,
}

/// The scene with the values set so far, and the initial-DTE choice.
#[derive(Clone)]
pub struct PairSettings {
    scene: PairScene,
    initial: InitialDteChoice,
}

impl PairSettings {
    fn new(scene: PairScene) -> PairSettings {
        let initial = InitialDteChoice {
            static_dte: scene.initial_dte == InitialDte::Static,
            initial_dte: variables::initial_dte_start(&scene),
        };
        PairSettings { scene, initial }
    }

    fn set_initial(&mut self, initial: InitialDteChoice) {
        self.initial = initial;
        self.scene.initial_dte = if initial.static_dte {
            InitialDte::Static
        } else {
            InitialDte::Value(initial.initial_dte)
        };
    }
}

/// The scene's operating point as the inputs, in `INPUTS` order.
fn start_inputs(scene: &PairScene) -> [f64; 3] {
    let op = &scene.operating;
    [op.pinion_speed, op.input_torque, op.load_torque]
}

fn inputs_array(u: Inputs) -> [f64; 3] {
    [u.pinion_speed, u.input_torque, u.load_torque]
}

impl Kernel for Pair {
    type Model = GearPair;
    type Settings = PairSettings;
    type Extra = InitialDteChoice;
    type SimState = SimState;

    const FALLBACK_DESCRIPTION: &'static str =
        "Single-mesh gear pair: dynamic transmission error, mesh force and contact loss (geardyn)";
    const DOCUMENTATION: &'static str = documentation::DOCUMENTATION;
    const START_DOCUMENTATION: &'static str = documentation::START;
    const INPUTS: &'static [u32] = &variables::INPUTS.vrs;
    const OUTPUT0: u32 = VR_OUTPUT0;

    fn load(text: &str, origin: &str) -> Result<PairSettings, String> {
        let scene = PairScene::from_toml_str(text, origin).map_err(|e| e.to_string())?;
        scene.profiles.refuse_in_fmu()?;
        Ok(PairSettings::new(scene))
    }

    fn header(s: &PairSettings) -> (&str, &str, &SolverSettings) {
        (&s.scene.name, &s.scene.description, &s.scene.solver)
    }

    fn solver_mut(s: &mut PairSettings) -> &mut SolverSettings {
        &mut s.scene.solver
    }

    fn build(s: &PairSettings) -> Result<Simulation, String> {
        Simulation::new(&s.scene)
    }

    fn variables(
        s: &PairSettings,
        _: &Simulation,
    ) -> Result<Vec<crate::fmi::model::Variable>, String> {
        Ok(variables::variables(&s.scene, s.initial.initial_dte))
    }

    fn apply(s: &mut PairSettings, name: &str, vr: u32, x: f64) -> Result<(), String> {
        let scene = &mut s.scene;
        let mut initial = s.initial;
        let positive = |unit: &str| check(name, x, x > 0.0, &format!("a finite number > 0 {unit}"));
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
                check(name, x, x >= 0.0, "a finite number >= 0 N.s/m")?;
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
                check(name, x, true, "finite")?;
                scene.initial_dte_rate = x;
            }
            VR_INITIAL_DTE => {
                check(name, x, true, "finite")?;
                initial.initial_dte = x;
            }
            VR_INITIAL_STATIC => initial.static_dte = x != 0.0,
            VR_PINION_SPEED => {
                check(name, x, x >= 0.0, "a finite number >= 0 rad/s")?;
                scene.operating.pinion_speed = x;
            }
            VR_INPUT_TORQUE => scene.operating.input_torque = x,
            VR_LOAD_TORQUE => scene.operating.load_torque = x,
            _ => return Err(format!("no settable variable with value reference {vr}")),
        }
        s.set_initial(initial);
        Ok(())
    }

    fn parameter(s: &PairSettings, pair: &GearPair, vr: u32) -> Option<f64> {
        let scene = &s.scene;
        Some(match vr {
            VR_PINION_INERTIA => scene.pinion.inertia,
            VR_GEAR_INERTIA => scene.gear.inertia,
            VR_PINION_BASE_RADIUS => scene.pinion.base_radius,
            VR_GEAR_BASE_RADIUS => scene.gear.base_radius,
            VR_DAMPING => scene.mesh.damping,
            VR_BACKLASH => match scene.mesh.contact {
                ContactLaw::Backlash { clearance } => clearance,
                _ => return None,
            },
            VR_INITIAL_PHASE => scene.mesh.initial_phase,
            VR_INITIAL_DTE_RATE => scene.initial_dte_rate,
            VR_INITIAL_DTE => s.initial.initial_dte,
            VR_EQUIVALENT_MASS => pair.equivalent_mass(),
            VR_MEAN_STIFFNESS => pair.mean_stiffness(),
            _ => return None,
        })
    }

    fn boolean(s: &PairSettings, vr: u32) -> Option<bool> {
        (vr == VR_INITIAL_STATIC).then_some(s.initial.static_dte)
    }

    fn start_inputs(s: &PairSettings) -> Vec<f64> {
        start_inputs(&s.scene).to_vec()
    }

    fn inputs(pair: &GearPair) -> Vec<f64> {
        inputs_array(pair.inputs()).to_vec()
    }

    fn set_inputs(sim: &mut Simulation, u: &[f64]) -> Result<(), String> {
        let &[pinion_speed, input_torque, load_torque] = u else {
            return Err(format!("{} inputs, expected 3", u.len()));
        };
        let u = Inputs {
            pinion_speed,
            input_torque,
            load_torque,
        };
        sim.model().check_inputs(&u)?;
        sim.set_inputs(u);
        Ok(())
    }

    fn outputs(sim: &Simulation, out: &mut Vec<f64>) {
        pair_row(sim, out);
    }

    fn extra(s: &PairSettings) -> InitialDteChoice {
        s.initial
    }

    fn set_extra(s: &mut PairSettings, extra: &InitialDteChoice) {
        s.set_initial(*extra);
    }

    fn sim_state(sim: &Simulation) -> SimState {
        sim.snapshot()
    }

    fn sim_inputs(_: &PairSettings, state: &SimState) -> Vec<f64> {
        inputs_array(state.pair.inputs).to_vec()
    }

    fn restore_sim(sim: &mut Simulation, state: &SimState) -> Result<(), String> {
        sim.restore(state)
    }

    fn encode(s: &KernelSnapshot<Pair>) -> Vec<u8> {
        state::encode(s)
    }

    fn decode(bytes: &[u8]) -> Result<KernelSnapshot<Pair>, String> {
        state::decode(bytes)
    }
}
