//! The one FMU adapter: a gear model of any [`Kernel`] as a [`CoSimModel`].
//!
//! Time: the scene's `t = 0` is the experiment's `startTime` (FMI 2.0.x §2.1.6,
//! `fmi2SetupExperiment`), so the model integrates in local time `τ = t − startTime`, which
//! for the usual `startTime = 0` is the host's time bit for bit.
//!
//! Inputs are held constant over a communication step, except those a kernel interpolates
//! ([`Kernel::rate_inputs`]: `canInterpolateInputs`, the Taylor polynomial over the next step,
//! FMI 2.0.x §4.2.1); a change re-anchors the mesh-phase clocks at the current time, so the phases stay
//! continuous. Before initialization is finished the inputs are part of the initial
//! operating point (a static initial state is computed from them).
//!
//! Parameters are `fixed` (FMI 2.0.x §2.2.7): they change the equations, so they may be set
//! before `fmi2ExitInitializationMode` only; every accepted change rebuilds the simulation so
//! outputs read in initialization mode are consistent.

use std::cell::{Cell, Ref, RefCell};

use crate::fmi::model::{
    Capabilities, Causality, CoSimModel, DefaultExperiment, Initial, Lifecycle, ModelInfo,
    StepFailure, Variability, Variable,
};
use crate::fmu::checks::check_snapshot_values;
use crate::fmu::kernel::{Kernel, KernelSnapshot};
use crate::fmu::payload::RecordedParams;
use crate::fmu::table::{name_of, settable_reals};
use crate::simulation::budget::{self, DEFAULT_CALL_BUDGET};
use crate::simulation::{DrivenModel, Driver};
use crate::solve::SolveError;

/// Value reference of the parameter `solver.work_budget` (docs/fmu.md "Work budget"), which
/// every gear FMU has; free in both kernels' tables.
pub const VR_WORK_BUDGET: u32 = 29;

/// Value reference of `solver.next_switch_time` (docs/cosimulation.md, "Steps that end at
/// the stage's knots"), which every gear FMU has; free in both kernels' tables.
pub const VR_NEXT_SWITCH_TIME: u32 = 28;

/// A step the integrator stopped at `reached`. Not the FMU ending the simulation
/// (fmi2Terminated stays false, so hosts report it); an exhausted work budget leaves a valid
/// state: a master may go on with shorter steps or a raised solver.work_budget.
fn refused(e: &SolveError, reached: f64) -> StepFailure {
    StepFailure::Discard {
        reason: format!("the integrator stopped: {e}"),
        reached,
        terminate: false,
    }
}

/// Advances to a communication point. A point on a switching instant reports the state after
/// the switch, as `simulate`'s rows do ([`Driver::switch_at_now`]).
fn advance_to_communication_point<M: DrivenModel>(
    sim: &mut Driver<M>,
    t: f64,
) -> Result<(), SolveError> {
    sim.advance_to(t)?;
    match sim.switch_at_now() {
        Some(stop) => sim.advance_to(stop),
        None => Ok(()),
    }
}

/// The local variable `solver.next_switch_time`: the time of the model's next known switch
/// of its equations, announced to the master by the vendor annotation
/// ([`Capabilities::switch_time`]).
fn next_switch_time_variable() -> Variable {
    Variable::real(
        NEXT_SWITCH_TIME,
        VR_NEXT_SWITCH_TIME,
        Causality::Local,
        Variability::Discrete,
        Some(Initial::Calculated),
        None,
        Some("s"),
        "Time of the model's next known switch of its equations (a mesh stiffness or STE \
         knot, where the outputs' slopes jump; the largest double when none is known): a master may end a \
         communication step there, so that no input polynomial spans the kink \
         (docs/cosimulation.md)",
    )
}

/// The name of [`VR_NEXT_SWITCH_TIME`].
pub const NEXT_SWITCH_TIME: &str = "solver.next_switch_time";

