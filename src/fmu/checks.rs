//! Pieces both gear adapters ([`crate::fmu::pair`], [`crate::fmu::drivetrain`]) share: parameter
//! checks whose messages name the FMU variable and the value, variable constructors and
//! lookups in a variable table (FMI 2.0.x §2.2.7), and the step through the shared
//! [`Driver`]. Physics-free.

use crate::fmi::model::{
    Causality, DefaultExperiment, Initial, ModelInfo, StepFailure, VarKind, Variability, Variable,
};
use crate::scene::SolverSettings;
use crate::simulation::{DrivenModel, Driver};

/// The description-level data of a scene's FMU: its name, its description (`fallback` when
/// the scene has none) and the scene's stop time and output interval as `DefaultExperiment`.
pub fn model_info(
    name: &str,
    description: &str,
    fallback: &str,
    solver: &SolverSettings,
    guid: String,
    documentation: &str,
) -> ModelInfo {
    ModelInfo {
        model_name: name.to_string(),
        description: if description.is_empty() {
            fallback
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
        documentation: documentation.to_string(),
    }
}

/// `name = value` must be finite and satisfy `ok` (`rule` says what is expected).
pub fn check(name: &str, value: f64, ok: bool, rule: &str) -> Result<(), String> {
    if value.is_finite() && ok {
        Ok(())
    } else {
        Err(format!("parameter '{name}' = {value}: must be {rule}"))
    }
}

/// A tunable-before-initialization Real parameter (`fixed`, `initial = exact`).
pub fn param(name: &str, vr: u32, start: f64, unit: Option<&str>, desc: &str) -> Variable {
    Variable::real(
        name,
        vr,
        Causality::Parameter,
        Variability::Fixed,
        Some(Initial::Exact),
        Some(start),
        unit,
        desc,
    )
}

/// A continuous Real input with a start value.
pub fn input(name: &str, vr: u32, start: f64, unit: &str, desc: &str) -> Variable {
    Variable::real(
        name,
        vr,
        Causality::Input,
        Variability::Continuous,
        None,
        Some(start),
        Some(unit),
        desc,
    )
}

/// Name of the variable with value reference `vr` (`?` when there is none).
pub fn name_of(vars: &[Variable], vr: u32) -> &str {
    vars.iter()
        .find(|v| v.value_reference == vr)
        .map_or("?", |v| v.name.as_str())
}

/// The Real parameters and inputs: what an FMU state must carry besides the run-time state
/// to rebuild an instance (their values set before initialization define its equations and
/// initial operating point).
pub fn settable_reals(vars: &[Variable]) -> impl Iterator<Item = &Variable> {
    vars.iter().filter(|v| {
        v.kind == VarKind::Real && matches!(v.causality, Causality::Parameter | Causality::Input)
    })
}

/// After `name = value` was set before initialization: the initial outputs of the rebuilt
/// model must be finite. A start value the arithmetic cannot carry (an initial DTE rate of
/// 1e308 gives an infinite damping force) is refused where it is set, naming the output,
/// rather than read back as an infinite output (issue 17).
pub fn check_initial_outputs(
    name: &str,
    value: f64,
    names: &[impl AsRef<str>],
    outputs: &[f64],
) -> Result<(), String> {
    match outputs.iter().position(|y| !y.is_finite()) {
        None => Ok(()),
        Some(k) => Err(format!(
            "'{name}' = {value:?}: the initial output '{}' would be {}",
            names.get(k).map_or("?", |n| n.as_ref()),
            outputs[k]
        )),
    }
}

/// Checks the values a snapshot sets, by value reference, with the layer's check of every
/// `fmi2SetReal` ([`Variable::check_value`]): a value reference the table does not have (a
/// state of another model), a non-finite value or one outside `[min, max]` is refused. The
/// model's own checks follow when the values are applied, as for a set (issue 17: a restored
/// state holds nothing `fmi2SetReal` would refuse).
pub fn check_restored(vars: &[Variable], values: &[(u32, f64)]) -> Result<(), String> {
    for &(vr, x) in values {
        let var = vars
            .iter()
            .find(|v| v.value_reference == vr)
            .ok_or_else(|| format!("the state sets unknown value reference {vr}"))?;
        var.check_value(x)
            .map_err(|e| format!("the state holds {e}"))?;
    }
    Ok(())
}

/// The values of a snapshot that either adapter checks before it rebuilds anything: the
/// parameters and start inputs as `fmi2SetReal` before initialization takes them, the current
/// inputs as it takes them at a communication point (both [`check_restored`]), and a finite
/// start time.
pub fn check_snapshot_values(
    vars: &[Variable],
    params: &[(u32, f64)],
    inputs: &[(u32, f64)],
    start_time: f64,
) -> Result<(), String> {
    check_restored(vars, params)?;
    check_restored(vars, inputs)?;
    if !start_time.is_finite() {
        return Err(format!("start time {start_time} is not finite"));
    }
    Ok(())
}

/// One co-simulation step of either adapter: integrates to exactly `t + h` in the host's
/// time (the simulation runs in local time from `start_time`), never backwards, and never
/// evaluates the model beyond that point. A failing integrator discards the step at the last
/// good state it holds and ends the run.
pub fn do_step<M: DrivenModel>(
    sim: &mut Driver<M>,
    start_time: f64,
    t: f64,
    h: f64,
) -> Result<(), StepFailure> {
    let target = ((t + h) - start_time).max(sim.t());
    sim.advance_to(target).map_err(|e| StepFailure::Discard {
        reason: format!("the integrator stopped: {e}"),
        reached: start_time + sim.t(),
        terminate: true,
    })
}
