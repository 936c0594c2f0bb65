//! One FMU instance: the safe-Rust semantics of every instance-bound FMI call.
//!
//! [`super::abi`] only validates raw pointers, catches panics and dispatches here. Every
//! method checks the state machine first ([`Call::allowed_in`]); every failure is logged
//! with the call name and the state or variable and value, and an `fmi2Error` moves the
//! instance into the `error` state (FMI 2.0.x §2.1.3: "the simulation cannot be continued").

use std::fmt::Display;

use super::blob::{self, LayerSnapshot};
use super::logger::{Category, Logger, Status};
use super::model::{
    Capabilities, Causality, CoSimModel, ModelInfo, StepFailure, VarKind, Variability, Variable,
};
use super::state::{check_settable, Call, FmuState};
use super::vr_index::VrIndex;

/// Marks a live instance so that a stale or foreign `fmi2Component` is caught (best effort).
pub const INSTANCE_MAGIC: u64 = 0x6765_6172_6479_6e49; // "gearydnI"
/// Marks a live `fmi2FMUstate` allocated by us.
pub const STATE_MAGIC: u64 = 0x6765_6172_6479_6e53;

/// `fmi2StatusKind` values (FMI 2.0.x §4.2.3).
pub const DO_STEP_STATUS: i32 = 0;
pub const PENDING_STATUS: i32 = 1;
pub const LAST_SUCCESSFUL_TIME: i32 = 2;
pub const TERMINATED: i32 = 3;

/// The object behind an `fmi2FMUstate`: an envelope from [`blob::encode_unsealed`].
pub struct StateBox {
    pub magic: u64,
    pub bytes: Vec<u8>,
    /// Whether `bytes` carry their checksum ([`blob::seal`]): written when the state is
    /// serialized, not when it is taken.
    pub sealed: bool,
}

/// Why [`Instance::lookup`] failed: `found` is the variable with that value reference, if any.
#[cold]
fn lookup_error(vr: u32, kind: VarKind, found: Option<&Variable>) -> String {
    match found {
        None => format!("unknown value reference {vr}"),
        Some(var) => format!(
            "value reference {vr} ('{}') is a {} variable, not {}",
            var.name,
            var.kind.as_str(),
            kind.as_str()
        ),
    }
}

pub struct Instance {
    pub magic: u64,
    pub logger: Logger,
    model: Box<dyn CoSimModel>,
    info: ModelInfo,
    /// Value reference → position in `model.variables()` (a host reads every output after
    /// every step).
    index: VrIndex,
    /// The base type of each variable, by position: the type check of a get needs no call
    /// into the model's table.
    kinds: Vec<VarKind>,
    /// Per base type ([`VarKind`] as index), the value references of the last get that
    /// passed the type check. A host asks for the same ones after every step, and the
    /// variable table never changes ([`CoSimModel::variables`]), so a repeated request
    /// needs no check per reference.
    checked_gets: [Vec<u32>; 3],
    /// The value references of the Real outputs, read and checked for finiteness after every
    /// step.
    real_outputs: Vec<u32>,
    /// The last finite values of `real_outputs` (after initialization or a step) and their
    /// time: what `fmi2GetReal` answers for the outputs after a failed step whose outputs are
    /// not finite (issue 17: after `fmi2Discard` or `fmi2Error` the outputs are the last good
    /// values, never NaN).
    last_good_outputs: Vec<f64>,
    last_good_time: f64,
    /// The outputs just read after a step (a buffer; swapped into `last_good_outputs`).
    step_outputs: Vec<f64>,
    /// Whether the model's outputs are not finite after a failed step, so `fmi2GetReal`
    /// answers the outputs from `last_good_outputs`.
    hold_outputs: bool,
    /// The model's input-interpolation and output-derivative capabilities (fixed).
    caps: Capabilities,
    pub state: FmuState,
    time: f64,
    start_time: f64,
    stop_time: Option<f64>,
    last_successful_time: f64,
    terminated: bool,
    setup_done: bool,
}

impl Instance {
    pub fn new(logger: Logger, model: Box<dyn CoSimModel>, info: ModelInfo) -> Instance {
        let index = VrIndex::new(model.variables().iter().map(|v| v.value_reference));
        let kinds = model.variables().iter().map(|v| v.kind).collect();
        let real_outputs = model
            .variables()
            .iter()
            .filter(|v| v.kind == VarKind::Real && v.causality == super::model::Causality::Output)
            .map(|v| v.value_reference)
            .collect::<Vec<u32>>();
        let outputs = real_outputs.len();
        let caps = model.capabilities();
        Instance {
            magic: INSTANCE_MAGIC,
            logger,
            model,
            info,
            index,
            kinds,
            checked_gets: Default::default(),
            real_outputs,
            last_good_outputs: vec![0.0; outputs],
            last_good_time: 0.0,
            step_outputs: vec![0.0; outputs],
            hold_outputs: false,
            caps,
            state: FmuState::Instantiated,
            time: 0.0,
            start_time: 0.0,
            stop_time: None,
            last_successful_time: 0.0,
            terminated: false,
            setup_done: false,
        }
    }

