//! The propagator driver shared by the single pair ([`crate::simulation::Simulation`]) and the
//! drivetrain ([`crate::model::train::TrainSimulation`]): choosing between the exact and the RK
//! propagator, stepping, restarting and snapshotting are the same for any model, so they live
//! here once and the two simulations only add what their model makes different (construction,
//! inputs, outputs, the shape of their state).

use super::budget::{self, Exhaustion, WorkBudget};
use super::scales::RunScales;
use crate::scene::{MethodChoice, SolverSettings};
use crate::solve::exact::segment_series::SegmentObserver;
use crate::solve::exact::{ExactPropagator, PiecewiseLti};
use crate::solve::rk::StepObserver;
use crate::solve::rk::{ControllerMemory, RkOptions, RkStepper};
use crate::solve::work::WorkPrices;
use crate::solve::{SolveError, SolverStats};

/// What the driver needs from a model beyond its equations: the run-time state (mode, phase
/// clock, contact bookkeeping) that is not in `y` but decides how the run continues.
pub trait DrivenModel: PiecewiseLti + Clone {
    /// The model's part of a snapshot.
    type RunState;
    /// Why the exact propagator does not apply (a segment that is not LTI in the augmented
    /// state), worded as the reason a user reads; `None` when every segment is LTI.
    fn not_lti_reason(&self) -> Option<String>;
    /// Whether every segment is LTI, so the exact propagator applies.
    fn is_piecewise_lti(&self) -> bool {
        self.not_lti_reason().is_none()
    }
    /// Re-derives the mode from `(t, y)` after a jump of the state.
    fn resynchronise(&mut self, t: f64, y: &[f64]);
    fn run_state(&self) -> Self::RunState;
    /// Restores a run state; on failure the model is unchanged.
    fn restore_run_state(&mut self, s: &Self::RunState) -> Result<(), String>;
    /// The time scales that decide the work of a run, checked against
    /// [`crate::simulation::RunLimits`] before a streamed run starts.
    fn run_scales(&self) -> RunScales;
    /// Whether advancing from `t` to `t_end` stays within the limits of one advance: each
    /// mesh clock's [`crate::model::PhaseClock::check_advance`]. O(1) per mesh.
    fn check_advance(&self, t: f64, t_end: f64) -> Result<(), String>;
    /// The scene's speed and torque profiles (a run-up, `docs/runup.md`), if it has any: the
    /// driver stops at their knots and calls [`DrivenModel::apply_profiles`] there.
    fn profiles(&self) -> Option<&crate::scene::Profiles>;
    /// Sets speed, torque and their rates to the profile pieces that start at `t` (phases
    /// continuous).
    fn apply_profiles(&mut self, t: f64) -> Result<(), String>;
    /// Why this run-up is not piecewise LTI although its constant-speed scene would be (the
    /// excitation a profile makes time-varying within a segment), or `None`.
    fn runup_not_lti(&self) -> Option<String>;
    /// The time of the next switch that is a state event known ahead only by the motion (a
    /// stiffness knot on a carried angle), predicted from `(t, y)`; `+inf` (the default)
    /// where the model has none.
    fn predicted_switch(&self, _t: f64, _y: &[f64]) -> f64 {
        f64::INFINITY
    }
}

/// Largest augmented state the exact propagator accepts: its mode cache holds dense `n × n`
/// matrices (transitions, guard series), `8n²` bytes each, so the size is checked before
/// anything is allocated; 2048 is 34 MB per matrix.
pub const MAX_EXACT_DIM: usize = 2048;

/// The counters the message of an exhausted budget reports, where its scope started.
#[derive(Debug, Clone, Copy, Default)]
struct ScopeCounts {
    steps: u64,
    rejected: u64,
    events: u64,
    guard_evals: u64,
    /// The observers' work ([`SegmentObserver`], [`StepObserver`]: the statistics).
    observer_work: f64,
}