/// The simulation of `settings` with the budget of one FMI call: the scene's
/// `solver.work_budget`, else [`DEFAULT_CALL_BUDGET`].
fn build_sim<K: Kernel>(settings: &K::Settings) -> Result<Driver<K::Model>, String> {
    let mut sim = K::build(settings)?;
    sim.default_work_budget(DEFAULT_CALL_BUDGET);
    Ok(sim)
}

/// The parameter `solver.work_budget` with its start value.
fn work_budget_variable(limit: f64) -> Variable {
    let mut v = crate::fmu::table::param(
        budget::BUDGET_KEY,
        VR_WORK_BUDGET,
        limit,
        None,
        "Work budget of one FMI call (about one floating-point multiply-add per unit): a call \
         that would need more returns fmi2Discard naming the likely cause (docs/fmu.md)",
    );
    v.min = Some(1.0);
    v
}

/// A gear model behind an FMU instance.
pub struct Adapter<K: Kernel> {
    vars: Vec<Variable>,
    /// The settings as loaded (restored by `fmi2Reset`).
    base: K::Settings,
    /// The settings with the parameter and start-input values set so far.
    settings: K::Settings,
    sim: Driver<K::Model>,
    /// Start time and initialization stage (FMI life cycle).
    lifecycle: Lifecycle,
    /// How many outputs there are (value references `K::OUTPUT0 + i`).
    n_outputs: usize,
    /// The outputs of the current state, evaluated on the first read: a host reads them one
    /// value reference at a time (and the FMI layer checks them after every step), and each
    /// evaluation computes all of them. Stale after every change of the simulation or its
    /// parameters: all of those go through `&mut self` (see [`Adapter::sim_mut`]). The
    /// buffer is kept, so a step allocates nothing.
    outputs: RefCell<Vec<f64>>,
    outputs_fresh: Cell<bool>,
    /// [`Adapter::params`] once initialized.
    params_cache: RecordedParams,
    /// [`Kernel::rate_inputs`] of the loaded settings: which inputs take rates is fixed by the
    /// scene's ports, which no parameter changes; looked up at every
    /// `fmi2SetRealInputDerivatives`.
    rate_inputs: Vec<bool>,
}

/// Why a set of parameter values was refused after it was applied: the model cannot be built
/// from it, or an initial output is not finite. Worded by [`Refusal::naming`] after the value
/// that caused it.
enum Refusal {
    Build(String),
    /// An initial output's name and value: a start value the arithmetic cannot carry (an
    /// initial DTE rate of 1e308 gives an infinite damping force) is refused where it is
    /// set, naming the output, rather than read back as an infinite output (issue 17).
    Output(String, f64),
}

impl Refusal {
    fn naming(&self, name: &str, x: f64) -> String {
        match self {
            Refusal::Build(e) => format!("'{name}' = {x:?}: the model cannot be built: {e}"),
            Refusal::Output(output, y) => {
                format!("'{name}' = {x:?}: the initial output '{output}' would be {y}")
            }
        }
    }
}

impl<K: Kernel> Adapter<K> {
    /// Builds the model of validated settings and its description data.
    pub fn new(settings: K::Settings, guid: String) -> Result<(Adapter<K>, ModelInfo), String> {
        let sim = build_sim::<K>(&settings)?;
        let mut vars = K::variables(&settings, &sim)?;
        vars.push(work_budget_variable(
            sim.work_limit().unwrap_or(DEFAULT_CALL_BUDGET),
        ));
        vars.push(next_switch_time_variable());
        let (name, description, solver) = K::header(&settings);
        let info = ModelInfo {
            model_name: name.to_string(),
            description: if description.is_empty() {
                K::FALLBACK_DESCRIPTION
            } else {
                description
            }
            .to_string(),
            default_experiment: DefaultExperiment {
                start_time: 0.0,
                stop_time: solver.stop_time,
                step_size: solver.output_interval,
                tolerance: None,
            },
            guid,
            documentation: documentation(
                K::DOCUMENTATION,
                K::START_DOCUMENTATION,
                K::rate_inputs(&settings).contains(&true),
            ),
        };
        let n_outputs = vars
            .iter()
            .filter(|v| v.causality == Causality::Output)
            .count();
        let rate_inputs = K::rate_inputs(&settings);
        let model = Adapter {
            vars,
            base: settings.clone(),
            settings,
            sim,
            lifecycle: Lifecycle::default(),
            n_outputs,
            outputs: RefCell::new(Vec::new()),
            outputs_fresh: Cell::new(false),
            params_cache: RecordedParams::default(),
            rate_inputs,
        };
        Ok((model, info))
    }