    pub fn guid(&self) -> &str {
        &self.info.guid
    }

    /// Logs an error for `call`, enters the `error` state (unless already fatal).
    pub fn error(&mut self, call: Call, msg: impl Display) -> Status {
        self.logger
            .log(Status::Error, &format!("{}: {msg}", call.name()));
        if self.state != FmuState::Fatal {
            self.state = FmuState::Error;
        }
        Status::Error
    }

    /// Logs a caught panic and enters the `fatal` state.
    pub fn fatal(&mut self, call: Call, msg: &str) -> Status {
        self.state = FmuState::Fatal;
        self.logger.log(
            Status::Fatal,
            &format!("{}: internal error (panic): {msg}", call.name()),
        );
        Status::Fatal
    }

    /// Call trace in category `logAll`.
    pub fn trace(&self, call: Call, args: impl FnOnce() -> String) {
        if self.logger.is_enabled(Category::All) {
            self.logger.log_in(
                Category::All,
                Status::Ok,
                &format!("{}({})", call.name(), args()),
            );
        }
    }

    fn event(&self, msg: impl FnOnce() -> String) {
        if self.logger.is_enabled(Category::Events) {
            self.logger.log_in(Category::Events, Status::Ok, &msg());
        }
    }

    /// State-machine check shared by every call (inlined: a mask test on the path of every
    /// call; the refusal is out of line).
    #[inline]
    pub fn check(&mut self, call: Call) -> Result<(), Status> {
        if call.allowed_in(self.state) {
            Ok(())
        } else {
            Err(self.refuse(call))
        }
    }

    #[cold]
    fn refuse(&mut self, call: Call) -> Status {
        let state = self.state.name();
        self.error(call, format!("not allowed in state {state}"))
    }

    pub fn set_debug_logging(&mut self, on: bool, categories: &[String]) -> Status {
        if let Err(s) = self.check(Call::SetDebugLogging) {
            return s;
        }
        let unknown = self.logger.set_categories(on, categories);
        if unknown.is_empty() {
            Status::Ok
        } else {
            // Not an error: the simulation can go on, only logging is affected.
            self.logger.log(
                Status::Warning,
                &format!(
                    "fmi2SetDebugLogging: unknown log categories {unknown:?} ignored (known: {})",
                    super::logger::Category::ALL.map(|c| c.name()).join(", ")
                ),
            );
            Status::Warning
        }
    }

    pub fn setup_experiment(
        &mut self,
        tolerance: Option<f64>,
        start: f64,
        stop: Option<f64>,
    ) -> Status {
        let call = Call::SetupExperiment;
        if let Err(s) = self.check(call) {
            return s;
        }
        if !start.is_finite() {
            return self.error(call, format!("startTime = {start} is not finite"));
        }
        if let Some(t) = stop {
            if !t.is_finite() || t < start {
                return self.error(
                    call,
                    format!("stopTime = {t} must be finite and >= startTime = {start}"),
                );
            }
        }
        if let Some(tol) = tolerance {
            if !(tol.is_finite() && tol > 0.0) {
                return self.error(call, format!("tolerance = {tol} must be finite and > 0"));
            }
        }
        if let Err(e) = self.model.setup_experiment(start, stop, tolerance) {
            return self.error(call, e);
        }
        self.start_time = start;
        self.time = start;
        self.last_successful_time = start;
        self.stop_time = stop;
        self.setup_done = true;
        Status::Ok
    }

    pub fn enter_initialization_mode(&mut self) -> Status {
        let call = Call::EnterInitializationMode;
        if let Err(s) = self.check(call) {
            return s;
        }
        if !self.setup_done {
            // The spec requires fmi2SetupExperiment first, but defaults are well defined
            // (startTime 0, no stopTime), so be lenient and say so.
            self.event(|| {
                "fmi2EnterInitializationMode: fmi2SetupExperiment was not called; using startTime = 0, no stopTime".into()
            });
            if let Err(e) = self.model.setup_experiment(0.0, None, None) {
                return self.error(call, e);
            }
            self.setup_done = true;
        }
        self.state = FmuState::InitializationMode;
        Status::Ok
    }