impl ScopeCounts {
    fn of(s: &SolverStats, observer_work: f64) -> ScopeCounts {
        ScopeCounts {
            steps: s.steps,
            rejected: s.rejected,
            events: s.events,
            guard_evals: s.guard_evals,
            observer_work,
        }
    }
}

/// A stop this close after the current time (relative to the time) is a switch at the current
/// time: an output grid's `k·h` and a clock's `t = (k + b − p₀)/f` carry a few roundings of `t`
/// each.
pub const SWITCH_AT_NOW: f64 = 64.0 * f64::EPSILON;

/// The propagator actually used.
pub enum Propagator {
    Rk(Box<RkStepper>),
    Exact(Box<ExactPropagator>),
}

/// A running simulation: the model (which holds the mode) and its propagator (which holds
/// `(t, y)`).
pub struct Driver<M> {
    model: M,
    propagator: Propagator,
    note: Option<String>,
    choice: String,
    /// The work budget ([`super::budget`]): per run unless the owner resets it per call.
    /// The propagator meters the work and stops at the budget's end itself.
    budget: WorkBudget,
    /// Time and counters at the start of the budget's scope (for its message), and whether
    /// the scope is one call ([`Driver::reset_work`] was called) rather than the whole run.
    scope: (f64, ScopeCounts),
    per_call: bool,
    /// Whether the driver was made under a deadline ([`budget::with_deadline`]), read once so
    /// an advance without one pays nothing for it.
    timed: bool,
    /// Under a deadline: the propagator's cumulative work at which to look at the clock next.
    clock_check: f64,
}

