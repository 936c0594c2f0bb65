//! One FMU instance: a safe wrapper over the raw FMI 2.0 function table.
//!
//! Every call goes through [`Instance::call`], which (a) optionally traces the call and its
//! status to stderr (`--fmi-trace`), and (b) turns a status of `fmi2Discard` or worse into an
//! error naming the function, its arguments, the status and the reasons the FMU logged
//! (FMI 2.0.5 §2.1.3: the logger is where an FMU explains a failing call).
//!
//! The instance owns its [`Logger`] and the `fmi2CallbackFunctions` struct: both must stay at a
//! fixed address until `fmi2FreeInstance`, since the FMU keeps pointers to them. `Drop` frees
//! the instance (unless the FMU reported `fmi2Fatal`, after which no call is allowed, §2.1.3).

use super::library::{CallbackFunctions, Component, FmiFunction, FmuLibrary, FmuState, Status};
use super::logger::{geardyn_host_logger, Logger};
use super::supervise::Activity;
use std::ffi::{c_char, c_int, CStr, CString};

/// The [`FmiFunction`] of a function name, checked when compiling.
macro_rules! f {
    ($name:literal) => {
        const { FmiFunction::named($name) }
    };
}

/// `fmi2Type` (fmi2TypesPlatform.h): we only instantiate Co-Simulation slaves.
const FMI2_COSIMULATION: c_int = 1;
/// `fmi2StatusKind` values used after `fmi2Discard` (FMI 2.0.5 §4.2.3).
const FMI2_LAST_SUCCESSFUL_TIME: c_int = 2;
const FMI2_TERMINATED: c_int = 3;

/// A failed FMI call, with everything needed to explain it.
#[derive(Debug, Clone)]
pub struct CallError {
    pub function: &'static str,
    pub status: Status,
    pub message: String,
}

impl std::fmt::Display for CallError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

pub struct Instance<'a> {
    lib: &'a FmuLibrary,
    c: Component,
    /// Where the call in progress is recorded before each call, for a supervising parent
    /// that must say where the FMU crashed ([`super::supervise`]).
    activity: &'a Activity,
    trace: bool,
    /// Set once the FMU returned fmi2Fatal: it must not be called again, not even freed.
    fatal: bool,
    // Dropped after `c` is freed (field order does not matter: Drop::drop runs first).
    _callbacks: Box<CallbackFunctions>,
    logger: Box<Logger>,
    /// The one FMU state this instance keeps for a rollback ([`Instance::save_state`]),
    /// reused from save to save and freed before the instance.
    saved: FmuState,
    /// `noSetFMUStatePriorToCurrentPoint` of `fmi2DoStep`: false once a state was saved.
    may_roll_back: bool,
}

/// Format a value list for the trace, like fmpy's `[FMI]` lines.
fn list<T: std::fmt::Debug>(v: &[T]) -> String {
    format!("{v:?}")
}