    pub fn exit_initialization_mode(&mut self) -> Status {
        let call = Call::ExitInitializationMode;
        if let Err(s) = self.check(call) {
            return s;
        }
        if let Err(e) = self.model.exit_initialization() {
            return self.error(call, e);
        }
        if let Some(msg) = self.read_outputs() {
            return self.error(call, format!("the initial outputs are not usable: {msg}"));
        }
        self.state = FmuState::StepComplete;
        self.event(|| format!("initialized at t = {:e} s", self.time));
        Status::Ok
    }

    pub fn terminate(&mut self) -> Status {
        if let Err(s) = self.check(Call::Terminate) {
            return s;
        }
        self.state = FmuState::Terminated;
        self.event(|| format!("terminated at t = {:e} s", self.time));
        Status::Ok
    }

    pub fn reset(&mut self) -> Status {
        let call = Call::Reset;
        if let Err(s) = self.check(call) {
            return s;
        }
        if let Err(e) = self.model.reset() {
            return self.error(call, e);
        }
        self.state = FmuState::Instantiated;
        self.time = 0.0;
        self.start_time = 0.0;
        self.stop_time = None;
        self.last_successful_time = 0.0;
        self.terminated = false;
        self.setup_done = false;
        self.hold_outputs = false;
        Status::Ok
    }

    /// Finds `vr` and checks its base type (inlined: on the path of every get and set).
    #[inline]
    fn lookup(&self, vr: u32, kind: VarKind) -> Result<&Variable, String> {
        match self.index.position(vr).map(|k| &self.model.variables()[k]) {
            Some(var) if var.kind == kind => Ok(var),
            found => Err(lookup_error(vr, kind, found)),
        }
    }

    /// Checks that `vr` names a variable of base type `kind` (the lookup of the getters, on
    /// the hot path of a host: a table load and a compare per value reference).
    #[inline(always)]
    fn check_kind(&self, vr: u32, kind: VarKind) -> Result<(), String> {
        match self.index.position(vr) {
            Some(k) if self.kinds[k] == kind => Ok(()),
            found => Err(lookup_error(
                vr,
                kind,
                found.map(|k| &self.model.variables()[k]),
            )),
        }
    }

    /// The checks of every getter: the state, then that each of `vrs` names a variable of
    /// base type `kind` (skipped when `vrs` is the last request of that type that passed).
    fn check_get(&mut self, call: Call, kind: VarKind, vrs: &[u32]) -> Result<(), Status> {
        self.check(call)?;
        let checked = &self.checked_gets[kind as usize];
        if vrs != checked.as_slice() {
            if let Some(e) = vrs.iter().find_map(|&vr| self.check_kind(vr, kind).err()) {
                return Err(self.error(call, e));
            }
            let checked = &mut self.checked_gets[kind as usize];
            checked.clear();
            checked.extend_from_slice(vrs);
        }
        Ok(())
    }

    /// Shared body of the Integer and Boolean getters: the checks, then the model's answer
    /// per value reference; the first failure is the call's error.
    fn get_values<T>(
        &mut self,
        call: Call,
        kind: VarKind,
        vrs: &[u32],
        out: &mut [T],
        get: impl Fn(&dyn CoSimModel, u32) -> Result<T, String>,
    ) -> Status {
        if let Err(s) = self.check_get(call, kind, vrs) {
            return s;
        }
        for (vr, slot) in vrs.iter().zip(out.iter_mut()) {
            match get(self.model.as_ref(), *vr) {
                Ok(x) => *slot = x,
                Err(e) => return self.error(call, e),
            }
        }
        Status::Ok
    }

    /// Like [`Self::get_values`], but the model answers the whole vector in one call: a host
    /// reads every output after every step.
    #[inline]
    pub fn get_real(&mut self, vrs: &[u32], out: &mut [f64]) -> Status {
        let call = Call::GetReal;
        if let Err(s) = self.check_get(call, VarKind::Real, vrs) {
            return s;
        }
        if let Err(e) = self.model.get_reals(vrs, out) {
            return self.error(call, e);
        }
        if self.hold_outputs {
            self.answer_held_outputs(vrs, out);
        }
        // Never a non-finite value with fmi2OK (issue 34): a model whose values are not finite
        // (an element's start state the arithmetic cannot carry) answers fmi2Discard, naming
        // the variable; the instance's state is unchanged. `0·x` is ±0 for a finite `x` and
        // NaN otherwise: one multiply-add per value, no branch per value.
        let values = &out[..vrs.len().min(out.len())];
        if values.iter().fold(0.0, |sum, x| sum + 0.0 * x) != 0.0 {
            return self.refuse_non_finite(vrs, values);
        }
        Status::Ok
    }