impl<M: DrivenModel> Driver<M> {
    /// Picks the propagator (`auto`: exact when the model is piecewise LTI) and starts at
    /// `t = 0` from `y0`. `method = exact` on a model that is not piecewise LTI is refused with
    /// the model's reason ([`DrivenModel::not_lti_reason`]); [`Driver::method_choice`] says
    /// what was chosen and why.
    pub fn with_model(
        model: M,
        y0: &[f64],
        settings: &SolverSettings,
    ) -> Result<Driver<M>, String> {
        let runup = model.runup_not_lti();
        let not_lti = model.not_lti_reason();
        let exact = match settings.method {
            MethodChoice::Exact => {
                if let Some(reason) = &runup {
                    return Err(format!(
                        "solver.method = \"exact\": {reason}; use \"rk\" or \"auto\""
                    ));
                }
                if let Some(reason) = &not_lti {
                    return Err(format!(
                        "solver.method = \"exact\": {reason} (use rk or auto)"
                    ));
                }
                true
            }
            MethodChoice::Auto => runup.is_none() && not_lti.is_none(),
            MethodChoice::Rk => false,
        };
        let note = match (&runup, settings.method) {
            (Some(reason), MethodChoice::Auto) if not_lti.is_none() => {
                Some(format!("auto chose RK: {reason}"))
            }
            _ => None,
        };
        let rk_name = settings.rk_method.to_string();
        let choice = match settings.method {
            MethodChoice::Exact => "exact (solver.method = exact)".to_owned(),
            MethodChoice::Rk => format!("{rk_name} (solver.method = rk)"),
            MethodChoice::Auto => match (&not_lti, &runup) {
                (None, None) => "exact (auto: every segment is linear time-invariant)".to_owned(),
                (Some(reason), _) => format!("{rk_name} (auto: exact refused: {reason})"),
                (None, Some(reason)) => format!("{rk_name} (auto: exact refused: {reason})"),
            },
        };
        let dim = model.lti_dim();
        if exact && dim > MAX_EXACT_DIM && settings.method == MethodChoice::Auto {
            let reason = format!(
                "the augmented state has {dim} entries, above the exact propagator's limit of \
                 {MAX_EXACT_DIM} (dense {dim}×{dim} matrices)"
            );
            let mut settings = settings.clone();
            settings.method = MethodChoice::Rk;
            let mut driver = Self::with_model(model, y0, &settings)?;
            driver.choice = format!("{rk_name} (auto: exact refused: {reason})");
            return Ok(driver);
        }
        if exact && dim > MAX_EXACT_DIM {
            return Err(format!(
                "the exact propagator would hold {dim}×{dim} matrices ({:.0} MB each) for this \
                 scene's {dim} augmented states (the state plus two per STE harmonic); the limit is \
                 {MAX_EXACT_DIM}: use solver.method = \"rk\"",
                (dim * dim * 8) as f64 / 1e6
            ));
        }
        // Unset, a driver's advances are unbounded until its owner applies the default of its
        // scope: one FMI call (the FMU adapter) or one streamed run (`stream`).
        let limit = match settings.work_budget {
            Some(x) => Some(budget::check_limit(budget::BUDGET_KEY, x)?),
            None => None,
        };
        let propagator = if exact {
            let nz = model.lti_dim();
            let mut p = ExactPropagator::new(&model);
            if let Some(bytes) = settings.exact_memory {
                let one_mode = ExactPropagator::mode_bytes_estimate(nz);
                if one_mode > bytes {
                    return Err(format!(
                        "solver.exact_memory_mb = {}: one mode of this scene ({nz} augmented \
                         states) takes about {:.1} MiB in the exact propagator's mode cache \
                         (its matrix, exponentials and duration bins), more than the cache may \
                         hold: raise solver.exact_memory_mb or use solver.method = \"rk\"",
                        bytes as f64 / (1u64 << 20) as f64,
                        one_mode as f64 / (1u64 << 20) as f64
                    ));
                }
                p.set_memory_budget(bytes);
            }
            p.set_state(0.0, y0);
            p.set_work_prices(WorkPrices {
                step: budget::segment_cost(nz),
                guard_eval: budget::guard_eval_cost(nz),
                mode: budget::mode_cost(nz),
            });
            Propagator::Exact(Box::new(p))
        } else {
            let options = RkOptions {
                rtol: settings.rtol,
                atol: settings.atol,
                ..RkOptions::new(settings.rk_method)
            };
            let mut p = RkStepper::new(options, y0.len())?;
            p.set_state(0.0, y0);
            p.set_work_prices(WorkPrices {
                step: budget::rk_step_cost(y0.len()),
                guard_eval: budget::guard_eval_cost(y0.len()),
                mode: 0.0,
            });
            Propagator::Rk(Box::new(p))
        };
        let mut driver = Driver {
            model,
            propagator,
            note,
            choice,
            budget: WorkBudget::new(limit),
            scope: (0.0, ScopeCounts::default()),
            per_call: false,
            timed: budget::deadline_set(),
            clock_check: 0.0,
        };
        driver.apply_work_limit();
        Ok(driver)
    }

    /// The method in use and why it was chosen, e.g. `exact (auto: every segment is linear
    /// time-invariant)` or `dop853 (auto: exact refused: <reason>)`.
    pub fn method_choice(&self) -> &str {
        &self.choice
    }

    /// Why `auto` did not choose the exact propagator for a scene whose constant-speed form it
    /// would have (a run-up that makes the excitation time-varying within a segment).
    pub fn method_note(&self) -> Option<&str> {
        self.note.as_deref()
    }

    /// Name of the propagator in use (`exact`, `dp5`, `dop853`).
    pub fn method_name(&self) -> String {
        match &self.propagator {
            Propagator::Exact(_) => "exact".into(),
            Propagator::Rk(p) => p.options().method.to_string(),
        }
    }

    pub fn t(&self) -> f64 {
        match &self.propagator {
            Propagator::Rk(p) => p.t(),
            Propagator::Exact(p) => p.t(),
        }
    }

    /// The model's next known switch of its equations (a stiffness or gap breakpoint; a
    /// time, not a state event) after the current segment's start, `+inf` when none: a
    /// co-simulation master may end a communication step there (`docs/cosimulation.md`,
    /// "Steps that end at the stage's knots").
    pub fn next_stop(&self) -> f64 {
        self.model.next_stop()
    }

