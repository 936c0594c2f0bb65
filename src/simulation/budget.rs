//! The work budget of the solver driver (issue 34): the work of a [`super::Driver`] in one
//! scope — one FMI call of an FMU, one whole streamed run (`geardyn simulate`, the Python
//! module's runs) — either stays within a documented amount or stops with
//! [`crate::solve::SolveError::OverBudget`], whose message names the likely cause. The scene's
//! `[solver] work_budget` sets it; unset, the scope's default applies ([`DEFAULT_CALL_BUDGET`],
//! [`DEFAULT_RUN_BUDGET`]); the analyses apply the run's default to each of their runs
//! (`Scene::simulation`, a sweep point a scope of its own); a driver used directly
//! (benchmarks) is unbounded until its owner applies one
//! ([`super::Driver::default_work_budget`]). The budget counts work, not time, so a run is
//! deterministic: the same inputs stop at the same step on any machine.
//!
//! The unit is an estimate of floating-point work (about one multiply-add; 2–3 ns on the CI
//! machine's core): an RK step attempt of an `n`-state model costs [`rk_step_cost`], a segment
//! (or state event) of the exact propagator [`segment_cost`]. The propagators meter their own
//! work at these prices ([`crate::solve::work`]) and stop at the cumulative work where the
//! scope's budget ends, so an advance never overruns it by more than one step; the budget
//! only records where its scope started, and nothing is charged per advance.
//! Matrix decompositions reachable from input (model construction, Floquet analyses) are
//! bounded by iteration caps of their own (`model::train::assembly`).

use super::scales::RunScales;
use crate::solve::SolverStats;

/// Default budget of one FMI call (`fmi2DoStep`), in work units: at most about 0.3 s on the
/// development machine's core for the costliest work per unit the FMI fuzzer finds (typically
/// far less), so a call returns well within a second whatever its inputs; 4 times the work of
/// the costliest shipped FMU's whole default experiment in one step.
pub const DEFAULT_CALL_BUDGET: f64 = 5e7;

/// Default budget of one run (`geardyn simulate`, the Python module's runs): about 5 s of
/// work, far beyond the shipped scenes' default runs (at most 0.17 s); a longer run needs
/// `solver.work_budget` raised explicitly.
pub const DEFAULT_RUN_BUDGET: f64 = 2e9;

/// The scene key (`[solver] work_budget`) and FMU parameter that set the budget.
pub const BUDGET_KEY: &str = "solver.work_budget";

/// Work units of one step attempt of an RK method on an `n`-state model: up to 16 right-hand
/// side evaluations (DOP853's 12 stages and its 3 dense-output stages when events are
/// searched), each dominated by a dense `n × n` product plus a fixed part (stiffness lookup,
/// contact logic).
pub fn rk_step_cost(n: usize) -> f64 {
    16.0 * ((n * n) as f64 + 16.0)
}

/// Work units of one segment or state event of the exact propagator on a lifted state of
/// `n_z` entries: a mat-vec or two (transition, guard rows) plus a fixed part. Large dense
/// products run several flops per unit (vectorised), so the quadratic and cubic terms below
/// are weighted by what they cost, not by their flop count.
pub fn segment_cost(n_z: usize) -> f64 {
    2.0 * (n_z * n_z) as f64 + 64.0
}

/// Work units of building one mode of the exact propagator on a lifted state of `n_z`
/// entries: balancing, its rates and first exponentials (which are metered on their own).
pub fn mode_cost(n_z: usize) -> f64 {
    0.5 * (n_z * n_z * n_z) as f64 + 4096.0
}

/// Work units of one guard evaluation on a state of `n` entries (a row times the state; the
/// crossing searches and the RK event checks make many per step).
pub fn guard_eval_cost(n: usize) -> f64 {
    2.0 * n as f64 + 8.0
}

/// The budget of a driver: its limit (`None`: unbounded, until a scope applies one) and the
/// propagator's cumulative work ([`crate::solve::work`]) where its scope started.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WorkBudget {
    limit: Option<f64>,
    start: f64,
}

impl WorkBudget {
    pub fn new(limit: Option<f64>) -> WorkBudget {
        WorkBudget { limit, start: 0.0 }
    }

    pub fn limit(&self) -> Option<f64> {
        self.limit
    }

    /// A new limit; the work spent in the scope so far counts against it.
    pub fn set_limit(&mut self, limit: f64) {
        self.limit = Some(limit);
    }

    /// Starts a new scope (an FMI call) where the propagator has done `work` in all.
    pub fn start_scope(&mut self, work: f64) {
        self.start = work;
    }

    /// The work spent in the scope, given the propagator's cumulative `work`.
    pub fn spent(&self, work: f64) -> f64 {
        work - self.start
    }

    /// The cumulative work of the propagator at which the scope's budget is spent.
    pub fn until(&self) -> Option<f64> {
        self.limit.map(|limit| self.start + limit)
    }
}