    /// fmi2Discard for the first value of `values` that is not finite, naming its variable
    /// (the failure path of [`Self::get_real`]).
    #[cold]
    #[inline(never)]
    fn refuse_non_finite(&mut self, vrs: &[u32], values: &[f64]) -> Status {
        let Some(k) = values.iter().position(|x| !x.is_finite()) else {
            return Status::Ok;
        };
        let name = self
            .lookup(vrs[k], VarKind::Real)
            .map_or_else(|_| format!("vr {}", vrs[k]), |v| format!("'{}'", v.name));
        self.logger.log(
            Status::Discard,
            &format!(
                "fmi2GetReal: {name} (vr {}) is {} at t = {:?}: not a usable value",
                vrs[k], values[k], self.time
            ),
        );
        Status::Discard
    }

    /// Replaces the outputs among `vrs` by their last good values (the failure path only).
    #[cold]
    fn answer_held_outputs(&self, vrs: &[u32], out: &mut [f64]) {
        for (vr, slot) in vrs.iter().zip(out.iter_mut()) {
            if let Some(k) = self.real_outputs.iter().position(|o| o == vr) {
                *slot = self.last_good_outputs[k];
            }
        }
    }

    pub fn get_integer(&mut self, vrs: &[u32], out: &mut [i32]) -> Status {
        self.get_values(Call::GetInteger, VarKind::Integer, vrs, out, |m, vr| {
            m.get_integer(vr)
        })
    }

    pub fn get_boolean(&mut self, vrs: &[u32], out: &mut [i32]) -> Status {
        self.get_values(Call::GetBoolean, VarKind::Boolean, vrs, out, |m, vr| {
            m.get_boolean(vr).map(i32::from)
        })
    }

    /// The model has no String variables: any value reference is an error.
    pub fn no_strings(&mut self, call: Call, vrs: &[u32]) -> Status {
        if let Err(s) = self.check(call) {
            return s;
        }
        match vrs.first() {
            None => Status::Ok,
            Some(vr) => {
                let msg = match self.lookup(*vr, VarKind::Real) {
                    Err(e) if e.starts_with("unknown") => e,
                    _ => format!("value reference {vr} is not a String variable"),
                };
                self.error(call, msg)
            }
        }
    }

    /// Layer-side checks for one set: existence, base type, causality/variability/initial
    /// against the current state, finiteness and bounds ([`Variable::check_value`]).
    fn check_set(&self, vr: u32, kind: VarKind, value: f64) -> Result<(), String> {
        let var = self.lookup(vr, kind)?;
        check_settable(var, self.state)?;
        var.check_value(value)
    }

    /// Shared body of the setters. Everything is validated first so that a rejected call
    /// changes nothing at layer level; then the model applies the values in order.
    fn set_values<T: Copy>(
        &mut self,
        call: Call,
        kind: VarKind,
        vrs: &[u32],
        values: &[T],
        as_f64: impl Fn(T) -> f64,
        set: impl Fn(&mut dyn CoSimModel, u32, T) -> Result<(), String>,
    ) -> Status {
        if let Err(s) = self.check_values(call, kind, vrs, values, as_f64) {
            return s;
        }
        for (vr, x) in vrs.iter().zip(values) {
            if let Err(e) = set(self.model.as_mut(), *vr, *x) {
                return self.error(call, e);
            }
        }
        Status::Ok
    }

    /// The setters' checks: the call's state, then every value before any is applied.
    fn check_values<T: Copy>(
        &mut self,
        call: Call,
        kind: VarKind,
        vrs: &[u32],
        values: &[T],
        as_f64: impl Fn(T) -> f64,
    ) -> Result<(), Status> {
        self.check(call)?;
        for (vr, x) in vrs.iter().zip(values) {
            if let Err(e) = self.check_set(*vr, kind, as_f64(*x)) {
                return Err(self.error(call, e));
            }
        }
        Ok(())
    }

    /// Like [`Self::set_values`], but the model applies the whole vector in one call
    /// ([`CoSimModel::set_reals`]): a host sets the inputs before every step.
    pub fn set_real(&mut self, vrs: &[u32], values: &[f64]) -> Status {
        let call = Call::SetReal;
        if let Err(s) = self.check_values(call, VarKind::Real, vrs, values, |x| x) {
            return s;
        }
        let n = vrs.len().min(values.len());
        match self.model.set_reals(&vrs[..n], &values[..n]) {
            Ok(()) => Status::Ok,
            Err(e) => self.error(call, e),
        }
    }

    pub fn set_integer(&mut self, vrs: &[u32], values: &[i32]) -> Status {
        self.set_values(
            Call::SetInteger,
            VarKind::Integer,
            vrs,
            values,
            f64::from,
            |m, vr, x| m.set_integer(vr, x),
        )
    }

    /// C code often passes any non-zero int as true.
    pub fn set_boolean(&mut self, vrs: &[u32], values: &[i32]) -> Status {
        self.set_values(
            Call::SetBoolean,
            VarKind::Boolean,
            vrs,
            values,
            |x| f64::from(i32::from(x != 0)),
            |m, vr, x| m.set_boolean(vr, x != 0),
        )
    }

