//! The FMI 2.0 Co-Simulation state machine (FMI 2.0.x §4.2.4, figure 11 and the table of
//! allowed calls), enforced per function.
//!
//! The asynchronous states `stepInProgress`/`stepCanceled` are never entered: this FMU does
//! not declare `canRunAsynchronuously`, so `fmi2DoStep` never returns `fmi2Pending`.

use super::model::{Causality, Initial, Variability, Variable};

/// Where an instance is in the FMI life cycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FmuState {
    Instantiated,
    InitializationMode,
    StepComplete,
    StepFailed,
    Terminated,
    /// A call returned `fmi2Error` (FMI 2.0.x §2.1.3): only debug getters, `fmi2Reset`,
    /// `fmi2SetFMUstate` and `fmi2FreeInstance` are allowed.
    Error,
    /// A call returned `fmi2Fatal` (a caught panic): nothing but `fmi2FreeInstance`.
    Fatal,
}

impl FmuState {
    pub fn name(self) -> &'static str {
        match self {
            FmuState::Instantiated => "instantiated",
            FmuState::InitializationMode => "initializationMode",
            FmuState::StepComplete => "stepComplete",
            FmuState::StepFailed => "stepFailed",
            FmuState::Terminated => "terminated",
            FmuState::Error => "error",
            FmuState::Fatal => "fatal",
        }
    }

    fn bit(self) -> u8 {
        1 << (self as u8)
    }

    /// Encoding used inside FMU-state blobs. Only states a snapshot can be taken in.
    pub fn to_code(self) -> u8 {
        self as u8
    }

    pub fn from_code(code: u8) -> Option<FmuState> {
        Some(match code {
            0 => FmuState::Instantiated,
            1 => FmuState::InitializationMode,
            2 => FmuState::StepComplete,
            3 => FmuState::StepFailed,
            4 => FmuState::Terminated,
            _ => return None,
        })
    }
}

const INST: u8 = 1 << 0;
const INIT: u8 = 1 << 1;
const STEP_COMPLETE: u8 = 1 << 2;
const STEP_FAILED: u8 = 1 << 3;
const TERMINATED: u8 = 1 << 4;
const ERROR: u8 = 1 << 5;

/// Every instance-bound FMI call, named for log lines.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Call {
    SetDebugLogging,
    SetupExperiment,
    EnterInitializationMode,
    ExitInitializationMode,
    Terminate,
    Reset,
    GetReal,
    GetInteger,
    GetBoolean,
    GetString,
    SetReal,
    SetInteger,
    SetBoolean,
    SetString,
    GetFMUstate,
    SetFMUstate,
    FreeFMUstate,
    SerializedFMUstateSize,
    SerializeFMUstate,
    DeSerializeFMUstate,
    GetDirectionalDerivative,
    SetRealInputDerivatives,
    GetRealOutputDerivatives,
    DoStep,
    CancelStep,
    GetStatus,
    GetRealStatus,
    GetIntegerStatus,
    GetBooleanStatus,
    GetStringStatus,
}

impl Call {
    pub fn name(self) -> &'static str {
        match self {
            Call::SetDebugLogging => "fmi2SetDebugLogging",
            Call::SetupExperiment => "fmi2SetupExperiment",
            Call::EnterInitializationMode => "fmi2EnterInitializationMode",
            Call::ExitInitializationMode => "fmi2ExitInitializationMode",
            Call::Terminate => "fmi2Terminate",
            Call::Reset => "fmi2Reset",
            Call::GetReal => "fmi2GetReal",
            Call::GetInteger => "fmi2GetInteger",
            Call::GetBoolean => "fmi2GetBoolean",
            Call::GetString => "fmi2GetString",
            Call::SetReal => "fmi2SetReal",
            Call::SetInteger => "fmi2SetInteger",
            Call::SetBoolean => "fmi2SetBoolean",
            Call::SetString => "fmi2SetString",
            Call::GetFMUstate => "fmi2GetFMUstate",
            Call::SetFMUstate => "fmi2SetFMUstate",
            Call::FreeFMUstate => "fmi2FreeFMUstate",
            Call::SerializedFMUstateSize => "fmi2SerializedFMUstateSize",
            Call::SerializeFMUstate => "fmi2SerializeFMUstate",
            Call::DeSerializeFMUstate => "fmi2DeSerializeFMUstate",
            Call::GetDirectionalDerivative => "fmi2GetDirectionalDerivative",
            Call::SetRealInputDerivatives => "fmi2SetRealInputDerivatives",
            Call::GetRealOutputDerivatives => "fmi2GetRealOutputDerivatives",
            Call::DoStep => "fmi2DoStep",
            Call::CancelStep => "fmi2CancelStep",
            Call::GetStatus => "fmi2GetStatus",
            Call::GetRealStatus => "fmi2GetRealStatus",
            Call::GetIntegerStatus => "fmi2GetIntegerStatus",
            Call::GetBooleanStatus => "fmi2GetBooleanStatus",
            Call::GetStringStatus => "fmi2GetStringStatus",
        }
    }

    /// States in which the call is allowed: the CS table of FMI 2.0.x §4.2.4 with the
    /// asynchronous states dropped. `fmi2GetFMUstate` is excluded in `error` because the
    /// spec only promises restarts from states saved "in non-erroneous state" (§2.1.8).
    fn mask(self) -> u8 {
        let live = INST | INIT | STEP_COMPLETE | STEP_FAILED | TERMINATED;
        match self {
            Call::SetDebugLogging => live | ERROR,
            Call::SetupExperiment | Call::EnterInitializationMode => INST,
            Call::ExitInitializationMode => INIT,
            Call::Terminate => STEP_COMPLETE | STEP_FAILED,
            Call::Reset => live | ERROR,
            Call::GetReal | Call::GetInteger | Call::GetBoolean | Call::GetString => {
                INIT | STEP_COMPLETE | STEP_FAILED | TERMINATED | ERROR
            }
            Call::SetReal | Call::SetInteger | Call::SetBoolean | Call::SetString => {
                INST | INIT | STEP_COMPLETE
            }
            Call::GetFMUstate => live,
            Call::SetFMUstate
            | Call::FreeFMUstate
            | Call::SerializedFMUstateSize
            | Call::SerializeFMUstate
            | Call::DeSerializeFMUstate => live | ERROR,
            Call::GetDirectionalDerivative => {
                INIT | STEP_COMPLETE | STEP_FAILED | TERMINATED | ERROR
            }
            Call::SetRealInputDerivatives => INST | INIT | STEP_COMPLETE,
            Call::GetRealOutputDerivatives => STEP_COMPLETE | STEP_FAILED | TERMINATED | ERROR,
            Call::DoStep => STEP_COMPLETE,
            // Only legal in stepInProgress, which this FMU never enters.
            Call::CancelStep => 0,
            Call::GetStatus
            | Call::GetRealStatus
            | Call::GetIntegerStatus
            | Call::GetBooleanStatus
            | Call::GetStringStatus => STEP_COMPLETE | STEP_FAILED | TERMINATED,
        }
    }

    pub fn allowed_in(self, state: FmuState) -> bool {
        self.mask() & state.bit() != 0
    }
}