    /// The simulation of `settings` and its initial outputs, which must be finite.
    fn build(&self, settings: &K::Settings) -> Result<(Driver<K::Model>, Vec<f64>), Refusal> {
        let sim = build_sim::<K>(settings).map_err(Refusal::Build)?;
        let mut outputs = Vec::new();
        K::outputs(&sim, &mut outputs);
        match outputs.iter().position(|y| !y.is_finite()) {
            None => Ok((sim, outputs)),
            Some(k) => Err(Refusal::Output(self.output_name(k).to_string(), outputs[k])),
        }
    }

    /// Applies a parameter or start-input value and rebuilds the simulation; on failure
    /// nothing changes.
    fn set_before_init(&mut self, vr: u32, x: f64) -> Result<(), String> {
        let name = name_of(&self.vars, vr).to_string();
        let mut settings = self.settings.clone();
        apply::<K>(&mut settings, &name, vr, x)?;
        let (mut sim, outputs) = self.build(&settings).map_err(|e| e.naming(&name, x))?;
        // Input rates set so far stay set (they are not parameters of the build).
        let du = K::input_rates(self.sim.model());
        if du.iter().any(|&r| r != [0.0; 3]) {
            K::set_input_rates(&mut sim, &du)?;
        }
        self.settings = settings;
        self.sim = sim;
        // New parameters: the outputs just checked are those of the new state.
        *self.outputs.get_mut() = outputs;
        self.outputs_fresh.set(true);
        Ok(())
    }

    /// Parameters and start inputs by value reference (the start inputs from the settings:
    /// they fixed the initial state; the current inputs are in the run-time state): what,
    /// besides the run-time state, distinguishes this instance from a freshly instantiated one.
    fn snapshot(&self) -> KernelSnapshot<K> {
        KernelSnapshot::<K> {
            params: self.params(),
            start_time: self.lifecycle.start_time,
            initialized: self.lifecycle.initialized,
            extra: K::extra(&self.settings),
            sim: K::sim_state(&self.sim),
        }
    }

    /// The parameter and start-input values by value reference, as a snapshot records them.
    fn params(&self) -> Vec<(u32, f64)> {
        self.params_cache
            .get(self.lifecycle.initialized, || self.current_params())
    }

    fn current_params(&self) -> Vec<(u32, f64)> {
        let start = K::start_inputs(&self.settings);
        settable_reals(&self.vars)
            .map(|v| {
                let vr = v.value_reference;
                let x = match input_position::<K>(vr) {
                    Some(k) => start[k],
                    None => self.get_real(vr).unwrap_or(f64::NAN),
                };
                (vr, x)
            })
            .collect()
    }

    /// The loaded settings with a snapshot's values applied, each with the checks of
    /// `fmi2SetReal`.
    fn settings_of(&self, snap: &KernelSnapshot<K>) -> Result<K::Settings, String> {
        let mut settings = self.base.clone();
        K::set_extra(&mut settings, &snap.extra);
        for &(vr, x) in &snap.params {
            apply::<K>(&mut settings, name_of(&self.vars, vr), vr, x)?;
        }
        Ok(settings)
    }

