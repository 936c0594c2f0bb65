//! The drivetrain elements of [`crate::model::elements`] as FMI 2.0 Co-Simulation models,
//! one FMU per `[element]` scene (`docs/elements.md`): an inertia, a shaft, a motor, a load.
//!
//! Beside the gear kernels of [`crate::fmu::Adapter`] (whose contract is built around the gear
//! simulation driver), an element is small enough to be its own [`CoSimModel`]: its
//! variable table ([`variables`]), its equations on the FMU's vectors ([`system`]), the
//! element scene ([`scene`]) and the payload of its FMU state ([`state`]).
//!
//! Integration: DOP853 ([`crate::solve::rk`]) at the scene's tolerances, landing exactly on
//! `tc + h`; the shaft is stateless. The inputs are held over a step, or, after
//! `fmi2SetRealInputDerivatives` (orders 1 to 3), follow their Taylor polynomial
//! `u + u'·s + u''·s²/2 + u⁽³⁾·s³/6`, `s = t − tc`, during the next step (the right-hand
//! side reads them at `t`, so the integrator sees the polynomial: a master that knows the
//! producer's values and slopes at both ends gives the cubic Hermite interpolant, whose
//! error is fourth order where a line's is second); output derivatives of
//! order 1 are answered for every output ([`system::output_rates`]), with the inputs' rates
//! at `tc` (`du_now`): those of the ramp that ended there, until new ones are set. Reading
//! them with the rates reset to 0 would drop every term of an output's derivative that comes
//! from its inputs' rates (the shaft's `c·(α_a − α_b)`), an O(1) error in the master's
//! extrapolation slope that makes the coupling first order (FMI 2.0.5 §4.2.1: the derivative
//! is that of the output at the communication point).

mod documentation;
pub mod scene;
pub mod state;
pub mod system;
pub mod variables;

use crate::fmi::model::input_polynomial;
use std::cell::RefCell;

use crate::fmi::model::{
    Capabilities, Causality, CoSimModel, DefaultExperiment, Lifecycle, LoadedModel, ModelInfo,
    StepFailure, Variable,
};
use crate::fmu::checks::check_snapshot_values;
use crate::fmu::payload::RecordedParams;
use crate::fmu::table::name_of;
use crate::model::elements::ElementSpec;
use crate::solve::rk::RkStepper;

pub use scene::{is_element_text, ElementScene};
use state::ElementSnapshot;
use variables::{VR_INPUT0, VR_OUTPUT0, VR_PARAM0};

/// The most inputs [`CoSimModel::set_reals`] sets together (an element has at most 4).
const MAX_INPUTS: usize = 8;

/// The value of the parameter `name` in a scene (`None`: the element has no such parameter).
pub fn parameter(scene: &ElementScene, name: &str) -> Option<f64> {
    let init = &scene.initial;
    Some(match (&scene.element, name) {
        (_, "initial.angle") => init.angle,
        (_, "initial.speed") => init.speed,
        (ElementSpec::Inertia(s), "inertia") => s.inertia,
        (ElementSpec::Inertia(s), "damping") => s.damping,
        (ElementSpec::Shaft(s), "stiffness") => s.stiffness,
        (ElementSpec::Shaft(s), "damping") => s.damping,
        (ElementSpec::Motor(m), "inertia") => m.inertia,
        (ElementSpec::Motor(m), "damping") => m.damping,
        (ElementSpec::Motor(m), "controller.kp") => m.controller?.kp,
        (ElementSpec::Motor(m), "controller.ki") => m.controller?.ki,
        (ElementSpec::Load(s), "inertia") => s.inertia,
        (ElementSpec::Load(s), "torque") => s.torque,
        (ElementSpec::Load(s), "viscous") => s.viscous,
        (ElementSpec::Load(s), "drag") => s.drag,
        _ => return None,
    })
}