    /// The earlier of [`Driver::next_stop`] and the model's predicted next state-event switch
    /// ([`DrivenModel::predicted_switch`]).
    pub fn next_switch(&self) -> f64 {
        self.next_stop()
            .min(self.model.predicted_switch(self.t(), self.y()))
    }

    /// The model's next stop (a stiffness or gap breakpoint) when it lies within the rounding
    /// of the current time after it: the current time is that switching instant, and a result
    /// taken now reports the state after the switch once the caller advances to the stop
    /// (issue 31 item 4, `docs/reference.md`). The one rule behind `simulate`'s rows
    /// ([`super::stream`]) and the FMU's communication points. The state is continuous across
    /// the stop; only the mode changes.
    pub fn switch_at_now(&self) -> Option<f64> {
        let stop = self.model.next_stop();
        let now = self.t();
        (stop > now && stop - now <= SWITCH_AT_NOW * now.abs()).then_some(stop)
    }

    /// The continuous state at [`Driver::t`].
    pub fn y(&self) -> &[f64] {
        match &self.propagator {
            Propagator::Rk(p) => p.y(),
            Propagator::Exact(p) => p.y(),
        }
    }

    pub fn stats(&self) -> SolverStats {
        match &self.propagator {
            Propagator::Rk(p) => *p.stats(),
            Propagator::Exact(p) => *p.stats(),
        }
    }

    pub fn model(&self) -> &M {
        &self.model
    }

    /// The limit of the work budget (`None`: unbounded).
    pub fn work_limit(&self) -> Option<f64> {
        self.budget.limit()
    }

    /// The work spent in the budget's scope, in work units ([`super::budget`]).
    pub fn work_spent(&self) -> f64 {
        self.budget.spent(self.work())
    }

    /// The propagator's cumulative work.
    fn work(&self) -> f64 {
        match &self.propagator {
            Propagator::Rk(p) => p.work(),
            Propagator::Exact(p) => p.work(),
        }
    }

    /// Hands the end of the budget's scope to the propagator, which stops there.
    fn apply_work_limit(&mut self) {
        let until = self.budget.until();
        match &mut self.propagator {
            Propagator::Rk(p) => p.set_work_limit(until),
            Propagator::Exact(p) => p.set_work_limit(until),
        }
    }

    /// A new limit of the work budget (checked: a finite number >= 1).
    pub fn set_work_budget(&mut self, limit: f64) -> Result<(), String> {
        self.budget
            .set_limit(budget::check_limit(budget::BUDGET_KEY, limit)?);
        self.apply_work_limit();
        Ok(())
    }

    /// Applies `limit` unless the scene set `solver.work_budget` (which then stays).
    pub fn default_work_budget(&mut self, limit: f64) {
        if self.budget.limit().is_none() {
            self.budget.set_limit(limit);
            self.apply_work_limit();
        }
    }

    /// Starts a new budget scope of one run within an analysis (a sweep point): the run
    /// budget then bounds each such run, as it bounds a streamed run.
    pub fn new_run_scope(&mut self) {
        self.reset_work();
        self.per_call = false;
    }

    /// Starts a new budget scope: an FMU calls this at the start of every call, so the
    /// budget bounds each call; a run that never calls it is bounded as a whole. The
    /// propagator computes its cumulative work once and returns it as the scope's start.
    pub fn reset_work(&mut self) {
        let limit = self.budget.limit();
        let start = match &mut self.propagator {
            Propagator::Rk(p) => {
                self.scope = (p.t(), ScopeCounts::of(p.stats(), p.observer_work()));
                p.start_work_scope(limit)
            }
            Propagator::Exact(p) => {
                self.scope = (p.t(), ScopeCounts::of(p.stats(), p.observer_work()));
                p.start_work_scope(limit)
            }
        };
        self.budget.start_scope(start);
        self.per_call = true;
    }

    /// Mutable access to the model for settings that do not change its equations (e.g.
    /// recording events); changes that do go through [`Driver::change_model`].
    pub fn model_mut(&mut self) -> &mut M {
        &mut self.model
    }