    /// Rebuilds the instance from a snapshot: the values go through the same checks as
    /// `fmi2SetReal`, then the run-time state is restored. On failure nothing changes. The
    /// values are applied to the loaded scene and the model is built once, not once per value
    /// as a sequence of sets would: a master that rolls back may restore at every step.
    fn restore(&mut self, snap: &KernelSnapshot<K>) -> Result<(), String> {
        let u = K::sim_inputs(&self.base, &snap.sim);
        let inputs: Vec<(u32, f64)> = (K::INPUTS.iter().zip(u))
            .filter(|(vr, _)| self.vars.iter().any(|v| v.value_reference == **vr))
            .map(|(&vr, x)| (vr, x))
            .collect();
        check_snapshot_values(&self.vars, &snap.params, &inputs, snap.start_time)?;
        if K::extra(&self.settings) == snap.extra
            && crate::fmu::checks::same_values(&snap.params, &self.params())
        {
            // This instance's own parameters (the rollback of an error-controlled master, at
            // every undone step): the simulation resumes from the state (`Driver::resume`,
            // bit-identical to a new build's) without building the model again.
            K::restore_sim(self.sim_mut(), &snap.sim)?;
            self.lifecycle = Lifecycle {
                start_time: snap.start_time,
                initialized: snap.initialized,
            };
            return Ok(());
        }
        // Other parameters from here on (or none, on failure: recomputed).
        self.params_cache.clear();
        let settings = self.settings_of(snap)?;
        let mut sim = match self.build(&settings) {
            Ok((sim, _)) => sim,
            Err(_) => return Err(self.first_refused(snap)),
        };
        K::restore_sim(&mut sim, &snap.sim)?;
        self.settings = settings;
        *self.sim_mut() = sim;
        self.lifecycle = Lifecycle {
            start_time: snap.start_time,
            initialized: snap.initialized,
        };
        Ok(())
    }

    /// The message of the first of a snapshot's values after which the model cannot be built,
    /// as `fmi2SetReal` of the values in turn would give it. One build per value: only for a
    /// snapshot that does not build.
    fn first_refused(&self, snap: &KernelSnapshot<K>) -> String {
        let mut settings = self.base.clone();
        K::set_extra(&mut settings, &snap.extra);
        for &(vr, x) in &snap.params {
            let name = name_of(&self.vars, vr);
            // Each value passed this apply in `settings_of` already.
            let _ = apply::<K>(&mut settings, name, vr, x);
            if let Err(e) = self.build(&settings) {
                return e.naming(name, x);
            }
        }
        "the state's parameters do not build a model".into()
    }

    /// The position in [`Kernel::INPUTS`] of an input that takes a derivative of `order`:
    /// orders 1 to [`Kernel::MAX_INPUT_DERIVATIVE_ORDER`] (the layer refuses others:
    /// [`Capabilities::max_input_derivative_order`]; checked here again, as a safety net) of
    /// the inputs of [`Kernel::rate_inputs`].
    fn rate_slot(&self, vr: u32, order: i32) -> Result<usize, String> {
        if !(1..=K::MAX_INPUT_DERIVATIVE_ORDER as i32).contains(&order) {
            return Err(format!(
                "'{}': input derivative of order {order} (this model takes orders 1 to {})",
                name_of(&self.vars, vr),
                K::MAX_INPUT_DERIVATIVE_ORDER
            ));
        }
        let takes = &self.rate_inputs;
        input_position::<K>(vr)
            .filter(|&k| takes[k])
            .ok_or_else(|| {
                let interpolated: Vec<String> = (0..takes.len())
                    .filter(|&k| takes[k])
                    .map(|k| format!("'{}'", name_of(&self.vars, K::INPUTS[k])))
                    .collect();
                format!(
                    "'{}' (vr {vr}) is held over a step and takes no input derivative (only {} do)",
                    name_of(&self.vars, vr),
                    interpolated.join(", ")
                )
            })
    }

    /// Index into the outputs of an output value reference.
    #[inline]
    fn output_index(&self, vr: u32) -> Option<usize> {
        vr.checked_sub(K::OUTPUT0)
            .map(|i| i as usize)
            .filter(|&i| i < self.n_outputs)
    }

    fn output_name(&self, k: usize) -> &str {
        name_of(&self.vars, K::OUTPUT0 + k as u32)
    }

    /// The simulation's outputs, evaluated once per state.
    fn current_outputs(&self) -> Ref<'_, [f64]> {
        if !self.outputs_fresh.get() {
            K::outputs(&self.sim, &mut self.outputs.borrow_mut());
            self.outputs_fresh.set(true);
        }
        Ref::map(self.outputs.borrow(), Vec::as_slice)
    }

    /// The simulation, for a change of its state or inputs: the cached outputs are marked
    /// stale first, so no read after the change can see the outputs of the state before it.
    fn sim_mut(&mut self) -> &mut Driver<K::Model> {
        self.outputs_fresh.set(false);
        &mut self.sim
    }
}