/// Sets the parameter `name` of a scene and checks the element (the message names the
/// parameter and the value); on failure the scene is unchanged.
fn apply(scene: &mut ElementScene, name: &str, x: f64) -> Result<(), String> {
    let mut s = scene.clone();
    let slot: &mut f64 = match (&mut s.element, name) {
        (_, "initial.angle") => &mut s.initial.angle,
        (_, "initial.speed") => &mut s.initial.speed,
        (ElementSpec::Inertia(e), "inertia") => &mut e.inertia,
        (ElementSpec::Inertia(e), "damping") => &mut e.damping,
        (ElementSpec::Shaft(e), "stiffness") => &mut e.stiffness,
        (ElementSpec::Shaft(e), "damping") => &mut e.damping,
        (ElementSpec::Motor(m), "inertia") => &mut m.inertia,
        (ElementSpec::Motor(m), "damping") => &mut m.damping,
        (ElementSpec::Motor(m), "controller.kp") => match &mut m.controller {
            Some(c) => &mut c.kp,
            None => return Err(format!("no parameter '{name}'")),
        },
        (ElementSpec::Motor(m), "controller.ki") => match &mut m.controller {
            Some(c) => &mut c.ki,
            None => return Err(format!("no parameter '{name}'")),
        },
        (ElementSpec::Load(e), "inertia") => &mut e.inertia,
        (ElementSpec::Load(e), "torque") => &mut e.torque,
        (ElementSpec::Load(e), "viscous") => &mut e.viscous,
        (ElementSpec::Load(e), "drag") => &mut e.drag,
        _ => return Err(format!("no parameter '{name}'")),
    };
    *slot = x;
    if !x.is_finite() {
        return Err(format!("parameter '{name}' = {x}: must be finite"));
    }
    s.element
        .validate("")
        .map_err(|e| format!("parameter {e}"))?;
    *scene = s;
    Ok(())
}

/// The RK steps one call may take: the default work budget of an FMI call
/// ([`crate::simulation::budget`]) at the cost of a step of this size, so an element's
/// `fmi2DoStep` is bounded like a gear FMU's (issue 34).
fn call_budget_steps(dim: usize) -> u64 {
    use crate::simulation::budget::{rk_step_cost, DEFAULT_CALL_BUDGET};
    (DEFAULT_CALL_BUDGET / rk_step_cost(dim)) as u64
}

/// The inputs a scene starts from, in value-reference order.
pub fn start_inputs(spec: &ElementSpec) -> Vec<f64> {
    match spec {
        ElementSpec::Inertia(_) => vec![0.0; 2],
        ElementSpec::Shaft(_) => vec![0.0; 4],
        ElementSpec::Motor(m) => {
            let u = m.start_inputs();
            let second = if m.controller.is_some() {
                u.speed_reference
            } else {
                u.torque_fraction
            };
            vec![u.flange_torque, second]
        }
        ElementSpec::Load(_) => vec![0.0],
    }
}

/// The initial state vector of a scene.
fn initial_state(scene: &ElementScene) -> Vec<f64> {
    let mut y = vec![0.0; system::dim(&scene.element)];
    if y.len() >= 2 {
        y[0] = scene.initial.angle;
        y[1] = scene.initial.speed;
    }
    y
}

/// One element behind an FMU instance.
pub struct ElementFmu {
    vars: Vec<Variable>,
    /// The scene as loaded (restored by `fmi2Reset`).
    base: ElementScene,
    /// The scene with the parameter values set so far.
    scene: ElementScene,
    lifecycle: Lifecycle,
    /// Model time from the start time (`t − startTime`).
    t: f64,
    /// State vector when there is no stepper (the stateless shaft: empty).
    y0: Vec<f64>,
    /// DOP853 over the state (`None` for the shaft).
    stepper: Option<RkStepper>,
    /// Start values of the inputs (set before initialization) and current inputs at `t`.
    u_start: Vec<f64>,
    u: Vec<f64>,
    /// First-order input rates for the next step (0: zero-order hold).
    du: Vec<f64>,
    /// Second and third input derivatives for the next step (0: a ramp or a hold).
    du_higher: Vec<[f64; 2]>,
    /// The inputs' rates at `t`, for the output derivatives: the last rates set, kept when a
    /// step ends (where `du` returns to 0) so they are the slope of the ramp that ended at `t`.
    du_now: Vec<f64>,
    scratch: RefCell<Vec<f64>>,
    /// [`ElementFmu::params`] once initialized.
    params_cache: RecordedParams,
    /// How many outputs the variable table has (value references `VR_OUTPUT0 + k`).
    n_outputs: usize,
}

