//! The work budget of a streamed run (issue 34): the run limits ([`super::RunLimits`]) bound
//! what can be known before a run (rows, mesh periods, periods of the fastest mode the model
//! bounds), but not the steps an integrator actually takes — a stiffness the bounds do not
//! see, a chattering contact or a tight tolerance can still make a short run take hours. So the
//! solver's work is counted as the run goes and the run stops once it exceeds the budget, with
//! a message that names the likely cause (stiffness, speed or step count) read off the model's
//! time scales and the steps taken. The same reading is added to the solver's own refusals of
//! one advance (too many steps, a step below the time resolution).
//!
//! The count is taken between output points, from the propagator's statistics: a run stops at
//! most one advance (itself bounded by the propagator, `RkOptions::max_steps`) after its budget.

use super::driver::{DrivenModel, Driver};
use super::stream::RunScales;
use crate::solve::{SolveError, SolverStats};

/// Default of [`super::RunLimits::max_work`]: 1e8 steps and events are a few minutes for a
/// single pair and up to an hour for a large drivetrain; the shipped scenes take 1e3 to 1e5.
pub const DEFAULT_MAX_WORK: u64 = 100_000_000;

/// The work of a run so far: accepted and rejected steps (segments of the exact propagator)
/// and located events.
pub fn solver_work(stats: &SolverStats) -> u64 {
    stats.steps + stats.rejected + stats.events
}

/// Checks a run's work against `max_work` after an output point: the message names the work,
/// the time reached, the budget and how to raise it, and the likely cause.
pub fn check_work<M: DrivenModel>(
    sim: &Driver<M>,
    stop_time: f64,
    max_work: u64,
) -> Result<(), String> {
    let stats = sim.stats();
    let work = solver_work(&stats);
    if work <= max_work {
        return Ok(());
    }
    let t = sim.t();
    let rate = if t > 0.0 {
        format!(
            " (at this rate the run would need about {:.1e})",
            work as f64 * stop_time / t
        )
    } else {
        String::new()
    };
    Err(format!(
        "the run took {work} solver steps and events by t = {t:e} s of stop_time = {stop_time:e} s, \
         more than its work budget of {max_work}{rate}; likely cause: {}. Raise the budget with \
         --max-work (Python: max_work) to run it anyway",
        likely_cause(&sim.model().run_scales(), &stats, t)
    ))
}

/// The solver's refusal of an advance, with the likely cause when it is one of work (too many
/// steps, a step below the time resolution, too many guard samples or events).
pub fn explain_failure<M: DrivenModel>(sim: &Driver<M>, e: &SolveError) -> String {
    match e {
        SolveError::TooManySteps { .. }
        | SolveError::StepSizeTooSmall { .. }
        | SolveError::TooManyGuardSamples { .. }
        | SolveError::EventStorm { .. } => format!(
            "integration failed: {e}; likely cause: {}",
            likely_cause(&sim.model().run_scales(), &sim.stats(), sim.t())
        ),
        _ => format!("integration failed: {e}"),
    }
}

/// Which of the model's time scales holds the step: the fastest mode (stiffness), the mesh
/// period (speed), the events, or none of them (the step count itself: tolerance, or a
/// stiffness the model's bound does not see). `t` is the time reached after `stats`.
pub fn likely_cause(scales: &RunScales, stats: &SolverStats, t: f64) -> String {
    let steps = (stats.steps + stats.rejected).max(1) as f64;
    let h = t / steps;
    let (rate, source) = scales.fastest_rate;
    let mode_period = if rate > 0.0 {
        std::f64::consts::TAU / rate
    } else {
        f64::INFINITY
    };
    let mesh_period = if scales.mesh_frequency > 0.0 {
        1.0 / scales.mesh_frequency
    } else {
        f64::INFINITY
    };
    let (field, speed) = scales.speed;
    if stats.events as f64 > 0.5 * steps {
        return format!(
            "the event count: {} contact changes by t = {t:e} s ({field} = {speed:e} rad/s, mesh \
             frequency {:.4e} Hz): the teeth chatter in and out of contact",
            stats.events, scales.mesh_frequency
        );
    }
    // A step within a few hundred of the fastest mode's period is what an explicit method
    // needs to stay stable there: that mode sets the pace.
    if mode_period < 0.1 * mesh_period && h > mode_period / 1000.0 {
        return format!(
            "stiffness: the fastest mode ({rate:.4e} rad/s, set by {source}) holds the step near \
             {h:.3e} s, {:.3e} steps per mesh period; a stiff method (solver.rk_method = \
             \"rodas4\") or softer values there",
            mesh_period / h
        );
    }
    if h > mesh_period / 10_000.0 {
        return format!(
            "speed: {field} = {speed:e} rad/s gives a mesh frequency of {:.4e} Hz, and each \
             mesh period takes about {:.0} steps",
            scales.mesh_frequency,
            mesh_period / h
        );
    }
    format!(
        "the step count: the mean step {h:.3e} s is far below the mesh period ({mesh_period:.3e} \
         s) and the period of the fastest mode the model bounds ({mode_period:.3e} s, set by \
         {source}); a tight tolerance (solver.rtol, solver.atol) or a stiffness outside that \
         bound (an element's shaft or port)"
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scales(mesh_frequency: f64, rate: f64) -> RunScales {
        RunScales {
            mesh_frequency,
            mesh_frequency_slope: 0.0,
            start_phase: 0.0,
            speed: ("operating.pinion_speed", 471.0),
            fastest_rate: (rate, "the mesh and bearing stiffnesses"),
        }
    }

    fn stats(steps: u64, events: u64) -> SolverStats {
        SolverStats {
            steps,
            events,
            ..Default::default()
        }
    }

    #[test]
    fn names_the_scale_that_holds_the_step() {
        // 1e6 steps over 1e-6 s: h = 1e-12 s against a mode period of 6e-12 s.
        let c = likely_cause(&scales(2850.0, 1e12), &stats(1_000_000, 0), 1e-6);
        assert!(c.starts_with("stiffness"), "{c}");
        // 1e6 steps over 1 s at a 1 GHz mesh: ~1000 steps per mesh period, no stiff mode.
        let c = likely_cause(&scales(1e9, 1e4), &stats(1_000_000, 0), 1e-3);
        assert!(c.starts_with("speed"), "{c}");
        let c = likely_cause(&scales(2850.0, 1e4), &stats(1_000_000, 900_000), 1e-3);
        assert!(c.starts_with("the event count"), "{c}");
        // h = 1e-12 s, nothing in the model near it.
        let c = likely_cause(&scales(2850.0, 1e4), &stats(1_000_000, 0), 1e-6);
        assert!(c.starts_with("the step count"), "{c}");
    }
}