/// Work between two looks at the clock while a deadline holds ([`with_deadline`]): about
/// 25 ms of the costliest work per unit, so a run stops within that of its deadline.
pub const DEADLINE_CHECK_WORK: f64 = 1e7;

thread_local! {
    static DEADLINE: std::cell::Cell<Option<(std::time::Instant, f64)>> =
        const { std::cell::Cell::new(None) };
}

/// Runs `f` with a wall-clock limit of `seconds` on every run of a [`super::Driver`] it
/// makes on this thread (the Python module's per-point timeout of a study): a run still going
/// at the deadline stops with [`crate::solve::SolveError::OverBudget`] and a message naming
/// the limit. The work budget stays deterministic and is checked as before; the deadline
/// only adds a look at the clock every [`DEADLINE_CHECK_WORK`] units, where the propagator
/// stops and goes on exactly as after any budget scope. `None`: no limit.
pub fn with_deadline<R>(seconds: Option<f64>, f: impl FnOnce() -> R) -> R {
    let limit = seconds.map(|s| {
        let now = std::time::Instant::now();
        let end = std::time::Duration::try_from_secs_f64(s)
            .ok()
            .and_then(|d| now.checked_add(d))
            .unwrap_or(now + std::time::Duration::from_secs(u32::MAX as u64));
        (end, s)
    });
    Deadline(limit).run(f)
}

/// The deadline of this thread ([`with_deadline`]), to hand to the threads an analysis
/// spawns ([`Deadline::run`]), so that they stop at it too.
#[derive(Clone, Copy, Debug)]
pub struct Deadline(Option<(std::time::Instant, f64)>);

impl Deadline {
    /// This thread's deadline (none outside [`with_deadline`]).
    pub fn current() -> Deadline {
        Deadline(DEADLINE.with(|d| d.get()))
    }

    /// Runs `f` under this deadline on the calling thread.
    pub fn run<R>(self, f: impl FnOnce() -> R) -> R {
        struct Restore(Option<(std::time::Instant, f64)>);
        impl Drop for Restore {
            fn drop(&mut self) {
                DEADLINE.with(|d| d.set(self.0));
            }
        }
        let _restore = Restore(DEADLINE.with(|d| d.replace(self.0)));
        f()
    }
}

/// Whether a deadline of [`with_deadline`] holds on this thread.
pub fn deadline_set() -> bool {
    DEADLINE.with(|d| d.get().is_some())
}

/// The message of a passed deadline (`t`: the simulated time reached, NaN where the solve has
/// none), or `None` while it has not passed (or none is set).
pub fn deadline_passed(t: f64) -> Option<String> {
    let (end, seconds) = DEADLINE.with(|d| d.get())?;
    (std::time::Instant::now() >= end).then(|| {
        let at = if t.is_nan() {
            String::new()
        } else {
            format!(" at t = {t:e} s")
        };
        format!("the time limit of {seconds} s was reached{at} (the point's timeout; its solve was stopped there)")
    })
}

/// Checks a time limit in seconds (a study's `timeout`): finite and > 0.
pub fn check_deadline(field: &str, seconds: f64) -> Result<f64, String> {
    if seconds.is_finite() && seconds > 0.0 {
        Ok(seconds)
    } else {
        Err(format!(
            "{field} = {seconds}: the time limit must be a finite number of seconds > 0"
        ))
    }
}

/// Checks a budget value (scene key or FMU parameter): a finite number ≥ 1.
pub fn check_limit(field: &str, x: f64) -> Result<f64, String> {
    if x.is_finite() && x >= 1.0 {
        Ok(x)
    } else {
        Err(format!(
            "{field} = {x:e}: the work budget must be a finite number >= 1 (work units, \
             docs/fmu.md \"Work budget\")"
        ))
    }
}

/// What a driver knew when its budget ran out, to name the likely cause.
pub struct Exhaustion<'a> {
    pub limit: f64,
    /// The work spent in the scope, and the part of it the observers spent (the statistics
    /// evaluated on every segment or step, `docs/units.md`).
    pub spent: f64,
    pub observer_work: f64,
    /// Simulated time reached and the time the advance started from, s.
    pub t: f64,
    pub t_start: f64,
    /// Counters of the work spent in this budget's scope.
    pub work: SolverStats,
    /// The model's time scales: mesh frequency, speed, fastest rate.
    pub scales: &'a RunScales,
    /// Name of the propagator (`exact`, `dop853`, ...).
    pub method: &'a str,
    /// Whether the budget bounds one FMI call (else a whole run).
    pub per_call: bool,
}