impl ElementFmu {
    /// Builds the model of a validated scene and its description data.
    pub fn new(scene: ElementScene, guid: String) -> Result<(ElementFmu, ModelInfo), String> {
        let u = start_inputs(&scene.element);
        let vars = variables::variables(&scene, &u);
        crate::fmi::model::validate_variables(&vars)?;
        let info = ModelInfo {
            model_name: scene.name.clone(),
            description: if scene.description.is_empty() {
                format!("Drivetrain element: {} (geardyn)", scene.element.kind())
            } else {
                scene.description.clone()
            },
            default_experiment: DefaultExperiment {
                start_time: 0.0,
                stop_time: scene.solver.stop_time,
                step_size: scene.solver.output_interval,
                tolerance: None,
            },
            guid,
            documentation: documentation::html(&scene.element),
        };
        let n = u.len();
        let n_outputs = (vars.iter())
            .filter(|v| v.causality == Causality::Output)
            .count();
        let mut fmu = ElementFmu {
            vars,
            base: scene.clone(),
            scene,
            lifecycle: Lifecycle::default(),
            t: 0.0,
            y0: Vec::new(),
            stepper: None,
            u_start: u.clone(),
            u,
            du: vec![0.0; n],
            du_higher: vec![[0.0; 2]; n],
            du_now: vec![0.0; n],
            scratch: RefCell::new(Vec::with_capacity(n)),
            params_cache: RecordedParams::default(),
            n_outputs,
        };
        fmu.rebuild()?;
        Ok((fmu, info))
    }

    /// Back to `t = 0` in the initial state of the current scene, inputs at their start
    /// values, no input rates.
    fn rebuild(&mut self) -> Result<(), String> {
        let y = initial_state(&self.scene);
        self.stepper = if y.is_empty() {
            None
        } else {
            let mut st = RkStepper::new(self.scene.solver.rk_options(), y.len())?;
            st.set_state(0.0, &y);
            st.set_max_steps(call_budget_steps(y.len()));
            Some(st)
        };
        self.y0 = y;
        self.t = 0.0;
        self.u.clone_from(&self.u_start);
        self.du.iter_mut().for_each(|d| *d = 0.0);
        self.du_higher.iter_mut().for_each(|d| *d = [0.0; 2]);
        self.du_now.iter_mut().for_each(|d| *d = 0.0);
        Ok(())
    }

    fn y(&self) -> &[f64] {
        self.stepper.as_ref().map_or(&self.y0, RkStepper::y)
    }

    fn input_index(&self, vr: u32) -> Option<usize> {
        vr.checked_sub(VR_INPUT0)
            .map(|k| k as usize)
            .filter(|&k| k < self.u.len())
    }

    fn output_index(&self, vr: u32) -> Option<usize> {
        vr.checked_sub(VR_OUTPUT0)
            .map(|k| k as usize)
            .filter(|&k| k < self.n_outputs)
    }