    /// Integrates exactly to `t_end` with the inputs held constant. An advance beyond the
    /// documented limits of one advance (mesh periods, phase and time resolution:
    /// [`DrivenModel::check_advance`]) is refused before any work, the state unchanged
    /// (issue 17: no step may grind without end or run on a phase that no longer advances).
    ///
    /// With speed or torque profiles, the advance stops at every knot where a slope changes
    /// and the model takes the next pieces there ([`DrivenModel::apply_profiles`]); the
    /// profiles are thus followed exactly, whatever the output grid.
    #[inline]
    pub fn advance_to(&mut self, t_end: f64) -> Result<(), SolveError> {
        if self.model.profiles().is_some() {
            return self.advance_with_profiles(t_end);
        }
        self.advance_plain(t_end)
    }

    /// [`Driver::advance_to`] through the knots of the scene's profiles.
    #[inline(never)]
    fn advance_with_profiles(&mut self, t_end: f64) -> Result<(), SolveError> {
        let Some(profiles) = self.model.profiles() else {
            return self.advance_plain(t_end);
        };
        let mut knot = profiles.next_change(self.t());
        // A knot at t_end is taken now: the next advance starts after it.
        while knot <= t_end {
            self.advance_plain(knot)?;
            let t = self.t();
            self.change_model(|m, t| m.apply_profiles(t))
                .map_err(|reason| SolveError::BeyondLimits { t, reason })?;
            knot = self
                .model
                .profiles()
                .map_or(f64::INFINITY, |p| p.next_change(t));
        }
        self.advance_plain(t_end)
    }

    #[inline(always)]
    fn advance_plain(&mut self, t_end: f64) -> Result<(), SolveError> {
        let t = self.t();
        if t_end != t {
            if let Err(reason) = self.model.check_advance(t, t_end) {
                return Err(SolveError::BeyondLimits { t, reason });
            }
        }
        // The propagator meters its work and stops where the budget's scope ends
        // (`start_work_scope`): nothing to do here per advance but word that stop, in place
        // (the result is not moved on the common path).
        let mut result = if self.timed {
            self.under_deadline(|d| match &mut d.propagator {
                Propagator::Rk(p) => p.advance_to(&mut d.model, t_end),
                Propagator::Exact(p) => p.advance_to(&mut d.model, t_end),
            })
        } else {
            match &mut self.propagator {
                Propagator::Rk(p) => p.advance_to(&mut self.model, t_end),
                Propagator::Exact(p) => p.advance_to(&mut self.model, t_end),
            }
        };
        // (A passed deadline's stop comes worded already.)
        if let Err(e @ SolveError::OverBudget { .. }) = &mut result {
            if matches!(e, SolveError::OverBudget { message, .. } if !message.is_empty()) {
                return result;
            }
            *e = self.over_budget();
        }
        result
    }

    /// [`Driver::advance_to`] that hands every segment of the exact propagator to
    /// `observer`, with the model in the segment's mode ([`SegmentObserver`]: the state
    /// anywhere inside a segment without re-integration). `Ok(false)`, nothing advanced,
    /// where the run has no such segments: on the RK propagator, or with speed or torque
    /// profiles (the caller then samples the run itself).
    pub fn advance_observed<O: SegmentObserver<M>>(
        &mut self,
        t_end: f64,
        observer: &mut O,
    ) -> Result<bool, SolveError> {
        if !self.observes_segments() {
            return Ok(false);
        }
        self.check_observed_advance(t_end)?;
        let result = self.under_deadline(|d| match &mut d.propagator {
            Propagator::Exact(p) => p.advance_observed(&mut d.model, t_end, observer),
            Propagator::Rk(_) => unreachable!("observes_segments: the exact propagator"),
        });
        self.observed(result)
    }

    /// [`DrivenModel::check_advance`] of an observed advance from now to `t_end`.
    fn check_observed_advance(&self, t_end: f64) -> Result<(), SolveError> {
        let t = self.t();
        if t_end != t {
            if let Err(reason) = self.model.check_advance(t, t_end) {
                return Err(SolveError::BeyondLimits { t, reason });
            }
        }
        Ok(())
    }