/// Sets a parameter of the settings: the adapter's own (the work budget) or the kernel's.
fn apply<K: Kernel>(settings: &mut K::Settings, name: &str, vr: u32, x: f64) -> Result<(), String> {
    if vr == VR_WORK_BUDGET {
        K::solver_mut(settings).work_budget = Some(budget::check_limit(name, x)?);
        return Ok(());
    }
    K::apply(settings, name, vr, x)
}

/// The position of an input value reference in `K::INPUTS`.
#[inline]
fn input_position<K: Kernel>(vr: u32) -> Option<usize> {
    K::INPUTS.iter().position(|&v| v == vr)
}

impl<K: Kernel> CoSimModel for Adapter<K> {
    fn variables(&self) -> &[Variable] {
        &self.vars
    }

    fn get_real(&self, vr: u32) -> Result<f64, String> {
        if let Some(i) = self.output_index(vr) {
            return Ok(self.current_outputs()[i]);
        }
        if vr == VR_WORK_BUDGET {
            return Ok(self.sim.work_limit().unwrap_or(DEFAULT_CALL_BUDGET));
        }
        if vr == VR_NEXT_SWITCH_TIME {
            // FMI values are finite: none is the largest double.
            return Ok(self.sim.next_switch().min(f64::MAX));
        }
        let model = self.sim.model();
        if let Some(k) = input_position::<K>(vr) {
            return Ok(K::inputs(model)[k]);
        }
        K::parameter(&self.settings, model, vr)
            .ok_or_else(|| format!("no Real variable with value reference {vr}"))
    }

    /// The outputs without a search per value reference: a host reads them after every step.
    fn get_reals(&self, vrs: &[u32], out: &mut [f64]) -> Result<(), String> {
        // After a change of the inputs, outputs the kernel evaluates on their own (a speed
        // port's torque, refreshed by the master) cost less than the whole vector.
        if !self.outputs_fresh.get()
            && vrs.iter().zip(out.iter_mut()).all(|(&vr, slot)| {
                let alone = self.output_index(vr).and_then(|i| K::output(&self.sim, i));
                alone.map(|v| *slot = v).is_some()
            })
        {
            return Ok(());
        }
        // Fetched once per call, not per value reference.
        let mut outputs = None;
        for (&vr, slot) in vrs.iter().zip(out.iter_mut()) {
            *slot = match self.output_index(vr) {
                Some(i) => outputs.get_or_insert_with(|| self.current_outputs())[i],
                None => self.get_real(vr)?,
            };
        }
        Ok(())
    }

    fn set_real(&mut self, vr: u32, value: f64) -> Result<(), String> {
        if !self.lifecycle.initialized {
            return self.set_before_init(vr, value);
        }
        let Some(k) = input_position::<K>(vr) else {
            // The layer's causality/variability check comes first; this is a safety net.
            return Err(format!(
                "'{}' is fixed after initialization",
                name_of(&self.vars, vr)
            ));
        };
        let mut u = K::inputs(self.sim.model());
        u[k] = value;
        K::set_inputs(self.sim_mut(), &u)
    }

    /// After initialization the inputs of one call are applied in one change of the model
    /// (one [`Kernel::set_inputs`]); the end state is that of setting them one by one.
    fn set_reals(&mut self, vrs: &[u32], values: &[f64]) -> Result<(), String> {
        if !self.lifecycle.initialized || vrs.len() < 2 {
            for (&vr, &x) in vrs.iter().zip(values) {
                self.set_real(vr, x)?;
            }
            return Ok(());
        }
        let mut u = K::inputs(self.sim.model());
        for (&vr, &x) in vrs.iter().zip(values) {
            let Some(k) = input_position::<K>(vr) else {
                return Err(format!(
                    "'{}' is fixed after initialization",
                    name_of(&self.vars, vr)
                ));
            };
            u[k] = x;
        }
        K::set_inputs(self.sim_mut(), &u)
    }

