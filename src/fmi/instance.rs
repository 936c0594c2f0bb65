//! One FMU instance: the safe-Rust semantics of every instance-bound FMI call.
//!
//! [`super::abi`] only validates raw pointers, catches panics and dispatches here. Every
//! method checks the state machine first ([`Call::allowed_in`]); every failure is logged
//! with the call name and the state or variable and value, and an `fmi2Error` moves the
//! instance into the `error` state (FMI 2.0.x §2.1.3: "the simulation cannot be continued").

use std::fmt::Display;

use super::blob::{self, LayerSnapshot};
use super::logger::{Category, Logger, Status};
use super::model::{CoSimModel, ModelInfo, StepFailure, VarKind, Variable};
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

/// The object behind an `fmi2FMUstate`: an envelope from [`blob::encode`].
pub struct StateBox {
    pub magic: u64,
    pub bytes: Vec<u8>,
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
    /// The value references of the last `fmi2GetReal` that passed the type check. A host
    /// asks for the same ones after every step, and the variable table never changes
    /// ([`CoSimModel::variables`]), so a repeated request needs no check per reference.
    checked_real_vrs: Vec<u32>,
    /// The value references of the Real outputs, checked for finiteness after every step.
    real_outputs: Vec<u32>,
    /// Their values after the last step (one buffer for the whole run).
    output_values: Vec<f64>,
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
        Instance {
            magic: INSTANCE_MAGIC,
            logger,
            model,
            info,
            index,
            kinds,
            checked_real_vrs: Vec::new(),
            output_values: vec![0.0; real_outputs.len()],
            real_outputs,
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

    /// State-machine check shared by every call.
    pub fn check(&mut self, call: Call) -> Result<(), Status> {
        if call.allowed_in(self.state) {
            Ok(())
        } else {
            let state = self.state.name();
            Err(self.error(call, format!("not allowed in state {state}")))
        }
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

    /// Shared body of the getters: state check, then per value reference the type check
    /// and the model's answer; the first failure is the call's error.
    fn get_values<T>(
        &mut self,
        call: Call,
        kind: VarKind,
        vrs: &[u32],
        out: &mut [T],
        get: impl Fn(&dyn CoSimModel, u32) -> Result<T, String>,
    ) -> Status {
        if let Err(s) = self.check(call) {
            return s;
        }
        for (vr, slot) in vrs.iter().zip(out.iter_mut()) {
            let r = self
                .check_kind(*vr, kind)
                .and_then(|()| get(self.model.as_ref(), *vr));
            match r {
                Ok(x) => *slot = x,
                Err(e) => return self.error(call, e),
            }
        }
        Status::Ok
    }

    /// Like [`Self::get_values`], but the model answers the whole vector in one call: a host
    /// reads every output after every step.
    pub fn get_real(&mut self, vrs: &[u32], out: &mut [f64]) -> Status {
        let call = Call::GetReal;
        if let Err(s) = self.check(call) {
            return s;
        }
        if vrs != self.checked_real_vrs.as_slice() {
            if let Some(e) = vrs
                .iter()
                .find_map(|&vr| self.check_kind(vr, VarKind::Real).err())
            {
                return self.error(call, e);
            }
            self.checked_real_vrs.clear();
            self.checked_real_vrs.extend_from_slice(vrs);
        }
        match self.model.get_reals(vrs, out) {
            Ok(()) => Status::Ok,
            Err(e) => self.error(call, e),
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
    /// against the current state, finiteness and bounds.
    fn check_set(&self, vr: u32, kind: VarKind, value: f64) -> Result<(), String> {
        let var = self.lookup(vr, kind)?;
        check_settable(var, self.state)?;
        if kind == VarKind::Real {
            if !value.is_finite() {
                return Err(format!("'{}' (vr {vr}) = {value} is not finite", var.name));
            }
            if var.min.is_some_and(|m| value < m) || var.max.is_some_and(|m| value > m) {
                return Err(format!(
                    "'{}' (vr {vr}) = {value} outside [{}, {}]",
                    var.name,
                    var.min.unwrap_or(f64::NEG_INFINITY),
                    var.max.unwrap_or(f64::INFINITY)
                ));
            }
        }
        Ok(())
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
        if let Err(s) = self.check(call) {
            return s;
        }
        for (vr, x) in vrs.iter().zip(values) {
            if let Err(e) = self.check_set(*vr, kind, as_f64(*x)) {
                return self.error(call, e);
            }
        }
        for (vr, x) in vrs.iter().zip(values) {
            if let Err(e) = set(self.model.as_mut(), *vr, *x) {
                return self.error(call, e);
            }
        }
        Status::Ok
    }

    pub fn set_real(&mut self, vrs: &[u32], values: &[f64]) -> Status {
        self.set_values(
            Call::SetReal,
            VarKind::Real,
            vrs,
            values,
            |x| x,
            |m, vr, x| m.set_real(vr, x),
        )
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
        if let Some(stop) = self.stop_time {
            let eps = 1e-12 * stop.abs().max(1.0);
            if target > stop + eps {
                return self.error(
                    call,
                    format!("step to tc + h = {target:?} would pass stopTime = {stop:?}"),
                );
            }
        }
        match self.model.do_step(tc, h) {
            Ok(()) => {
                // Safety net independent of the model: a non-finite output must never be
                // reported as a good step.
                if let Some(msg) = self.non_finite_output() {
                    self.time = tc;
                    self.last_successful_time = tc;
                    self.terminated = true;
                    self.state = FmuState::StepFailed;
                    self.logger.log(
                        Status::Discard,
                        &format!("fmi2DoStep: step from t = {tc:?} by h = {h:?} discarded: {msg}"),
                    );
                    return Status::Discard;
                }
                self.time = target;
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
            Err(StepFailure::Error(e)) => self.error(
                call,
                format!("step from t = {tc:?} by h = {h:?} failed: {e}"),
            ),
        }
    }

    /// The first Real output that is not finite after a step, as a reason; `None` if all
    /// are finite. Reads them through the model's `get_reals` (one pass over the outputs it
    /// evaluates anyway for the host's `fmi2GetReal`), into a buffer sized once.
    fn non_finite_output(&mut self) -> Option<String> {
        if let Err(e) = self
            .model
            .get_reals(&self.real_outputs, &mut self.output_values)
        {
            return Some(e);
        }
        let (&vr, &x) = self
            .real_outputs
            .iter()
            .zip(&self.output_values)
            .find(|(_, x)| !x.is_finite())?;
        let name = self.lookup(vr, VarKind::Real).map_or("?", |v| &v.name);
        Some(format!("output '{name}' (vr {vr}) = {x} is not finite"))
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

    /// `fmi2GetFMUstate`: the complete state as an envelope.
    pub fn snapshot(&mut self) -> Result<Vec<u8>, Status> {
        self.check(Call::GetFMUstate)?;
        Ok(blob::encode(
            &self.info.guid,
            &self.layer_snapshot(),
            &self.model.save_state(),
        ))
    }

    /// `fmi2SetFMUstate`: checks the envelope, then restores model and layer state
    /// ("transitions to the given state", §4.2.4).
    pub fn restore(&mut self, bytes: &[u8]) -> Status {
        let call = Call::SetFMUstate;
        if let Err(s) = self.check(call) {
            return s;
        }
        let (layer, payload) = match blob::decode(bytes, &self.info.guid) {
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

/// Answer of a status query.
pub enum StatusAnswer {
    Real(f64),
    Boolean(bool),
}