    /// The result of an observed advance: `true`, or the error with an exhausted budget's
    /// message naming the likely cause.
    fn observed(&self, result: Result<(), SolveError>) -> Result<bool, SolveError> {
        match result {
            Err(e @ SolveError::OverBudget { .. }) if matches!(&e, SolveError::OverBudget { message, .. } if !message.is_empty()) => {
                Err(e)
            }
            Err(SolveError::OverBudget { .. }) => Err(self.over_budget()),
            other => other.map(|()| true),
        }
    }

    /// Whether [`Driver::advance_observed`] observes this run's segments.
    pub fn observes_segments(&self) -> bool {
        self.model.profiles().is_none() && matches!(self.propagator, Propagator::Exact(_))
    }

    /// [`Driver::advance_observed`] on the exact propagator; on the RK propagator the same
    /// advance handing every accepted step with its dense output to `observer`
    /// ([`StepObserver`]). `Ok(false)`, nothing advanced, with speed or torque profiles.
    pub fn advance_observed_steps<O: SegmentObserver<M> + StepObserver<M>>(
        &mut self,
        t_end: f64,
        observer: &mut O,
    ) -> Result<bool, SolveError> {
        if matches!(self.propagator, Propagator::Exact(_)) {
            return self.advance_observed(t_end, observer);
        }
        if !self.observes_steps() {
            return Ok(false);
        }
        self.check_observed_advance(t_end)?;
        let result = self.under_deadline(|d| match &mut d.propagator {
            Propagator::Rk(p) => p.advance_observed(&mut d.model, t_end, observer),
            Propagator::Exact(_) => unreachable!("matched above: the RK propagator"),
        });
        self.observed(result)
    }

    /// Runs `advance` (one advance of the propagator) under this thread's deadline
    /// ([`budget::with_deadline`]), if one holds: the propagator stops every
    /// [`budget::DEADLINE_CHECK_WORK`] units (at a step or segment end, as at the end of a
    /// budget scope) for a look at the clock and then goes on, so the run takes the same steps
    /// as without the deadline. A passed deadline ends the advance with its message.
    fn under_deadline(
        &mut self,
        mut advance: impl FnMut(&mut Self) -> Result<(), SolveError>,
    ) -> Result<(), SolveError> {
        if !self.timed {
            return advance(self);
        }
        let until = self.budget.until();
        loop {
            let work = self.work();
            if work >= self.clock_check {
                if let Some(message) = budget::deadline_passed(self.t()) {
                    return Err(SolveError::OverBudget {
                        t: self.t(),
                        message,
                    });
                }
                self.clock_check = work + budget::DEADLINE_CHECK_WORK;
            }
            let at_check = until.is_none_or(|u| self.clock_check < u);
            self.set_propagator_limit(if at_check {
                Some(self.clock_check)
            } else {
                until
            });
            let result = advance(self);
            self.set_propagator_limit(until);
            match result {
                // The stop to look at the clock (the next pass looks).
                Err(SolveError::OverBudget { .. })
                    if at_check && self.work() >= self.clock_check => {}
                other => return other,
            }
        }
    }

    fn set_propagator_limit(&mut self, until: Option<f64>) {
        match &mut self.propagator {
            Propagator::Rk(p) => p.set_work_limit(until),
            Propagator::Exact(p) => p.set_work_limit(until),
        }
    }

    /// Whether [`Driver::advance_observed_steps`] observes this run (segments or steps: any
    /// run without speed or torque profiles).
    pub fn observes_steps(&self) -> bool {
        self.model.profiles().is_none()
    }