    /// `fmi2DoStep` (FMI 2.0.x §4.2.2).
    pub fn do_step(&mut self, tc: f64, h: f64) -> Status {
        let call = Call::DoStep;
        if let Err(s) = self.check(call) {
            return s;
        }
        self.trace(call, || format!("tc={tc:?}, h={h:?}"));
        if !tc.is_finite() || !h.is_finite() || h <= 0.0 {
            return self.error(
                call,
                format!("currentCommunicationPoint = {tc} and communicationStepSize = {h} must be finite with h > 0"),
            );
        }
        // The master's tc is authoritative (spec recommends it against drift); a mismatch
        // beyond rounding means the master lost track of time, e.g. a rollback without
        // fmi2SetFMUstate.
        let tol = 1e-9 * self.time.abs().max(1.0);
        if (tc - self.time).abs() > tol {
            let t = self.time;
            return self.error(
                call,
                format!("currentCommunicationPoint = {tc:?} does not match the FMU time {t:?}"),
            );
        }
        let target = tc + h;
        let resolution = MIN_STEP_IN_ULPS * ulp(tc);
        if !(h >= resolution) {
            return self.error(
                call,
                format!(
                    "communicationStepSize = {h:e} is below the time resolution at \
                     currentCommunicationPoint = {tc:?}: a step must be at least 2^20 ulps of \
                     tc ({resolution:e} s), or rounding tc + h changes it by more than 1e-6"
                ),
            );
        }
        if let Some(stop) = self.stop_time {
            let eps = 1e-12 * stop.abs().max(1.0);
            if target > stop + eps {
                return self.error(
                    call,
                    format!("step to tc + h = {target:?} would pass stopTime = {stop:?}"),
                );
            }
        }
        self.time = target;
        match self.model.do_step(tc, h) {
            Ok(()) => {
                // Safety net independent of the model: a non-finite output must never be
                // reported as a good step.
                if let Some(msg) = self.read_outputs() {
                    self.time = tc;
                    self.last_successful_time = tc;
                    // A failure, not the model ending the run (see `StepFailure::Discard`).
                    self.terminated = false;
                    self.state = FmuState::StepFailed;
                    self.logger.log(
                        Status::Discard,
                        &format!("fmi2DoStep: step from t = {tc:?} by h = {h:?} discarded: {msg}"),
                    );
                    return Status::Discard;
                }
                self.last_successful_time = target;
                Status::Ok
            }
            Err(StepFailure::Discard {
                reason,
                reached,
                terminate,
            }) => {
                let reached = if reached.is_finite() {
                    reached.clamp(tc, target)
                } else {
                    tc
                };
                self.time = reached;
                // The model's state at `reached` is valid; if its outputs are not, the last
                // good ones (at tc) are the answer, and tc the last successful time.
                let reached = match self.read_outputs() {
                    None => reached,
                    Some(_) => self.last_good_time,
                };
                self.time = reached;
                self.last_successful_time = reached;
                self.terminated = terminate;
                self.state = FmuState::StepFailed;
                self.logger.log(
                    Status::Discard,
                    &format!(
                        "fmi2DoStep: step from t = {tc:?} by h = {h:?} discarded at t = {reached:?}: {reason}"
                    ),
                );
                Status::Discard
            }
            Err(StepFailure::Error(e)) => {
                // The state is unusable: the outputs stay those of tc.
                self.time = tc;
                self.hold_outputs = true;
                self.error(
                    call,
                    format!("step from t = {tc:?} by h = {h:?} failed: {e}"),
                )
            }
        }
    }

    /// Reads the Real outputs of the model's current state (at `self.time`): if all are
    /// finite they become the last good values and `None` is returned; otherwise the first
    /// that is not, as a reason, and from then on `fmi2GetReal` answers the outputs from the
    /// last good values. One vector read per step (the model evaluates its outputs once
    /// per state and a host reads them all after every step anyway).
    fn read_outputs(&mut self) -> Option<String> {
        if let Err(e) = self
            .model
            .get_reals(&self.real_outputs, &mut self.step_outputs)
        {
            self.hold_outputs = true;
            return Some(e);
        }
        match self.step_outputs.iter().position(|x| !x.is_finite()) {
            None => {
                std::mem::swap(&mut self.last_good_outputs, &mut self.step_outputs);
                self.last_good_time = self.time;
                self.hold_outputs = false;
                None
            }
            Some(k) => {
                self.hold_outputs = true;
                let vr = self.real_outputs[k];
                let name = self.lookup(vr, VarKind::Real).map_or("?", |v| &v.name);
                Some(format!(
                    "output '{name}' (vr {vr}) = {} is not finite",
                    self.step_outputs[k]
                ))
            }
        }
    }