    /// The Integer outputs (the layer has checked the base type).
    fn get_integer(&self, vr: u32) -> Result<i32, String> {
        match self.output_index(vr) {
            Some(i) => Ok(self.current_outputs()[i] as i32),
            None => Err(format!("no Integer variable with value reference {vr}")),
        }
    }

    fn get_boolean(&self, vr: u32) -> Result<bool, String> {
        K::boolean(&self.settings, vr)
            .ok_or_else(|| format!("no Boolean variable with value reference {vr}"))
    }

    fn set_boolean(&mut self, vr: u32, value: bool) -> Result<(), String> {
        if self.lifecycle.initialized || K::boolean(&self.settings, vr).is_none() {
            return Err(format!(
                "no settable Boolean variable with value reference {vr}"
            ));
        }
        self.set_before_init(vr, f64::from(u8::from(value)))
    }

    fn lifecycle_mut(&mut self) -> &mut Lifecycle {
        &mut self.lifecycle
    }

    /// Integrates to exactly `t + h` in the host's time (the simulation runs in local time
    /// from the start time), never backwards, and never evaluates the model beyond that
    /// point. A failing integrator discards the step at the last good state it holds (the
    /// outputs then show that state) and ends the run.
    ///
    /// With input derivatives ([`CoSimModel::set_input_derivative`], orders 1–3) the model
    /// reads their Taylor polynomial `u + u'·s + u''·s²/2 + u'''·s³/6` during the step; one
    /// that leaves an input's bounds by the end of the step refuses the step, naming the
    /// input. At the end the inputs are where the model moved them ([`Kernel::inputs_after`]:
    /// the polynomial at `h`, a speed port's held angle the integral of its speed) and the
    /// derivatives 0 again.
    fn do_step(&mut self, t: f64, h: f64) -> Result<(), StepFailure> {
        // The budget bounds each call (docs/fmu.md "Work budget").
        self.sim.reset_work();
        let start_time = self.lifecycle.start_time;
        if K::inputs_held(self.sim.model()) {
            let t0 = self.sim.t();
            let sim = self.sim_mut();
            return advance_to_communication_point(sim, ((t + h) - start_time).max(t0))
                .map_err(|e| refused(&e, start_time + sim.t()));
        }
        let du = K::input_rates(self.sim.model());
        let u = K::inputs(self.sim.model());
        let t0 = self.sim.t();
        let target = ((t + h) - start_time).max(t0);
        let ramp = du.iter().any(|&r| r != [0.0; 3]);
        if ramp {
            let end = K::inputs_after(&self.sim, &u, &du, target - t0);
            for k in (0..du.len()).filter(|&k| du[k] != [0.0; 3]) {
                let var = self.vars.iter().find(|v| v.value_reference == K::INPUTS[k]);
                if let Some(Err(e)) = var.map(|v| v.check_value(end[k])) {
                    return Err(StepFailure::Error(format!(
                        "the input ramp leaves the bounds by the end of the step: {e} (rate {})",
                        du[k][0]
                    )));
                }
            }
        }
        let sim = self.sim_mut();
        if let Err(e) = advance_to_communication_point(sim, target) {
            let reached = sim.t();
            if ramp {
                // The inputs follow the state to where the integrator stopped.
                let end = K::inputs_after(sim, &u, &du, reached - t0);
                K::set_inputs(sim, &end).ok();
                K::set_input_rates(sim, &du).ok();
            }
            return Err(refused(&e, start_time + reached));
        }
        let fail = |e: String| StepFailure::Error(format!("end of the input ramp: {e}"));
        let end = K::inputs_after(sim, &u, &du, target - t0);
        if end != u {
            K::set_inputs(sim, &end).map_err(fail)?;
        }
        if ramp {
            K::set_input_rates(sim, &vec![[0.0; 3]; du.len()]).map_err(fail)?;
        }
        Ok(())
    }