    fn param_name(&self, vr: u32) -> Option<&'static str> {
        let names = variables::param_names(&self.scene.element);
        vr.checked_sub(VR_PARAM0)
            .and_then(|k| names.get(k as usize).copied())
    }

    fn outputs(&self) -> Vec<f64> {
        // At most six outputs (the inertia's): one allocation, no regrowth.
        let mut out = Vec::with_capacity(6);
        system::outputs(&self.scene.element, self.y(), &self.u, &mut out);
        out
    }

    /// The parameter and start-input values by value reference, as a state records them.
    fn params(&self) -> Vec<(u32, f64)> {
        self.params_cache
            .get(self.lifecycle.initialized, || self.current_params())
    }

    fn current_params(&self) -> Vec<(u32, f64)> {
        let names = variables::param_names(&self.scene.element);
        let mut params: Vec<(u32, f64)> = names
            .iter()
            .enumerate()
            .map(|(k, n)| {
                (
                    VR_PARAM0 + k as u32,
                    parameter(&self.scene, n).unwrap_or(f64::NAN),
                )
            })
            .collect();
        params.extend(
            self.u_start
                .iter()
                .enumerate()
                .map(|(k, &x)| (VR_INPUT0 + k as u32, x)),
        );
        params
    }

    /// Rebuilds the instance from a snapshot with the checks of `fmi2SetReal`; on failure
    /// nothing changes.
    fn restore(&mut self, s: &ElementSnapshot) -> Result<(), String> {
        let inputs: Vec<(u32, f64)> = (s.u.iter().enumerate())
            .map(|(k, &x)| (VR_INPUT0 + k as u32, x))
            .collect();
        check_snapshot_values(&self.vars, &s.params, &inputs, s.start_time)?;
        if s.u.len() != self.u.len()
            || s.du.len() != self.u.len()
            || s.du_higher.len() != self.u.len()
            || s.du_now.len() != self.u.len()
        {
            return Err(format!(
                "the state holds {} inputs and {} and {} rates; the model has {} inputs",
                s.u.len(),
                s.du.len(),
                s.du_now.len(),
                self.u.len()
            ));
        }
        let higher = s.du_higher.iter().flatten();
        if let Some(d) =
            s.du.iter()
                .chain(&s.du_now)
                .chain(higher)
                .find(|d| !d.is_finite())
        {
            return Err(format!("the state holds an input rate {d}"));
        }
        if !(s.t.is_finite() && s.t >= 0.0) || s.y.iter().any(|y| !y.is_finite()) {
            return Err(format!(
                "the state holds a non-finite time or state at t = {}",
                s.t
            ));
        }
        if crate::fmu::checks::same_values(&s.params, &self.params()) {
            // The parameters this instance has (the rollback of an error-controlled master,
            // at every undone step): only the run-time state changes, no scene is rebuilt.
            return self.restore_run(s);
        }
        // Other parameters from here on (or none, on failure: recomputed).
        self.params_cache.clear();
        let mut scene = self.base.clone();
        let mut u_start = start_inputs(&scene.element);
        for &(vr, x) in &s.params {
            if let Some(k) = self.input_index(vr) {
                u_start[k] = x;
            } else {
                let name = self
                    .param_name(vr)
                    .ok_or_else(|| format!("the state sets unknown value reference {vr}"))?;
                apply(&mut scene, name, x)?;
            }
        }
        let dim = system::dim(&scene.element);
        if s.y.len() != dim || s.controller.is_some() != (dim > 0) {
            return Err(format!(
                "the state holds {} states; the element has {dim}",
                s.y.len()
            ));
        }
        let stepper = match s.controller {
            Some(mem) => {
                let mut st = RkStepper::new(scene.solver.rk_options(), dim)?;
                st.restore(s.t, &s.y, &mem);
                st.set_max_steps(call_budget_steps(dim));
                Some(st)
            }
            None => None,
        };
        self.scene = scene;
        self.stepper = stepper;
        self.y0 = if dim == 0 { Vec::new() } else { s.y.clone() };
        self.u_start = u_start;
        self.restore_clock_and_inputs(s);
        Ok(())
    }

    /// [`ElementFmu::restore`] of a state with this instance's own parameters: the stepper
    /// continues from the state's time, solution and controller memory, as a new one would.
    fn restore_run(&mut self, s: &ElementSnapshot) -> Result<(), String> {
        let dim = system::dim(&self.scene.element);
        if s.y.len() != dim || s.controller.is_some() != self.stepper.is_some() {
            return Err(format!(
                "the state holds {} states; the element has {dim}",
                s.y.len()
            ));
        }
        if let (Some(st), Some(mem)) = (self.stepper.as_mut(), s.controller) {
            st.restore(s.t, &s.y, &mem);
        } else {
            self.y0.clone_from(&s.y);
        }
        self.restore_clock_and_inputs(s);
        Ok(())
    }

    /// The part of a restore that is the same with any parameters: the time, the held inputs
    /// and their rates, and the life-cycle state.
    fn restore_clock_and_inputs(&mut self, s: &ElementSnapshot) {
        self.t = s.t;
        self.u.clone_from(&s.u);
        self.du.clone_from(&s.du);
        self.du_higher.clone_from(&s.du_higher);
        self.du_now.clone_from(&s.du_now);
        self.lifecycle = Lifecycle {
            start_time: s.start_time,
            initialized: s.initialized,
        };
    }
}