    /// `fmi2SetRealInputDerivatives` (FMI 2.0.x §4.2.1): derivatives of continuous Real inputs
    /// (orders 1 to the model's [`Capabilities::max_input_derivative_order`]), used by the
    /// model during the next `fmi2DoStep`
    /// ([`CoSimModel::set_input_derivative`]). Everything is checked before the model sees a
    /// value, so a refused call changes nothing.
    pub fn set_real_input_derivatives(
        &mut self,
        vrs: &[u32],
        orders: &[i32],
        values: &[f64],
    ) -> Status {
        let call = Call::SetRealInputDerivatives;
        if let Err(s) = self.check(call) {
            return s;
        }
        if !self.caps.can_interpolate_inputs {
            return self.error(
                call,
                "not supported: inputs are held constant over a step (canInterpolateInputs=\"false\")",
            );
        }
        let max = self.caps.max_input_derivative_order.max(1);
        for ((&vr, &order), &x) in vrs.iter().zip(orders).zip(values) {
            let checked = self.lookup(vr, VarKind::Real).and_then(|var| {
                // Formatted only on a refusal: this call comes with every step.
                let who = || format!("'{}' (vr {vr})", var.name);
                if var.causality != Causality::Input || var.variability != Variability::Continuous {
                    Err(format!("{} is not a continuous Real input", who()))
                } else if order < 1 || order as u32 > max {
                    Err(format!(
                        "{}: derivative order {order} is not supported (orders 1 to {max}: the input follows its Taylor polynomial over the step)", who()
                    ))
                } else if !x.is_finite() {
                    Err(format!("{}: derivative {x} is not finite", who()))
                } else {
                    Ok(())
                }
            });
            if let Err(e) = checked {
                return self.error(call, e);
            }
        }
        match self.model.set_input_derivatives(vrs, orders, values) {
            Ok(()) => Status::Ok,
            Err(e) => self.error(call, e),
        }
    }

    /// `fmi2GetRealOutputDerivatives` (FMI 2.0.x §4.2.1): first-order time derivatives of
    /// Real outputs at the current time ([`CoSimModel::output_derivative`]).
    pub fn get_real_output_derivatives(
        &mut self,
        vrs: &[u32],
        orders: &[i32],
        out: &mut [f64],
    ) -> Status {
        let call = Call::GetRealOutputDerivatives;
        if let Err(s) = self.check(call) {
            return s;
        }
        let max = self.caps.max_output_derivative_order;
        if max == 0 {
            return self.error(call, "not supported: maxOutputDerivativeOrder=\"0\"");
        }
        let n = vrs.len().min(orders.len()).min(out.len());
        for (&vr, &order) in vrs[..n].iter().zip(orders) {
            let checked = self.lookup(vr, VarKind::Real).and_then(|var| {
                // Formatted only on a refusal: this call comes with every step.
                let who = || format!("'{}' (vr {vr})", var.name);
                if var.causality != Causality::Output {
                    Err(format!("{} is not an output", who()))
                } else if order != 1 {
                    Err(format!(
                        "{}: derivative order {order} is not supported (maxOutputDerivativeOrder=\"{max}\")", who()
                    ))
                } else {
                    Ok(())
                }
            });
            if let Err(e) = checked {
                return self.error(call, e);
            }
        }
        match self.model.output_derivatives(&vrs[..n], &mut out[..n]) {
            Ok(()) => Status::Ok,
            Err(e) => self.error(call, e),
        }
    }

    /// Refusal of an unsupported capability, after the state check.
    pub fn unsupported(&mut self, call: Call, why: &str) -> Status {
        if let Err(s) = self.check(call) {
            return s;
        }
        self.error(call, format!("not supported: {why}"))
    }

    pub fn cancel_step(&mut self) -> Status {
        let state = self.state.name();
        self.error(
            Call::CancelStep,
            format!("not allowed in state {state}: the FMU never runs asynchronously (canRunAsynchronuously=false), so there is no step to cancel"),
        )
    }

    /// `fmi2GetXXXStatus`: answers `fmi2LastSuccessfulTime` (Real) and `fmi2Terminated`
    /// (Boolean); other kinds return `fmi2Discard` ("status not available", §4.2.3).
    pub fn status_query(&mut self, call: Call, kind: i32) -> Result<StatusAnswer, Status> {
        self.check(call)?;
        match (call, kind) {
            (Call::GetRealStatus, LAST_SUCCESSFUL_TIME) => {
                Ok(StatusAnswer::Real(self.last_successful_time))
            }
            (Call::GetBooleanStatus, TERMINATED) => Ok(StatusAnswer::Boolean(self.terminated)),
            _ => {
                let what = match kind {
                    DO_STEP_STATUS | PENDING_STATUS => {
                        "asynchronous step status is not supported (canRunAsynchronuously=false)"
                    }
                    LAST_SUCCESSFUL_TIME | TERMINATED => "this status kind has another type",
                    _ => "unknown status kind",
                };
                self.logger.log(
                    Status::Discard,
                    &format!("{}: status kind {kind}: {what}", call.name()),
                );
                Err(Status::Discard)
            }
        }
    }