    /// The error of an exhausted budget, with the message naming the likely cause.
    #[cold]
    #[inline(never)]
    fn over_budget(&self) -> SolveError {
        let t = self.t();
        let mut work = self.stats();
        let start = &self.scope.1;
        work.steps -= start.steps.min(work.steps);
        work.rejected -= start.rejected.min(work.rejected);
        work.events -= start.events.min(work.events);
        work.guard_evals -= start.guard_evals.min(work.guard_evals);
        let observer = match &self.propagator {
            Propagator::Rk(p) => p.observer_work(),
            Propagator::Exact(p) => p.observer_work(),
        } - start.observer_work;
        let scales = self.model.run_scales();
        let message = budget::exhausted_message(&Exhaustion {
            limit: self.budget.limit().unwrap_or(f64::INFINITY),
            spent: self.work_spent(),
            observer_work: observer.max(0.0),
            t,
            t_start: self.scope.0,
            work,
            scales: &scales,
            method: &self.method_name(),
            per_call: self.per_call,
        });
        SolveError::OverBudget { t, message }
    }

    /// Applies `change(model, t)`, which alters the right-hand side from the current time on
    /// (new inputs), and on success drops the propagator's cached matrices and FSAL stage.
    /// On failure the model is expected unchanged, so nothing is dropped.
    pub fn change_model<E>(
        &mut self,
        change: impl FnOnce(&mut M, f64) -> Result<(), E>,
    ) -> Result<(), E> {
        let t = self.t();
        change(&mut self.model, t)?;
        match &mut self.propagator {
            Propagator::Rk(p) => p.invalidate(),
            Propagator::Exact(p) => p.invalidate(),
        }
        Ok(())
    }

    /// Drops what the exact propagator learned from recurring segments (see
    /// [`crate::solve::exact::ExactPropagator::forget_recurrences`]): called when a state is
    /// captured, so that the run continues from it as it would from the restored state.
    pub fn forget_recurrences(&mut self) {
        if let Propagator::Exact(p) = &mut self.propagator {
            p.forget_recurrences();
        }
    }

    /// [`Driver::forget_recurrences`] before the next advance, for a snapshot that only reads
    /// the run: the run then continues from the captured state as a restored one does.
    pub fn forget_before_next_advance(&self) {
        if let Propagator::Exact(p) = &self.propagator {
            p.forget_before_next_advance();
        }
    }

    /// Switches the exact propagator's recurring-segment decisions on (the default) or off
    /// (every segment gets the full crossing search); no effect on the RK path.
    pub fn use_recurrences(&mut self, on: bool) {
        if let Propagator::Exact(p) = &mut self.propagator {
            p.use_recurrences(on);
        }
    }

    /// Switches the exact propagator's composite transitions of recurring guard-free
    /// sequences on (the default) or off (every segment applied on its own); no effect on
    /// the RK path.
    pub fn use_composites(&mut self, on: bool) {
        if let Propagator::Exact(p) = &mut self.propagator {
            p.use_composites(on);
        }
    }

    /// Composite products built and sequences applied as one product by the exact
    /// propagator (`(0, 0)` on the RK path).
    pub fn composite_counts(&self) -> (u64, u64) {
        match &self.propagator {
            Propagator::Exact(p) => p.composite_counts(),
            Propagator::Rk(_) => (0, 0),
        }
    }

    /// The exact propagator's mode-cache memory (`None` on the RK path): bytes held now
    /// (recounted), the most held, and the budget (`solver.exact_memory_mb`).
    pub fn cache_memory(&mut self) -> Option<crate::solve::exact::CacheMemory> {
        match &mut self.propagator {
            Propagator::Exact(p) => Some(p.memory()),
            Propagator::Rk(_) => None,
        }
    }

    /// Modes built and full mode caches cleared by the exact propagator (`(0, 0)` on the RK
    /// path).
    pub fn mode_counts(&self) -> (u64, u64) {
        match &self.propagator {
            Propagator::Exact(p) => p.mode_counts(),
            Propagator::Rk(_) => (0, 0),
        }
    }

    /// Restarts from `(t, y)` with the mode re-derived from the state (FMU state restore and
    /// initial-value changes).
    pub fn set_y(&mut self, t: f64, y: &[f64]) {
        self.model.resynchronise(t, y);
        match &mut self.propagator {
            Propagator::Rk(p) => p.set_state(t, y),
            Propagator::Exact(p) => {
                p.invalidate();
                p.set_state(t, y)
            }
        }
    }