impl CoSimModel for ElementFmu {
    fn variables(&self) -> &[Variable] {
        &self.vars
    }

    fn get_real(&self, vr: u32) -> Result<f64, String> {
        if let Some(k) = self.output_index(vr) {
            return Ok(self.outputs()[k]);
        }
        if let Some(k) = self.input_index(vr) {
            return Ok(self.u[k]);
        }
        self.param_name(vr)
            .and_then(|n| parameter(&self.scene, n))
            .ok_or_else(|| format!("no Real variable with value reference {vr}"))
    }

    /// The outputs computed once per call.
    fn get_reals(&self, vrs: &[u32], out: &mut [f64]) -> Result<(), String> {
        let mut outputs = None;
        for (&vr, slot) in vrs.iter().zip(out.iter_mut()) {
            *slot = match self.output_index(vr) {
                Some(k) => outputs.get_or_insert_with(|| self.outputs())[k],
                None => self.get_real(vr)?,
            };
        }
        Ok(())
    }

    /// A value the outputs cannot carry is refused where it is set (issue 34: an
    /// `initial.angle` of -1e308 read back as a non-finite output): the check follows every
    /// accepted set, and the instance is restored on refusal.
    fn set_real(&mut self, vr: u32, value: f64) -> Result<(), String> {
        if let Some(i) = self.input_index(vr) {
            // An input, set at every communication step: only `u[i]` (and before
            // initialization its start value) changes, so only they are kept for a refusal.
            let before = (self.u[i], self.u_start[i]);
            self.set_real_unchecked(vr, value)?;
            let outputs = self.outputs();
            let Some(k) = outputs.iter().position(|y| !y.is_finite()) else {
                return Ok(());
            };
            (self.u[i], self.u_start[i]) = before;
            if let Some(st) = &mut self.stepper {
                st.invalidate();
            }
            return Err(self.refusal(vr, value, k, outputs[k]));
        }
        let before = (self.scene.clone(), self.u.clone(), self.u_start.clone());
        self.set_real_unchecked(vr, value)?;
        let outputs = self.outputs();
        let Some(k) = outputs.iter().position(|y| !y.is_finite()) else {
            return Ok(());
        };
        let (scene, u, u_start) = before;
        let rebuilt = self.scene != scene;
        (self.scene, self.u, self.u_start) = (scene, u, u_start);
        if rebuilt {
            let kept = (self.u.clone(), self.du.clone(), self.du_higher.clone());
            let du_now = self.du_now.clone();
            self.rebuild().ok();
            (self.u, self.du, self.du_higher) = kept;
            self.du_now = du_now;
        } else if let Some(st) = &mut self.stepper {
            st.invalidate();
        }
        Err(self.refusal(vr, value, k, outputs[k]))
    }