    fn layer_snapshot(&self) -> LayerSnapshot {
        LayerSnapshot {
            state: self.state,
            time: self.time,
            start_time: self.start_time,
            stop_time: self.stop_time,
            last_successful_time: self.last_successful_time,
            terminated: self.terminated,
            setup_done: self.setup_done,
        }
    }

    /// `fmi2GetFMUstate`: the complete state as an envelope into `out` (its buffer reused),
    /// unsealed ([`blob::encode_unsealed`]).
    pub fn snapshot(&mut self, out: &mut Vec<u8>) -> Result<(), Status> {
        self.check(Call::GetFMUstate)?;
        let model = self.model.save_state();
        blob::encode_unsealed(out, &self.info.guid, &self.layer_snapshot(), &model);
        Ok(())
    }

    /// `fmi2SetFMUstate`: checks the envelope of a state object (all but its checksum:
    /// [`blob::open`]), then restores model and layer state ("transitions to the given
    /// state", §4.2.4).
    pub fn restore(&mut self, bytes: &[u8]) -> Status {
        let call = Call::SetFMUstate;
        if let Err(s) = self.check(call) {
            return s;
        }
        let (layer, payload) = match blob::open(bytes, &self.info.guid) {
            Ok(x) => x,
            Err(e) => return self.error(call, e),
        };
        if let Err(e) = self.model.load_state(payload) {
            return self.error(call, format!("model rejected the state: {e}"));
        }
        self.state = layer.state;
        self.time = layer.time;
        self.start_time = layer.start_time;
        self.stop_time = layer.stop_time;
        self.last_successful_time = layer.last_successful_time;
        self.terminated = layer.terminated;
        self.setup_done = layer.setup_done;
        // The restored state's outputs are the good ones from now on (a state is only taken
        // in states whose outputs are finite, and a restored one was validated).
        self.hold_outputs = false;
        if matches!(
            self.state,
            FmuState::StepComplete | FmuState::StepFailed | FmuState::Terminated
        ) {
            let _ = self.read_outputs();
        }
        self.event(|| {
            format!(
                "FMU state restored: state {}, t = {:e} s",
                self.state.name(),
                self.time
            )
        });
        Status::Ok
    }

    /// `fmi2DeSerializeFMUstate`: validate before handing out a state object, so a corrupt
    /// or foreign blob fails here with a reason rather than later.
    pub fn check_blob(&mut self, bytes: &[u8]) -> Status {
        let call = Call::DeSerializeFMUstate;
        if let Err(s) = self.check(call) {
            return s;
        }
        match blob::decode(bytes, &self.info.guid) {
            Ok(_) => Status::Ok,
            Err(e) => self.error(call, e),
        }
    }
}

/// A step must be at least this many ulps of its communication point: then rounding
/// `tc + h` changes the step by at most 2^-21 of itself (issue 17: a step that has lost its
/// floating-point resolution is refused, not taken as a step of another length or none).
const MIN_STEP_IN_ULPS: f64 = 1_048_576.0;

/// The spacing of the `f64` values at `x` (`ulp(0)` is the smallest denormal).
fn ulp(x: f64) -> f64 {
    let a = x.abs();
    f64::from_bits(a.to_bits() + 1) - a
}

/// Answer of a status query.
pub enum StatusAnswer {
    Real(f64),
    Boolean(bool),
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fmi::logger::CallbackFunctions;
    use crate::fmi::model::{Causality, DefaultExperiment, Initial, Lifecycle, Variability};
    use std::ffi::CString;

    /// One Real output `y` and one Integer output `n`: `y` becomes `y_after_step` with the
    /// first step (the model itself reports success).
    struct Outputs {
        vars: Vec<Variable>,
        y: f64,
        y_after_step: f64,
        lifecycle: Lifecycle,
    }