    fn reset(&mut self) -> Result<(), String> {
        self.params_cache.clear();
        *self.sim_mut() = build_sim::<K>(&self.base)?;
        self.settings = self.base.clone();
        self.lifecycle = Lifecycle::default();
        Ok(())
    }

    fn save_state(&mut self) -> Vec<u8> {
        self.sim.forget_recurrences();
        K::encode(&self.snapshot())
    }

    fn load_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        self.restore(&K::decode(bytes)?)
    }

    fn capabilities(&self) -> Capabilities {
        Capabilities {
            can_interpolate_inputs: self.rate_inputs.contains(&true),
            max_output_derivative_order: u32::from(K::output_derivatives(&self.base)),
            // The drivetrain's cubic forcing (`GearTrain::set_torque_derivatives`, a speed
            // port's cubic neighbour), the pair none.
            max_input_derivative_order: K::MAX_INPUT_DERIVATIVE_ORDER,
            switch_time: Some(VR_NEXT_SWITCH_TIME),
        }
    }

    fn set_input_derivative(&mut self, vr: u32, order: u32, rate: f64) -> Result<(), String> {
        self.set_input_derivatives(&[vr], &[order as i32], &[rate])
    }

    /// The call's derivatives are applied in one change of the model (one
    /// [`Kernel::set_input_rates`], whose re-anchoring and dropped propagator caches a master
    /// would otherwise pay once per value: 12 values per step into a gear stage with two speed
    /// ports); on a refused value nothing changes.
    fn set_input_derivatives(
        &mut self,
        vrs: &[u32],
        orders: &[i32],
        values: &[f64],
    ) -> Result<(), String> {
        let mut du = K::input_rates(self.sim.model());
        for ((&vr, &order), &rate) in vrs.iter().zip(orders).zip(values) {
            let k = self.rate_slot(vr, order)?;
            du[k][order as usize - 1] = rate;
        }
        K::set_input_rates(self.sim_mut(), &du)
    }

    fn output_derivative(&self, vr: u32) -> Result<f64, String> {
        let k = self
            .output_index(vr)
            .ok_or_else(|| format!("'{}' (vr {vr}) is not an output", name_of(&self.vars, vr)))?;
        K::output_rate(&self.sim, k, &self.current_outputs())
    }

    /// The kernel answers the vector at once ([`Kernel::output_rates`]).
    fn output_derivatives(&self, vrs: &[u32], out: &mut [f64]) -> Result<(), String> {
        let ks = (vrs.iter())
            .map(|&vr| {
                self.output_index(vr).ok_or_else(|| {
                    format!("'{}' (vr {vr}) is not an output", name_of(&self.vars, vr))
                })
            })
            .collect::<Result<Vec<usize>, String>>()?;
        K::output_rates(&self.sim, &ks, &|| self.current_outputs(), out)
    }
}

/// The FMU's `documentation/index.html` body (FMI 2.0.x §2.3): the kernel's model part, then
/// the co-simulation behaviour, which is the adapter's (the packager adds the variable table).
/// `interpolates`: the kernel takes input derivatives ([`Kernel::rate_inputs`]).
fn documentation(model: &str, start: &str, interpolates: bool) -> String {
    let (held, unsupported) = if interpolates {
        (
            "the port inputs (torques, a speed port's angle and speed) follow their Taylor polynomial <code>u + u'·s + u''·s²/2 + u'''·s³/6</code> (s = t − tc) over the step after <code>fmi2SetRealInputDerivatives</code> (orders 1–3), then become its value at h with the derivatives 0; every other input is held constant over the step.",
            "directional derivatives and asynchronous stepping are not",
        )
    } else {
        (
            "the\ninputs are held constant over the step.",
            "directional derivatives, input\ninterpolation and asynchronous stepping are not",
        )
    };
    format!(
        r#"{model}<h2>Co-simulation behaviour</h2>
<ul>
<li><code>fmi2DoStep</code> integrates exactly to <code>tc + h</code> for any positive <code>h</code>; {held}</li>
<li>{start}</li>
<li>Parameters are fixed: they can be set before <code>fmi2ExitInitializationMode</code> only.</li>
<li>FMU state get/set and serialization are supported; {unsupported}.</li>
</ul>
"#
    )
}