impl<'a> Instance<'a> {
    /// `fmi2Instantiate` (FMI 2.0.5 §2.1.5) as a Co-Simulation slave, not visible.
    ///
    /// `resource_uri` is the `file://` URI of the extracted `resources/` folder. A logger that
    /// prints every message ([`Logger::prints_all`]) also enables the FMU's debug logging
    /// from the start: asking for all messages means asking the FMU to produce them.
    pub fn instantiate(
        lib: &'a FmuLibrary,
        instance_name: &str,
        guid: &str,
        resource_uri: &str,
        logger: Logger,
        trace: bool,
        activity: &'a Activity,
    ) -> Result<Instance<'a>, String> {
        let logging_on = logger.prints_all();
        let cstring = |what: &str, s: &str| {
            CString::new(s).map_err(|_| format!("{what} \"{s}\" contains a NUL character"))
        };
        let name = cstring("instance name", instance_name)?;
        let guid_c = cstring("guid", guid)?;
        let uri = cstring("resource location", resource_uri)?;
        let logger = Box::new(logger);
        let callbacks = Box::new(CallbackFunctions {
            logger: Some(geardyn_host_logger),
            allocate_memory: Some(super::library::calloc),
            free_memory: Some(super::library::free),
            step_finished: None,
            component_environment: logger.component_environment(),
        });
        activity.enter(f!("fmi2Instantiate"));
        // SAFETY: all pointers are valid NUL-terminated strings / a callbacks struct that
        // outlives the instance (owned by it, boxed so its address is stable).
        let c = unsafe {
            (lib.fns.instantiate)(
                name.as_ptr(),
                FMI2_COSIMULATION,
                guid_c.as_ptr(),
                uri.as_ptr(),
                &*callbacks,
                0,
                c_int::from(logging_on),
            )
        };
        activity.leave();
        if trace {
            eprintln!(
                "[FMI] fmi2Instantiate(instanceName=\"{instance_name}\", fmuType=fmi2CoSimulation, fmuGUID=\"{guid}\", fmuResourceLocation=\"{resource_uri}\", visible=fmi2False, loggingOn={}) -> {c:?}",
                if logging_on { "fmi2True" } else { "fmi2False" }
            );
        }
        if c.is_null() {
            let why = logger.reasons(Status::Ok);
            return Err(format!(
                "fmi2Instantiate returned NULL{}",
                if why.is_empty() {
                    " (the FMU logged no reason)".to_string()
                } else {
                    format!(": {why}")
                }
            ));
        }
        Ok(Instance {
            lib,
            c,
            activity,
            trace,
            fatal: false,
            _callbacks: callbacks,
            logger,
            saved: std::ptr::null_mut(),
            may_roll_back: false,
        })
    }

    /// Check a status: trace it, and make `fmi2Discard` or worse an error. Inlined: it runs
    /// after every call, and a good status costs a compare and the logger's clear.
    #[inline]
    fn call(
        &mut self,
        function: FmiFunction,
        raw: c_int,
        args: impl FnOnce() -> String,
    ) -> Result<Status, CallError> {
        self.activity.leave();
        let status = Status::from_raw(raw);
        if self.trace {
            eprintln!("[FMI] {}({}) -> {status}", function.name(), args());
        }
        if status < Status::Discard {
            self.logger.clear();
            Ok(status)
        } else {
            Err(self.failed(function, status))
        }
    }

    /// The error of a call that returned `status` (`fmi2Discard` or worse), with the reasons
    /// the FMU logged during it.
    #[cold]
    fn failed(&mut self, function: FmiFunction, status: Status) -> CallError {
        let function = function.name();
        if status >= Status::Fatal {
            self.fatal = true;
        }
        let why = self.logger.reasons(Status::Warning);
        CallError {
            function,
            status,
            message: format!(
                "{function} returned {status}{}",
                if why.is_empty() {
                    " (the FMU logged no reason)".to_string()
                } else {
                    format!(": {why}")
                }
            ),
        }
    }

    /// The record of the call in progress (the runner adds the communication time).
    pub fn activity(&self) -> &'a Activity {
        self.activity
    }

    /// `fmi2SetDebugLogging(c, on, 0, NULL)`: zero categories means all of them (§2.1.5).
    pub fn set_debug_logging(&mut self, on: bool) -> Result<Status, CallError> {
        self.activity.enter(f!("fmi2SetDebugLogging"));
        // SAFETY: valid instance; nCategories = 0 with a null array is allowed.
        let r = unsafe {
            (self.lib.fns.set_debug_logging)(self.c, c_int::from(on), 0, std::ptr::null())
        };
        self.call(f!("fmi2SetDebugLogging"), r, || {
            format!("loggingOn={on}, nCategories=0")
        })
    }

    /// `fmi2SetupExperiment` (§2.1.6).
    pub fn setup_experiment(
        &mut self,
        tolerance: Option<f64>,
        start: f64,
        stop: Option<f64>,
    ) -> Result<Status, CallError> {
        self.activity.enter(f!("fmi2SetupExperiment"));
        // SAFETY: valid instance, plain values.
        let r = unsafe {
            (self.lib.fns.setup_experiment)(
                self.c,
                c_int::from(tolerance.is_some()),
                tolerance.unwrap_or(0.0),
                start,
                c_int::from(stop.is_some()),
                stop.unwrap_or(0.0),
            )
        };
        self.call(f!("fmi2SetupExperiment"), r, || {
            format!("toleranceDefined={}, tolerance={}, startTime={start}, stopTimeDefined={}, stopTime={}",
                tolerance.is_some(), tolerance.unwrap_or(0.0), stop.is_some(), stop.unwrap_or(0.0))
        })
    }

    pub fn enter_initialization_mode(&mut self) -> Result<Status, CallError> {
        self.activity.enter(f!("fmi2EnterInitializationMode"));
        // SAFETY: valid instance.
        let r = unsafe { (self.lib.fns.enter_initialization_mode)(self.c) };
        self.call(f!("fmi2EnterInitializationMode"), r, String::new)
    }

    pub fn exit_initialization_mode(&mut self) -> Result<Status, CallError> {
        self.activity.enter(f!("fmi2ExitInitializationMode"));
        // SAFETY: valid instance.
        let r = unsafe { (self.lib.fns.exit_initialization_mode)(self.c) };
        self.call(f!("fmi2ExitInitializationMode"), r, String::new)
    }

    pub fn terminate(&mut self) -> Result<Status, CallError> {
        self.activity.enter(f!("fmi2Terminate"));
        // SAFETY: valid instance.
        let r = unsafe { (self.lib.fns.terminate)(self.c) };
        self.call(f!("fmi2Terminate"), r, String::new)
    }

    /// `fmi2DoStep` (§4.2.2). `fmi2Discard` is returned as an error like any other failure;
    /// the caller asks [`Instance::discard_details`] what happened.
    pub fn do_step(&mut self, t: f64, h: f64) -> Result<Status, CallError> {
        self.activity.enter(f!("fmi2DoStep"));
        // SAFETY: valid instance. noSetFMUStatePriorToCurrentPoint is true unless a state
        // was saved (an error-controlled master may restore it).
        let no_rollback = !self.may_roll_back;
        let r = unsafe { (self.lib.fns.do_step)(self.c, t, h, c_int::from(no_rollback)) };
        self.call(f!("fmi2DoStep"), r, || {
            format!("currentCommunicationPoint={t:?}, communicationStepSize={h:?}, noSetFMUStatePriorToCurrentPoint={}",
                if no_rollback { "fmi2True" } else { "fmi2False" })
        })
    }

    /// `fmi2GetFMUstate` (§2.1.8) into the instance's one saved state (overwritten in place
    /// from the second save on, as the function allows), for [`Instance::restore_state`].
    pub fn save_state(&mut self) -> Result<Status, CallError> {
        self.may_roll_back = true;
        self.activity.enter(f!("fmi2GetFMUstate"));
        // SAFETY: valid instance; `saved` is NULL or a state this instance returned.
        let r = unsafe { (self.lib.fns.get_fmu_state)(self.c, &mut self.saved) };
        self.call(f!("fmi2GetFMUstate"), r, String::new)
    }

    /// `fmi2SetFMUstate` (§2.1.8) to the state of the last [`Instance::save_state`].
    pub fn restore_state(&mut self) -> Result<Status, CallError> {
        if self.saved.is_null() {
            return Err(CallError {
                function: "fmi2SetFMUstate",
                status: Status::Error,
                message: "fmi2SetFMUstate: no state was saved".into(),
            });
        }
        self.activity.enter(f!("fmi2SetFMUstate"));
        // SAFETY: valid instance and a state it returned from fmi2GetFMUstate.
        let r = unsafe { (self.lib.fns.set_fmu_state)(self.c, self.saved) };
        self.call(f!("fmi2SetFMUstate"), r, String::new)
    }

    /// After `fmi2DoStep` returned `fmi2Discard` (§4.2.3): `(terminated, lastSuccessfulTime)`,
    /// each `None` when the FMU cannot answer.
    pub fn discard_details(&mut self) -> (Option<bool>, Option<f64>) {
        let mut term: c_int = 0;
        let mut last: f64 = f64::NAN;
        self.activity.enter(f!("fmi2GetBooleanStatus"));
        // SAFETY: valid instance, valid out-pointers.
        let r1 = unsafe { (self.lib.fns.get_boolean_status)(self.c, FMI2_TERMINATED, &mut term) };
        let terminated = self
            .call(f!("fmi2GetBooleanStatus"), r1, || "s=fmi2Terminated".into())
            .ok()
            .map(|_| term != 0);
        self.activity.enter(f!("fmi2GetRealStatus"));
        // SAFETY: as above.
        let r2 =
            unsafe { (self.lib.fns.get_real_status)(self.c, FMI2_LAST_SUCCESSFUL_TIME, &mut last) };
        let last = self
            .call(f!("fmi2GetRealStatus"), r2, || {
                "s=fmi2LastSuccessfulTime".into()
            })
            .ok()
            .filter(|_| last.is_finite())
            .map(|_| last);
        (terminated, last)
    }

    pub fn set_real(&mut self, vr: &[u32], v: &[f64]) -> Result<Status, CallError> {
        debug_assert_eq!(vr.len(), v.len());
        self.activity.enter(f!("fmi2SetReal"));
        // SAFETY: both slices have len() elements.
        let r = unsafe { (self.lib.fns.set_real)(self.c, vr.as_ptr(), vr.len(), v.as_ptr()) };
        self.call(f!("fmi2SetReal"), r, || {
            format!("vr={}, value={}", list(vr), list(v))
        })
    }

    /// `fmi2SetRealInputDerivatives` (FMI 2.0.5 §4.2.1): the `order`-th time derivatives of
    /// Real inputs at the current communication point; an FMU with
    /// `canInterpolateInputs="true"` extrapolates the inputs over the step with them.
    pub fn set_real_input_derivatives(
        &mut self,
        vr: &[u32],
        order: &[i32],
        v: &[f64],
    ) -> Result<Status, CallError> {
        debug_assert!(vr.len() == v.len() && vr.len() == order.len());
        self.activity.enter(f!("fmi2SetRealInputDerivatives"));
        // SAFETY: the three slices have vr.len() elements.
        let r = unsafe {
            (self.lib.fns.set_real_input_derivatives)(
                self.c,
                vr.as_ptr(),
                vr.len(),
                order.as_ptr(),
                v.as_ptr(),
            )
        };
        self.call(f!("fmi2SetRealInputDerivatives"), r, || {
            format!("vr={}, order={}, value={}", list(vr), list(order), list(v))
        })
    }

    /// `fmi2GetRealOutputDerivatives` (FMI 2.0.5 §4.2.3): the `order`-th time derivatives of
    /// Real outputs at the current communication point (up to `maxOutputDerivativeOrder`).
    pub fn get_real_output_derivatives(
        &mut self,
        vr: &[u32],
        order: &[i32],
        out: &mut [f64],
    ) -> Result<Status, CallError> {
        debug_assert!(vr.len() == out.len() && vr.len() == order.len());
        self.activity.enter(f!("fmi2GetRealOutputDerivatives"));
        // SAFETY: out and order have vr.len() elements.
        let r = unsafe {
            (self.lib.fns.get_real_output_derivatives)(
                self.c,
                vr.as_ptr(),
                vr.len(),
                order.as_ptr(),
                out.as_mut_ptr(),
            )
        };
        let trace = self.trace;
        self.call(f!("fmi2GetRealOutputDerivatives"), r, || {
            if trace {
                format!(
                    "vr={}, order={}, value={}",
                    list(vr),
                    list(order),
                    list(out)
                )
            } else {
                String::new()
            }
        })
    }

    pub fn set_integer(&mut self, vr: &[u32], v: &[i32]) -> Result<Status, CallError> {
        self.activity.enter(f!("fmi2SetInteger"));
        // SAFETY: both slices have len() elements.
        let r = unsafe { (self.lib.fns.set_integer)(self.c, vr.as_ptr(), vr.len(), v.as_ptr()) };
        self.call(f!("fmi2SetInteger"), r, || {
            format!("vr={}, value={}", list(vr), list(v))
        })
    }

    /// Values are fmi2Boolean (`int`, 0 or 1).
    pub fn set_boolean(&mut self, vr: &[u32], v: &[i32]) -> Result<Status, CallError> {
        self.activity.enter(f!("fmi2SetBoolean"));
        // SAFETY: both slices have len() elements.
        let r = unsafe { (self.lib.fns.set_boolean)(self.c, vr.as_ptr(), vr.len(), v.as_ptr()) };
        self.call(f!("fmi2SetBoolean"), r, || {
            format!("vr={}, value={}", list(vr), list(v))
        })
    }

    pub fn set_string(&mut self, vr: &[u32], v: &[String]) -> Result<Status, CallError> {
        let owned: Vec<CString> = v
            .iter()
            .map(|s| CString::new(s.replace('\0', "")).unwrap_or_default())
            .collect();
        let ptrs: Vec<*const c_char> = owned.iter().map(|s| s.as_ptr()).collect();
        self.activity.enter(f!("fmi2SetString"));
        // SAFETY: vr and ptrs have the same length; the strings live until the call returns.
        let r = unsafe { (self.lib.fns.set_string)(self.c, vr.as_ptr(), vr.len(), ptrs.as_ptr()) };
        self.call(f!("fmi2SetString"), r, || {
            format!("vr={}, value={}", list(vr), list(v))
        })
    }

    pub fn get_real(&mut self, vr: &[u32], out: &mut [f64]) -> Result<Status, CallError> {
        debug_assert_eq!(vr.len(), out.len());
        self.activity.enter(f!("fmi2GetReal"));
        // SAFETY: out has vr.len() elements.
        let r = unsafe { (self.lib.fns.get_real)(self.c, vr.as_ptr(), vr.len(), out.as_mut_ptr()) };
        let trace = self.trace;
        self.call(f!("fmi2GetReal"), r, || {
            if trace {
                format!("vr={}, value={}", list(vr), list(out))
            } else {
                String::new()
            }
        })
    }

    pub fn get_integer(&mut self, vr: &[u32], out: &mut [i32]) -> Result<Status, CallError> {
        self.activity.enter(f!("fmi2GetInteger"));
        // SAFETY: out has vr.len() elements.
        let r =
            unsafe { (self.lib.fns.get_integer)(self.c, vr.as_ptr(), vr.len(), out.as_mut_ptr()) };
        self.call(f!("fmi2GetInteger"), r, || {
            format!("vr={}, value={}", list(vr), list(out))
        })
    }

    pub fn get_boolean(&mut self, vr: &[u32], out: &mut [i32]) -> Result<Status, CallError> {
        self.activity.enter(f!("fmi2GetBoolean"));
        // SAFETY: out has vr.len() elements.
        let r =
            unsafe { (self.lib.fns.get_boolean)(self.c, vr.as_ptr(), vr.len(), out.as_mut_ptr()) };
        self.call(f!("fmi2GetBoolean"), r, || {
            format!("vr={}, value={}", list(vr), list(out))
        })
    }

    /// `fmi2GetString`; the FMU owns the returned strings only until its next call, so they
    /// are copied at once (§2.1.7).
    pub fn get_string(&mut self, vr: &[u32]) -> Result<Vec<String>, CallError> {
        let mut ptrs: Vec<*const c_char> = vec![std::ptr::null(); vr.len()];
        self.activity.enter(f!("fmi2GetString"));
        // SAFETY: ptrs has vr.len() elements.
        let r =
            unsafe { (self.lib.fns.get_string)(self.c, vr.as_ptr(), vr.len(), ptrs.as_mut_ptr()) };
        self.call(f!("fmi2GetString"), r, || format!("vr={}", list(vr)))?;
        Ok(ptrs
            .iter()
            .map(|&p| {
                if p.is_null() {
                    String::new()
                } else {
                    // SAFETY: the FMU returned NUL-terminated strings, valid until its next call.
                    unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
                }
            })
            .collect())
    }
}

impl Drop for Instance<'_> {
    fn drop(&mut self) {
        if self.fatal {
            // §2.1.3: after fmi2Fatal "it is not possible to call any other function";
            // leaking the instance is the only safe choice.
            if self.trace {
                eprintln!("[FMI] fmi2FreeInstance skipped: the FMU returned fmi2Fatal");
            }
            return;
        }
        if !self.saved.is_null() {
            self.activity.enter(f!("fmi2FreeFMUstate"));
            // SAFETY: a state of this instance, freed once, before the instance.
            unsafe { (self.lib.fns.free_fmu_state)(self.c, &mut self.saved) };
            self.activity.leave();
        }
        self.activity.enter(f!("fmi2FreeInstance"));
        // SAFETY: c came from fmi2Instantiate of this library and is freed exactly once.
        unsafe { (self.lib.fns.free_instance)(self.c) };
        self.activity.leave();
        if self.trace {
            eprintln!("[FMI] fmi2FreeInstance()");
        }
    }
}