    impl CoSimModel for Outputs {
        fn variables(&self) -> &[Variable] {
            &self.vars
        }
        fn get_real(&self, vr: u32) -> Result<f64, String> {
            match vr {
                1 => Ok(self.y),
                _ => Err(format!("no Real {vr}")),
            }
        }
        fn set_real(&mut self, vr: u32, _: f64) -> Result<(), String> {
            Err(format!("no settable {vr}"))
        }
        fn get_integer(&self, vr: u32) -> Result<i32, String> {
            match vr {
                2 => Ok(7),
                _ => Err(format!("no Integer {vr}")),
            }
        }
        fn lifecycle_mut(&mut self) -> &mut Lifecycle {
            &mut self.lifecycle
        }
        fn do_step(&mut self, _: f64, _: f64) -> Result<(), StepFailure> {
            self.y = self.y_after_step;
            Ok(())
        }
        fn reset(&mut self) -> Result<(), String> {
            Ok(())
        }
        fn save_state(&mut self) -> Vec<u8> {
            Vec::new()
        }
        fn load_state(&mut self, _: &[u8]) -> Result<(), String> {
            Ok(())
        }
    }

    fn ready(y_after_step: f64) -> Instance {
        let output = |name: &str, vr: u32| {
            let mut v = Variable::real(
                name,
                vr,
                Causality::Output,
                Variability::Continuous,
                Some(Initial::Calculated),
                None,
                None,
                "an output",
            );
            if vr == 2 {
                v.kind = VarKind::Integer;
                v.variability = Variability::Discrete;
            }
            v
        };
        let model = Outputs {
            vars: vec![output("y", 1), output("n", 2)],
            y: 1.0,
            y_after_step,
            lifecycle: Lifecycle::default(),
        };
        let callbacks = CallbackFunctions {
            logger: None,
            allocate_memory: None,
            free_memory: None,
            step_finished: None,
            component_environment: std::ptr::null_mut(),
        };
        let info = ModelInfo {
            model_name: "outputs".into(),
            description: String::new(),
            default_experiment: DefaultExperiment {
                start_time: 0.0,
                stop_time: 1.0,
                step_size: 0.1,
                tolerance: None,
            },
            guid: "{outputs}".into(),
            documentation: String::new(),
        };
        let logger = Logger::new(callbacks, CString::new("outputs").unwrap(), false);
        let mut inst = Instance::new(logger, Box::new(model), info);
        assert_eq!(inst.setup_experiment(None, 0.0, None), Status::Ok);
        assert_eq!(inst.enter_initialization_mode(), Status::Ok);
        assert_eq!(inst.exit_initialization_mode(), Status::Ok);
        inst
    }

    /// The safety net: a step after which an output is not finite is discarded at its start
    /// (a failure, not a termination), although the model reported success; the output
    /// then reads as its last good value, never the non-finite one (issue 17).
    #[test]
    fn a_non_finite_output_discards_the_step() {
        for bad in [f64::NAN, f64::INFINITY] {
            let mut inst = ready(bad);
            assert_eq!(inst.do_step(0.0, 0.1), Status::Discard, "y = {bad}");
            assert_eq!(inst.state, FmuState::StepFailed);
            let mut y = [f64::NAN];
            assert_eq!(inst.get_real(&[1], &mut y), Status::Ok);
            assert_eq!(y, [1.0], "the value after initialization, not {bad}");
            assert!(matches!(
                inst.status_query(Call::GetBooleanStatus, TERMINATED),
                Ok(StatusAnswer::Boolean(false))
            ));
            assert!(matches!(
                inst.status_query(Call::GetRealStatus, LAST_SUCCESSFUL_TIME),
                Ok(StatusAnswer::Real(t)) if t == 0.0
            ));
        }
        let mut inst = ready(2.0);
        assert_eq!(inst.do_step(0.0, 0.1), Status::Ok);
        assert_eq!(inst.read_outputs(), None);
    }

    /// A repeated get skips the type check only for the very request that passed it: a
    /// different vector, or a value reference of another type, is checked again.
    #[test]
    fn repeated_gets_keep_their_type_check() {
        let mut inst = ready(2.0);
        let (mut x, mut n) = ([0.0], [0]);
        for _ in 0..2 {
            assert_eq!(inst.get_real(&[1], &mut x), Status::Ok);
            assert_eq!(inst.get_integer(&[2], &mut n), Status::Ok);
        }
        assert_eq!((x, n), ([1.0], [7]));
        let mut inst = ready(2.0);
        assert_eq!(inst.get_real(&[1], &mut x), Status::Ok);
        assert_eq!(inst.get_real(&[2], &mut x), Status::Error);
        let mut inst = ready(2.0);
        assert_eq!(inst.get_integer(&[2], &mut n), Status::Ok);
        assert_eq!(inst.get_integer(&[1], &mut n), Status::Error);
        let mut inst = ready(2.0);
        assert_eq!(inst.get_integer(&[2, 2], &mut [0, 0]), Status::Ok);
        assert_eq!(inst.get_integer(&[2, 9], &mut [0, 0]), Status::Error);
    }
}