#[cfg(test)]
mod tests {
    use crate::fmi::model::{Causality, CoSimModel, StepFailure, VarKind};

    /// A ramp of `input.torque` (spur_stage, vr 31) that would end above the input's `max`
    /// refuses the step naming the input and changes nothing; one that stays within steps,
    /// and ends at `u + u'h` with the rate back at 0. (The shipped ports have no bounds, so
    /// the bound is put on the variable here.)
    #[test]
    fn a_ramp_leaving_the_bounds_refuses_the_step() {
        use crate::fmu::drivetrain::Drivetrain;
        use crate::fmu::kernel::Kernel;
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/fmu/spur_stage/scene.toml");
        let text = std::fs::read_to_string(dir).unwrap();
        let settings = Drivetrain::load(&text, "spur_stage").unwrap();
        let (mut a, _) = super::Adapter::<Drivetrain>::new(settings, "g".into()).unwrap();
        let k = a.vars.iter().position(|v| v.value_reference == 31).unwrap();
        assert_eq!(a.vars[k].name, "input.torque");
        a.vars[k].max = Some(150.0);
        a.lifecycle_mut().initialized = true;
        a.set_input_derivative(31, 1, 2e5).unwrap();
        match a.do_step(0.0, 5e-4) {
            Err(StepFailure::Error(e)) => assert!(e.contains("'input.torque'"), "{e}"),
            other => panic!("{other:?}"),
        }
        assert_eq!(a.sim.t(), 0.0);
        a.set_input_derivative(31, 1, 1e5).unwrap();
        a.do_step(0.0, 5e-4).unwrap();
        assert_eq!(a.get_real(31).unwrap(), 100.0 + 1e5 * 5e-4);
        assert!(Drivetrain::input_rates(a.sim.model())
            .iter()
            .all(|&r| r == [0.0; 3]));
        // operating.input_speed is a parameter with ports: no rate.
        assert!(a.set_input_derivative(30, 1, 1.0).is_err());
    }

    /// For every shipped scene (both kernels): a batched read of the outputs, the one the
    /// FMI layer makes after every step, and a batch mixing parameters, inputs and outputs
    /// give what reading them one by one gives, bit for bit; the Integer outputs (contact
    /// states, tooth pairs in contact) read as small integers.
    #[test]
    fn batched_reads_agree_with_single_reads() {
        let scenes = std::fs::read_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/fmu")).unwrap();
        let mut kernels = (0, 0);
        for dir in scenes {
            let scene = dir.unwrap().path().join(crate::fmu::entry::SCENE_FILE);
            let Ok(loaded) = crate::fmu::entry::load_scene(&scene) else {
                continue;
            };
            let model = loaded.model;
            let reals = |pick: &dyn Fn(Causality) -> bool| -> Vec<u32> {
                let vars = model.variables();
                vars.iter()
                    .filter(|v| v.kind == VarKind::Real && pick(v.causality))
                    .map(|v| v.value_reference)
                    .collect()
            };
            let outputs = reals(&|c| c == Causality::Output);
            let mut mixed = reals(&|_| true);
            mixed.reverse();
            for vrs in [outputs, mixed] {
                let mut batch = vec![0.0; vrs.len()];
                model.get_reals(&vrs, &mut batch).unwrap();
                for (&vr, x) in vrs.iter().zip(batch) {
                    assert_eq!(model.get_real(vr).map(f64::to_bits), Ok(x.to_bits()));
                }
            }
            for v in model.variables() {
                if v.kind == VarKind::Integer {
                    let n = model.get_integer(v.value_reference).unwrap();
                    assert!((-1..=64).contains(&n), "{}: {n}", v.name);
                }
            }
            if crate::scene::is_train_text(&std::fs::read_to_string(&scene).unwrap()) {
                kernels.1 += 1;
            } else {
                kernels.0 += 1;
            }
        }
        assert!(kernels.0 > 0 && kernels.1 > 0, "{kernels:?}");
    }
}