/// May `var` be set in `state`? (FMI 2.0.x §2.2.7, "Setting values": before initialization
/// variables with `initial = exact | approx`; during initialization `initial = exact` or
/// inputs; at communication points inputs and tunable parameters.) Inputs are also accepted
/// in `instantiated` because hosts such as fmpy set input start values there.
/// Returns a reason when not.
pub fn check_settable(var: &Variable, state: FmuState) -> Result<(), String> {
    if var.variability == Variability::Constant {
        return Err(format!("'{}' is a constant", var.name));
    }
    let is_input = var.causality == Causality::Input;
    let ok = match state {
        FmuState::Instantiated => {
            is_input || matches!(var.initial, Some(Initial::Exact | Initial::Approx))
        }
        FmuState::InitializationMode => is_input || var.initial == Some(Initial::Exact),
        FmuState::StepComplete => {
            is_input
                || (var.causality == Causality::Parameter
                    && var.variability == Variability::Tunable)
        }
        _ => false,
    };
    if ok {
        Ok(())
    } else {
        Err(format!(
            "'{}' (causality={}, variability={}, initial={}) cannot be set in state {}",
            var.name,
            var.causality.as_str(),
            var.variability.as_str(),
            var.initial.map_or("(none)", Initial::as_str),
            state.name()
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn param(variability: Variability) -> Variable {
        Variable::real(
            "k",
            1,
            Causality::Parameter,
            variability,
            Some(Initial::Exact),
            Some(1.0),
            None,
            "k",
        )
    }

    #[test]
    fn fixed_parameter_only_before_exit_initialization() {
        let p = param(Variability::Fixed);
        assert!(check_settable(&p, FmuState::Instantiated).is_ok());
        assert!(check_settable(&p, FmuState::InitializationMode).is_ok());
        let e = check_settable(&p, FmuState::StepComplete).unwrap_err();
        assert!(
            e.contains("'k'") && e.contains("fixed") && e.contains("stepComplete"),
            "{e}"
        );
        assert!(check_settable(&param(Variability::Tunable), FmuState::StepComplete).is_ok());
    }

    #[test]
    fn outputs_are_never_settable() {
        let mut o = param(Variability::Continuous);
        o.causality = Causality::Output;
        o.initial = Some(Initial::Calculated);
        for s in [
            FmuState::Instantiated,
            FmuState::InitializationMode,
            FmuState::StepComplete,
        ] {
            assert!(check_settable(&o, s).is_err());
        }
    }

    #[test]
    fn call_masks_follow_the_table() {
        assert!(Call::DoStep.allowed_in(FmuState::StepComplete));
        assert!(!Call::DoStep.allowed_in(FmuState::StepFailed));
        assert!(!Call::GetReal.allowed_in(FmuState::Instantiated));
        assert!(Call::GetReal.allowed_in(FmuState::Error));
        assert!(Call::Reset.allowed_in(FmuState::Error));
        assert!(!Call::Reset.allowed_in(FmuState::Fatal));
        assert!(!Call::Terminate.allowed_in(FmuState::Error));
        assert!(!Call::CancelStep.allowed_in(FmuState::StepComplete));
        for code in 0..5 {
            assert_eq!(FmuState::from_code(code).unwrap().to_code(), code);
        }
        assert!(FmuState::from_code(5).is_none());
    }
}