    /// After initialization the inputs of one call (a master sets them before every step)
    /// are set together and the outputs checked once, not once per value. Should an output
    /// then not be finite, the inputs go back to where they were and are set one by one with
    /// [`CoSimModel::set_real`], which names the value that makes it so (the earlier ones
    /// stay set, as in that sequence).
    fn set_reals(&mut self, vrs: &[u32], values: &[f64]) -> Result<(), String> {
        let n = self.u.len();
        let together = self.lifecycle.initialized
            && vrs.len() > 1
            && n <= MAX_INPUTS
            && vrs.iter().all(|&vr| self.input_index(vr).is_some());
        if together {
            let mut before = [0.0; MAX_INPUTS];
            before[..n].copy_from_slice(&self.u);
            for (&vr, &x) in vrs.iter().zip(values) {
                if let Some(k) = self.input_index(vr) {
                    self.u[k] = x;
                }
            }
            // The right-hand side changed at the current time.
            if let Some(st) = &mut self.stepper {
                st.invalidate();
            }
            if self.outputs().iter().all(|y| y.is_finite()) {
                return Ok(());
            }
            self.u.copy_from_slice(&before[..n]);
        }
        for (&vr, &x) in vrs.iter().zip(values) {
            self.set_real(vr, x)?;
        }
        Ok(())
    }

    fn lifecycle_mut(&mut self) -> &mut Lifecycle {
        &mut self.lifecycle
    }

    fn do_step(&mut self, t: f64, h: f64) -> Result<(), StepFailure> {
        let start_time = self.lifecycle.start_time;
        let target = ((t + h) - start_time).max(self.t);
        let dt = target - self.t;
        // A ramp must stay within the inputs' bounds at the end of the step.
        for k in 0..self.u.len() {
            if self.du[k] != 0.0 || self.du_higher[k] != [0.0; 2] {
                let var = &self.vars[self
                    .vars
                    .iter()
                    .position(|v| v.value_reference == VR_INPUT0 + k as u32)
                    .unwrap_or(0)];
                let end = input_polynomial(self.u[k], self.du[k], self.du_higher[k], dt);
                var.check_value(end).map_err(|e| {
                    StepFailure::Error(format!(
                        "the input ramp leaves the bounds by the end of the step: {e} (rate {})",
                        self.du[k]
                    ))
                })?;
            }
        }
        if let Some(st) = &mut self.stepper {
            let mut sys = system::StepSystem {
                spec: &self.scene.element,
                u: &self.u,
                du: &self.du,
                du_higher: &self.du_higher,
                t0: self.t,
                scratch: std::mem::take(&mut self.scratch),
            };
            let result = st.advance_to(&mut sys, target);
            self.scratch = sys.scratch;
            if let Err(e) = result {
                // The inputs follow the state to where the integrator stopped.
                let reached = st.t();
                for k in 0..self.u.len() {
                    let (du, higher) = (self.du[k], self.du_higher[k]);
                    self.u[k] = input_polynomial(self.u[k], du, higher, reached - self.t);
                }
                self.t = reached;
                return Err(StepFailure::Discard {
                    reason: format!("the integrator stopped: {e}"),
                    reached: start_time + reached,
                    terminate: false,
                });
            }
        }
        // The output derivatives at the new time see the rates of the ramp that ended here.
        for k in 0..self.u.len() {
            self.du_now[k] = system::input_rate_at(self.du[k], self.du_higher[k], dt);
        }
        let higher = self.du_higher.iter().any(|d| *d != [0.0; 2]);
        if higher || self.du.iter().any(|&d| d != 0.0) {
            for k in 0..self.u.len() {
                self.u[k] = input_polynomial(self.u[k], self.du[k], self.du_higher[k], dt);
                self.du[k] = 0.0;
                self.du_higher[k] = [0.0; 2];
            }
            // The inputs at the new time come from the ramp: f(t, y) is recomputed from them.
            if let Some(st) = &mut self.stepper {
                st.invalidate();
            }
        }
        self.t = target;
        Ok(())
    }

    fn reset(&mut self) -> Result<(), String> {
        self.params_cache.clear();
        self.scene = self.base.clone();
        self.u_start = start_inputs(&self.scene.element);
        self.lifecycle = Lifecycle::default();
        self.rebuild()
    }