    /// Restarts at `(t, y)` with the model's run state `run`, captured from a driver of the
    /// same model with the same inputs, keeping the propagator's per-mode operators: the
    /// probes of a recording (`analysis::orbit_statistics`) go back to a cell's start many
    /// times. Not bit-identical to the run the state came from (a capture is,
    /// [`Driver::resume`]); on failure nothing changes.
    pub fn restart(&mut self, t: f64, y: &[f64], run: &M::RunState) -> Result<(), String> {
        self.model.restore_run_state(run)?;
        match &mut self.propagator {
            Propagator::Rk(p) => p.set_state(t, y),
            Propagator::Exact(p) => p.set_state(t, y),
        }
        Ok(())
    }

    /// The RK controller memory, `None` for the exact propagator, whose steps depend on
    /// `(t, y)` and the mode only (and, in the last bits of event times, on the recurring
    /// segments it learned, which a capture drops: [`Driver::forget_recurrences`]).
    pub fn controller_memory(&self) -> Option<ControllerMemory> {
        match &self.propagator {
            Propagator::Rk(p) => Some(p.controller_memory()),
            Propagator::Exact(_) => None,
        }
    }

    /// Continues from a snapshot `(t, y, run, controller)` taken from a driver of the same
    /// scene, bit-identically to the run it was taken from (FMU state get/set, FMI 2.0.x
    /// §2.1.8). Rejects a state of another dimension, a non-finite one, one taken with the
    /// other propagator, or a run state the model cannot have; on failure nothing changes.
    pub fn resume(
        &mut self,
        t: f64,
        y: &[f64],
        run: &M::RunState,
        controller: Option<&ControllerMemory>,
    ) -> Result<(), String> {
        let dim = self.y().len();
        if y.len() != dim {
            return Err(format!(
                "the state has {} entries, this model {dim}",
                y.len()
            ));
        }
        if !(t.is_finite() && y.iter().all(|v| v.is_finite())) {
            return Err(format!("state (t = {t}, y = {y:?}) is not finite"));
        }
        // The run state's clocks must also hold at `t` (phase and time within the limits of
        // an advance), and on failure nothing may change. `restore_run_state` changes nothing
        // when it fails; a state its clocks refuse is undone by the run state taken before,
        // which is cheaper than restoring into a copy of the whole model (an FMU master
        // restores at every undone communication step, docs/cosimulation.md).
        let model = &mut self.model;
        let mut restored = || -> Result<(), String> {
            let before = model.run_state();
            model.restore_run_state(run)?;
            if let Err(e) = model.check_advance(t, t) {
                model
                    .restore_run_state(&before)
                    .map_err(|back| format!("the model's own run state did not restore: {back}"))?;
                return Err(format!("at the state's time t = {t:e} s: {e}"));
            }
            Ok(())
        };
        match (&mut self.propagator, controller) {
            (Propagator::Rk(p), Some(memory)) => {
                restored()?;
                p.invalidate();
                p.restore(t, y, memory);
            }
            (Propagator::Exact(p), None) => {
                restored()?;
                p.invalidate();
                p.set_state(t, y);
            }
            _ => {
                return Err(format!(
                    "the snapshot was taken with another propagator than '{}'",
                    self.method_name()
                ))
            }
        }
        Ok(())
    }

    /// Advances through the points of `times` (an [`crate::simulation::OutputGrid`]) and
    /// hands each point to `row(self, t)` as soon as it is reached, so that nothing is held
    /// between points (the rows are streamed by [`crate::simulation::stream`]).
    pub fn sample(
        &mut self,
        times: impl IntoIterator<Item = f64>,
        mut row: impl FnMut(&Self, f64) -> Result<(), String>,
    ) -> Result<(), String> {
        for t in times {
            self.advance_to(t)
                .map_err(|e| format!("integration failed: {e}"))?;
            row(self, t)?;
        }
        Ok(())
    }
}