/// The one message of an exhausted budget (FMU, `simulate` and Python alike): what was spent,
/// where the run stopped, the likely cause and how to go on.
pub fn exhausted_message(e: &Exhaustion) -> String {
    let w = &e.work;
    let steps = w.steps + w.rejected;
    let span = (e.t - e.t_start).max(0.0);
    let by_observer = observer_cause(e);
    let observed = match by_observer {
        None if e.observer_work > 0.0 && e.spent > 0.0 => format!(
            ", {:.0} % of the work by the statistics' observer",
            100.0 * e.observer_work / e.spent
        ),
        _ => String::new(),
    };
    let cause = by_observer.unwrap_or_else(|| likely_cause(e.scales, w, span));
    let remedy = if e.per_call {
        format!("shorten the communication step, or raise the parameter {BUDGET_KEY}")
    } else {
        format!(
            "raise {BUDGET_KEY} in the scene's [solver] table (or the command's \
             --work-budget, Python's work_budget=) if the run is meant to do this much work"
        )
    };
    format!(
        "the work budget of {:e} units was spent at t = {:e} s ({} steps with {}, {} events, {} \
         guard evaluations{observed}); likely cause: {cause}. Check the inputs, or {remedy} \
         (docs/fmu.md \"Work budget\")",
        e.limit, e.t, steps, e.method, w.events, w.guard_evals
    )
}

/// The statistics as the likely cause when their observer spent at least half of the work,
/// else `None` (the message then gives their share, where they took any, beside the counters).
fn observer_cause(e: &Exhaustion) -> Option<String> {
    if !(e.observer_work > 0.0 && e.spent > 0.0) {
        return None;
    }
    let share = e.observer_work / e.spent;
    (share >= 0.5).then(|| {
        format!(
            "the statistics: their observer (peak, RMS and contact loss evaluated on every \
             segment or step, docs/units.md) spent {:.0} % of the work ({:e} units), the \
             integration itself {:e}; a run without them (simulate --quiet, Python's \
             statistics=False) does only the integration",
            100.0 * share,
            e.observer_work,
            e.spent - e.observer_work
        )
    })
}

/// Which of the model's time scales holds the step: the fastest mode (stiffness), the mesh
/// period (speed), the events, or none of them (the step count itself: tolerance, or a
/// stiffness the model's bound does not see). `span` is the simulated time over which `stats` were spent.
pub fn likely_cause(scales: &RunScales, stats: &SolverStats, span: f64) -> String {
    let steps = (stats.steps + stats.rejected).max(1) as f64;
    let h = span / steps;
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
            "contact chatter: {} contact changes in {span:e} s ({field} = {speed:e} rad/s, mesh \
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
        "stiffness outside the model's frequency bound, or the tolerance: the mean step \
         {h:.3e} s is far below the mesh period ({mesh_period:.3e} s) and the period of the \
         fastest mode the model bounds ({mode_period:.3e} s, set by {source}); a stiff port or \
         shaft coupling (try solver.rk_method = \"rodas4\" or a softer value there) or a tight \
         tolerance (solver.rtol, solver.atol)"
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_deadline_holds_inside_its_scope_and_in_threads_handed_it() {
        assert!(!deadline_set() && deadline_passed(0.0).is_none());
        with_deadline(Some(1e-9), || {
            std::thread::sleep(std::time::Duration::from_millis(2));
            let message = deadline_passed(0.25).expect("passed");
            assert!(message.contains("time limit of 0.000000001 s was reached at t = 2.5e-1 s"));
            // A thread sees it only when handed it.
            let deadline = Deadline::current();
            std::thread::scope(|s| {
                assert!(s.spawn(|| !deadline_set()).join().unwrap());
                assert!(s.spawn(|| deadline.run(deadline_set)).join().unwrap());
            });
            with_deadline(None, || assert!(!deadline_set()));
            assert!(deadline_set());
        });
        assert!(!deadline_set());
        // A limit beyond what the clock can hold is no limit in practice, not a panic.
        with_deadline(Some(1e300), || assert!(deadline_passed(0.0).is_none()));
        assert!(check_deadline("timeout", 0.0).is_err());
        assert!(check_deadline("timeout", f64::NAN).is_err());
        assert_eq!(check_deadline("timeout", 2.5), Ok(2.5));
    }

    #[test]
    fn a_scope_ends_its_limit_after_its_start() {
        let mut b = WorkBudget::new(None);
        assert_eq!(b.until(), None);
        b.set_limit(1000.0);
        assert_eq!(b.until(), Some(1000.0));
        b.start_scope(1100.0);
        assert_eq!(b.spent(1150.0), 50.0);
        assert_eq!(b.until(), Some(2100.0));
    }

    #[test]
    fn limits_are_checked() {
        assert!(check_limit("solver.work_budget", 1e8).is_ok());
        for x in [0.0, 0.5, -1.0, f64::NAN, f64::INFINITY] {
            let e = check_limit("solver.work_budget", x).unwrap_err();
            assert!(e.contains("solver.work_budget"), "{e}");
        }
    }

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
        assert!(c.starts_with("contact chatter"), "{c}");
        // h = 1e-12 s, nothing in the model near it.
        let c = likely_cause(&scales(2850.0, 1e4), &stats(1_000_000, 0), 1e-6);
        assert!(c.starts_with("stiffness outside"), "{c}");
    }
}