    /// The state encoded from the instance's own fields (no snapshot copied first).
    fn save_state(&mut self) -> Vec<u8> {
        let params = || self.current_params();
        self.params_cache
            .with(self.lifecycle.initialized, params, |params| {
                state::encode(&state::ElementStateRef {
                    params,
                    start_time: self.lifecycle.start_time,
                    initialized: self.lifecycle.initialized,
                    t: self.t,
                    y: self.y(),
                    u: &self.u,
                    du: &self.du,
                    du_higher: &self.du_higher,
                    du_now: &self.du_now,
                    controller: self.stepper.as_ref().map(RkStepper::controller_memory),
                })
            })
    }

    fn load_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        self.restore(&state::decode(bytes)?)
    }

    fn capabilities(&self) -> Capabilities {
        Capabilities {
            can_interpolate_inputs: true,
            max_output_derivative_order: 1,
            max_input_derivative_order: 3,
            // Elements are smooth: no switches a master could step to.
            switch_time: None,
        }
    }

    /// The output derivatives at `tc` read the first derivative set (`du_now`).
    fn set_input_derivative(&mut self, vr: u32, order: u32, value: f64) -> Result<(), String> {
        let k = self
            .input_index(vr)
            .ok_or_else(|| format!("'{}' (vr {vr}) is not an input", name_of(&self.vars, vr)))?;
        match order {
            1 => {
                self.du[k] = value;
                self.du_now[k] = value;
            }
            2 | 3 => self.du_higher[k][order as usize - 2] = value,
            _ => return Err(format!("input derivative order {order} (orders 1 to 3)")),
        }
        Ok(())
    }

    fn output_derivative(&self, vr: u32) -> Result<f64, String> {
        let k = self
            .output_index(vr)
            .ok_or_else(|| format!("'{}' (vr {vr}) is not an output", name_of(&self.vars, vr)))?;
        Ok(system::output_rate(
            &self.scene.element,
            k,
            self.y(),
            &self.u,
            &self.du_now,
        ))
    }
}

impl ElementFmu {
    /// Why `vr = value` was refused: output `k` would be `y`, which is not finite.
    fn refusal(&self, vr: u32, value: f64, k: usize, y: f64) -> String {
        let output = self
            .vars
            .iter()
            .find(|v| v.value_reference == VR_OUTPUT0 + k as u32)
            .map_or("?", |v| v.name.as_str());
        let name = name_of(&self.vars, vr);
        format!("'{name}' = {value:?}: the output '{output}' would be {y}")
    }

    /// [`CoSimModel::set_real`] without the check of the outputs.
    fn set_real_unchecked(&mut self, vr: u32, value: f64) -> Result<(), String> {
        if let Some(k) = self.input_index(vr) {
            self.u[k] = value;
            if self.lifecycle.initialized {
                // The right-hand side changed at the current time.
                if let Some(st) = &mut self.stepper {
                    st.invalidate();
                }
            } else {
                self.u_start[k] = value;
            }
            return Ok(());
        }
        let name = self
            .param_name(vr)
            .ok_or_else(|| format!("no settable variable with value reference {vr}"))?;
        if self.lifecycle.initialized {
            return Err(format!("'{name}' is fixed after initialization"));
        }
        let mut scene = self.scene.clone();
        apply(&mut scene, name, value)?;
        let old = std::mem::replace(&mut self.scene, scene);
        let (u, du, du_now) = (self.u.clone(), self.du.clone(), self.du_now.clone());
        let du_higher = self.du_higher.clone();
        if let Err(e) = self.rebuild() {
            self.scene = old;
            self.rebuild().ok();
            return Err(format!("'{name}' = {value:?}: {e}"));
        }
        // Inputs set so far stay set.
        self.u = u;
        self.du = du;
        self.du_higher = du_higher;
        self.du_now = du_now;
        Ok(())
    }
}

/// Parses and validates an element scene and adapts it to the FMI layer.
pub fn load(text: &str, origin: &str, guid: String) -> Result<LoadedModel, String> {
    let scene = ElementScene::from_toml_str(text, origin)?;
    let (model, info) =
        ElementFmu::new(scene, guid).map_err(|e| format!("scene '{origin}': {e}"))?;
    Ok(LoadedModel {
        model: Box::new(model),
        info,
    })
}
