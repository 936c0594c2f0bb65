//! Runge–Kutta methods with dense output, PI step control, stops and event location.
//!
//! Methods: Dormand–Prince 5(4) (Dormand & Prince 1980, J. Comput. Appl. Math. 6:19–26) and
//! DOP853 (Hairer, Nørsett & Wanner, *Solving ODEs I*, 2nd ed. 1993, §II.10), both with
//! Hairer's continuous extensions (§II.6) and step-size control (§II.4); and the linearly
//! implicit, L-stable RODAS4 (Hairer & Wanner, *Solving ODEs II*, §IV.7, [`rosenbrock`]) for
//! stiff scenes, driven by the same step loop (stops, events on its dense output, grazing).
//!
//! [`RkStepper`] is stateful so that a co-simulation master calling [`RkStepper::advance_to`]
//! once per communication step keeps the step-size proposal, the PI-controller memory and the
//! FSAL stage: a communication point costs nothing beyond the (possibly shortened) last step.
//!
//! Hybrid discipline ([`HybridSystem`]): the stepper never evaluates the right-hand side past
//! `min(t_end, sys.next_stop())`, lands on stops bit-exactly, and locates state events on the
//! interpolant of each accepted step (see [`event`]).

mod control;
mod dense;
mod event;
mod graze;
mod observe;
mod rosenbrock;
#[cfg(test)]
mod rosenbrock_tests;
mod tableau;
#[cfg(test)]
mod tableau_tests;

use std::fmt;
use std::str::FromStr;

use super::work::{self, WorkPrices};
use super::{HybridSystem, SolveError, SolverStats};
use control::Controller;
use rosenbrock::LinearlyImplicit;
use tableau::Tableau;

pub use observe::{DenseStep, StepObserver};

/// The Runge–Kutta pair.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Method {
    /// Dormand–Prince 5(4), FSAL, 6 evaluations per step, free 4th-order dense output.
    Dp5,
    /// Hairer's DOP853 8(5,3): 12 evaluations per accepted step, 7th-order dense output at 3
    /// more evaluations (computed only when events or dense output need it).
    Dop853,
    /// RODAS4 4(3), L-stable and stiffly accurate Rosenbrock method: one LU of
    /// `I/(hγ) − J` and 6 evaluations per step, free 3rd-order dense output. For stiff scenes
    /// (a step size limited by stability, not accuracy, for the explicit pairs).
    Rodas4,
}

impl Method {
    /// Every method, in the order of their names in error messages.
    pub const ALL: [Method; 3] = [Method::Dp5, Method::Dop853, Method::Rodas4];
    /// The explicit pairs (those with a Butcher tableau).
    pub const EXPLICIT: [Method; 2] = [Method::Dp5, Method::Dop853];

    /// Canonical name (what [`FromStr`] accepts and [`fmt::Display`] prints).
    pub fn name(self) -> &'static str {
        match self {
            Method::Dp5 => "dp5",
            Method::Dop853 => "dop853",
            Method::Rodas4 => "rodas4",
        }
    }

    /// Order of the propagated solution.
    pub fn order(self) -> u32 {
        self.tableau().map_or(4, |t| t.order)
    }

    /// Order of the dense output.
    pub fn dense_order(self) -> u32 {
        self.tableau().map_or(3, |t| t.dense_order)
    }

    /// Whether the method is linearly implicit (needs `∂f/∂y`: the system's, or differences).
    pub fn is_implicit(self) -> bool {
        self.tableau().is_none()
    }

    /// The Butcher tableau of an explicit pair; `None` for the Rosenbrock method.
    fn tableau(self) -> Option<&'static Tableau> {
        match self {
            Method::Dp5 => Some(&tableau::DP5),
            Method::Dop853 => Some(&tableau::DOP853),
            Method::Rodas4 => None,
        }
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Method {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Method::ALL
            .into_iter()
            .find(|m| m.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| {
                format!("unknown integration method \"{s}\" (expected dp5, dop853 or rodas4)")
            })
    }
}

/// Integrator settings. All are validated by [`RkOptions::validate`]; nothing is clamped.
#[derive(Debug, Clone, PartialEq)]
pub struct RkOptions {
    pub method: Method,
    /// Relative tolerance (> 10 ε).
    pub rtol: f64,
    /// Absolute tolerance (> 0; pure relative control would divide by zero at `y_i = 0`).
    pub atol: f64,
    /// First step size; `None` uses Hairer's heuristic (HNW I §II.4, `hinit`).
    pub h_init: Option<f64>,
    /// Largest step size (may be `f64::INFINITY`).
    pub h_max: f64,
    /// Largest number of step attempts (accepted + rejected) in one `advance_to` call.
    pub max_steps: u64,
    /// Interior points of each step's interpolant where guards are sampled in addition to the
    /// step end, to catch an even number of sign changes within a step (grazing contact).
    /// Used only for guards the system does not declare affine
    /// ([`HybridSystem::affine_guard`]); affine guards are bounded along the whole interpolant
    /// instead and need no samples.
    pub guard_samples: usize,
    /// Build the interpolant of every accepted step even without guards, so that
    /// [`RkStepper::dense`] is available (for DOP853 this costs 3 evaluations per step).
    pub dense_output: bool,
}

impl Default for RkOptions {
    fn default() -> Self {
        RkOptions {
            method: Method::Dp5,
            rtol: 1e-6,
            atol: 1e-9,
            h_init: None,
            h_max: f64::INFINITY,
            max_steps: 1_000_000,
            guard_samples: 4,
            dense_output: false,
        }
    }
}

impl RkOptions {
    /// Default settings for `method`.
    pub fn new(method: Method) -> Self {
        RkOptions {
            method,
            ..RkOptions::default()
        }
    }

    /// Checks every field; the message names the field and its value.
    pub fn validate(&self) -> Result<(), String> {
        let min_rtol = 10.0 * f64::EPSILON;
        if !(self.rtol.is_finite() && self.rtol > 0.0) {
            return Err(format!("rtol = {} must be > 0 and finite", self.rtol));
        }
        if self.rtol < min_rtol {
            return Err(format!(
                "rtol = {:e} must be >= {:e} (10 machine epsilons)",
                self.rtol, min_rtol
            ));
        }
        if !(self.atol.is_finite() && self.atol > 0.0) {
            return Err(format!("atol = {} must be > 0 and finite", self.atol));
        }
        if let Some(h) = self.h_init {
            if !(h.is_finite() && h > 0.0) {
                return Err(format!("h_init = {h} must be > 0 and finite"));
            }
        }
        if self.h_max.is_nan() || self.h_max <= 0.0 {
            return Err(format!("h_max = {} must be > 0", self.h_max));
        }
        if self.max_steps == 0 {
            return Err("max_steps = 0 must be > 0".to_string());
        }
        Ok(())
    }
}

/// Consecutive state events allowed without time progress before [`SolveError::EventStorm`].
const MAX_EVENTS_WITHOUT_PROGRESS: u64 = 100;
/// Consecutive steps with a non-finite trial solution before [`SolveError::NonFinite`].
const MAX_NONFINITE_TRIALS: u32 = 30;
/// A step ending within this factor of a stop is stretched onto it.
const STRETCH: f64 = 1.01;

/// Stateful Runge–Kutta (explicit or Rosenbrock) integrator for a [`HybridSystem`].
///
/// All buffers are allocated in [`RkStepper::new`]; the step loop does not allocate (guard
/// buffers grow only when a mode reports more guards than ever before).
#[derive(Debug, Clone)]
pub struct RkStepper {
    opts: RkOptions,
    /// The explicit pair's tableau; `None` for the Rosenbrock method, which has `implicit`.
    tab: Option<&'static Tableau>,
    implicit: Option<Box<LinearlyImplicit>>,
    ctl: ControllerState,
    n: usize,
    t: f64,
    y: Vec<f64>,
    y1: Vec<f64>,
    ytmp: Vec<f64>,
    /// Stages, `tab.total × n`, row-major; row 0 is `f(t, y)` when `fsal_valid`. For the
    /// Rosenbrock method row 0 is `f(t, y)` and rows 1–6 the stages `u_1 … u_6`.
    k: Vec<f64>,
    fsal_valid: bool,
    dense: DenseState,
    ev: event::EventState,
    stats: SolverStats,
    /// The owner's prices of this stepper's work and the cumulative work at which an advance
    /// stops ([`crate::solve::work`]); `None`: unbounded.
    prices: WorkPrices,
    work_until: Option<f64>,
    /// Work units of the step observers ([`StepObserver`], priced by the step).
    observer_units: f64,
}

/// The step-size controller's memory: with `(t, y)` it determines every future step (FSAL
/// stage and guard values are pure functions of `(t, y)` and are recomputed bit-identically).
/// Saved and restored for FMU state snapshots.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControllerMemory {
    pub h: Option<f64>,
    pub err_old: f64,
    pub last_rejected: bool,
    pub nonfinite_trials: u32,
}

#[derive(Debug, Clone)]
struct ControllerState {
    c: Controller,
    /// Step-size proposal carried across steps and calls.
    h: Option<f64>,
    /// Previous accepted error (PI memory).
    err_old: f64,
    last_rejected: bool,
    nonfinite_trials: u32,
}

#[derive(Debug, Clone)]
struct DenseState {
    r: Vec<f64>,
    valid: bool,
    t0: f64,
    h: f64,
    /// End of validity: the step end, or the event/stop time that cut the step.
    t1: f64,
}

impl RkStepper {
    /// A stepper for systems of dimension `dim`, at `t = 0`, `y = 0` until
    /// [`RkStepper::set_state`]. Fails with the message of [`RkOptions::validate`].
    pub fn new(opts: RkOptions, dim: usize) -> Result<Self, String> {
        opts.validate()?;
        let tab = opts.method.tableau();
        let rows = tab.map_or(1 + rosenbrock::STAGES, |t| t.total);
        let ctl = ControllerState {
            c: Controller::of(opts.method),
            h: opts.h_init,
            err_old: 1e-4,
            last_rejected: false,
            nonfinite_trials: 0,
        };
        Ok(RkStepper {
            tab,
            implicit: opts
                .method
                .is_implicit()
                .then(|| Box::new(LinearlyImplicit::new(dim))),
            ctl,
            n: dim,
            t: 0.0,
            y: vec![0.0; dim],
            y1: vec![0.0; dim],
            ytmp: vec![0.0; dim],
            k: vec![0.0; rows * dim],
            fsal_valid: false,
            dense: DenseState {
                r: vec![0.0; dense::rows(opts.method) * dim],
                valid: false,
                t0: 0.0,
                h: 0.0,
                t1: 0.0,
            },
            ev: event::EventState::default(),
            stats: SolverStats::default(),
            prices: WorkPrices::default(),
            work_until: None,
            observer_units: 0.0,
            opts,
        })
    }

    /// (Re)starts at `(t, y)`: drops FSAL, the dense output and the step-size history.
    ///
    /// # Panics
    /// If `y.len()` differs from the dimension given to [`RkStepper::new`] (a programming
    /// error, not a run-time condition).
    pub fn set_state(&mut self, t: f64, y: &[f64]) {
        assert_eq!(
            y.len(),
            self.n,
            "set_state: state length differs from stepper dimension"
        );
        self.t = t;
        self.y.copy_from_slice(y);
        self.fsal_valid = false;
        self.dense.valid = false;
        self.ev.restart();
        self.ctl.h = self.opts.h_init;
        self.ctl.err_old = 1e-4;
        self.ctl.last_rejected = false;
    }

    /// The controller memory (see [`ControllerMemory`]).
    pub fn controller_memory(&self) -> ControllerMemory {
        ControllerMemory {
            h: self.ctl.h,
            err_old: self.ctl.err_old,
            last_rejected: self.ctl.last_rejected,
            nonfinite_trials: self.ctl.nonfinite_trials,
        }
    }

    /// Restarts at `(t, y)` with a saved controller memory, so the run continues exactly as it
    /// would have from the moment the memory was taken.
    pub fn restore(&mut self, t: f64, y: &[f64], memory: &ControllerMemory) {
        self.set_state(t, y);
        self.ctl.h = memory.h;
        self.ctl.err_old = memory.err_old;
        self.ctl.last_rejected = memory.last_rejected;
        self.ctl.nonfinite_trials = memory.nonfinite_trials;
    }

    /// The system's inputs or parameters changed at the current time: drop the stage `f(t, y)`
    /// and the guard values, keep the step-size proposal (the solution is still smooth enough
    /// that the last step size is the best guess).
    pub fn invalidate(&mut self) {
        self.fsal_valid = false;
        self.ev.invalidate();
    }

    pub fn t(&self) -> f64 {
        self.t
    }

    pub fn y(&self) -> &[f64] {
        &self.y
    }

    /// Cumulative counters since construction (or [`RkStepper::reset_stats`]).
    pub fn stats(&self) -> &SolverStats {
        &self.stats
    }

    pub fn reset_stats(&mut self) {
        self.stats = SolverStats::default();
    }

    /// Sets the most step attempts of one `advance_to` ([`RkOptions::max_steps`], > 0): a
    /// caller with a work budget of its own lowers it to what is left (issue 34).
    pub fn set_max_steps(&mut self, max_steps: u64) {
        self.opts.max_steps = max_steps.max(1);
    }

    /// Prices this stepper's work ([`RkStepper::work`]).
    pub fn set_work_prices(&mut self, prices: WorkPrices) {
        self.prices = prices;
    }

    /// Stops every following advance before the step attempt that would start with the
    /// cumulative [`RkStepper::work`] at or above `until` ([`SolveError::OverBudget`], empty
    /// message); `None` lifts the limit.
    pub fn set_work_limit(&mut self, until: Option<f64>) {
        self.work_until = until;
    }

    /// Starts a scope of the owner's budget ([`RkStepper::set_work_limit`] at the cumulative
    /// work now plus `limit`; `None`: unbounded) and returns that work.
    pub fn start_work_scope(&mut self, limit: Option<f64>) -> f64 {
        let work = self.work();
        self.work_until = limit.map(|limit| work + limit);
        work
    }

    /// The work of the step observers so far (e.g. `simulate`'s statistics from the dense
    /// output), part of [`RkStepper::work`].
    pub fn observer_work(&self) -> f64 {
        self.observer_units
    }

    /// The work of all step attempts and guard evaluations so far, at the prices set
    /// ([`crate::solve::work`]).
    pub fn work(&self) -> f64 {
        // Through i64: one instruction (the counts stay far below 2^63).
        (self.stats.steps + self.stats.rejected) as i64 as f64 * self.prices.step
            + self.stats.guard_evals as i64 as f64 * self.prices.guard_eval
            + self.observer_units
    }

    pub fn options(&self) -> &RkOptions {
        &self.opts
    }

    /// Current step-size proposal (`None` before the first step).
    pub fn step_size(&self) -> Option<f64> {
        self.ctl.h
    }

    /// Interval on which [`RkStepper::dense`] is valid: the last accepted step, cut at the
    /// event or stop that ended it. `None` when no interpolant was built (no guards and
    /// `dense_output == false`, or after `set_state`).
    pub fn dense_interval(&self) -> Option<(f64, f64)> {
        self.dense.valid.then_some((self.dense.t0, self.dense.t1))
    }

    /// Evaluates the interpolant of the last accepted step at `t` (the state of the mode that
    /// step was taken in, before any event/stop handling). Returns `false` and leaves `out`
    /// untouched when `t` is outside [`RkStepper::dense_interval`].
    pub fn dense(&self, t: f64, out: &mut [f64]) -> bool {
        match self.dense_interval() {
            Some((t0, t1)) if t >= t0 && t <= t1 && out.len() == self.n => {
                dense::eval(
                    self.opts.method,
                    (t - t0) / self.dense.h,
                    &self.dense.r,
                    out,
                );
                true
            }
            _ => false,
        }
    }

    /// Integrates to exactly `t_end` (`self.t() == t_end` bit-exactly on success).
    ///
    /// Never evaluates `sys.rhs` beyond `min(t_end, sys.next_stop())`; lands on every stop and
    /// calls `sys.on_stop`; locates state events on the interpolant and calls `sys.on_event`.
    /// On error the stepper holds the last accepted state.
    pub fn advance_to<S: HybridSystem>(
        &mut self,
        sys: &mut S,
        t_end: f64,
    ) -> Result<(), SolveError> {
        self.advance_observed(sys, t_end, &mut observe::Unobserved)
    }

    /// [`RkStepper::advance_to`], handing every accepted step with its dense output to
    /// `observer` ([`observe`]) before the event or stop at its end is handled. The steps are
    /// those of the plain advance (the observer only reads them); the interpolant is then built
    /// on every step (for DOP853 at 3 more evaluations where no event search needs it).
    pub fn advance_observed<S: HybridSystem, O: StepObserver<S>>(
        &mut self,
        sys: &mut S,
        t_end: f64,
        observer: &mut O,
    ) -> Result<(), SolveError> {
        if sys.dim() != self.n {
            return Err(SolveError::DimensionMismatch {
                expected: self.n,
                got: sys.dim(),
            });
        }
        if !t_end.is_finite() {
            return Err(SolveError::InvalidEndTime { t: self.t, t_end });
        }
        if !self.t.is_finite() || self.y.iter().any(|v| !v.is_finite()) {
            return Err(SolveError::NonFinite { t: self.t });
        }
        if t_end < self.t {
            return Err(SolveError::BackwardTime { t: self.t, t_end });
        }
        let mut attempts: u64 = 0;
        loop {
            let stop = sys.next_stop();
            if !(stop >= self.t) {
                return Err(SolveError::StopNotAhead { t: self.t, stop });
            }
            if stop == self.t {
                self.land_on_stop(sys)?;
                continue;
            }
            if self.t == t_end {
                return Ok(());
            }
            let t_lim = stop.min(t_end);

            if !self.fsal_valid {
                let (k0, _) = self.k.split_at_mut(self.n);
                sys.rhs(self.t, &self.y, k0);
                self.stats.rhs_evals += 1;
                if k0.iter().any(|v| !v.is_finite()) {
                    return Err(SolveError::NonFinite { t: self.t });
                }
                if let Some(implicit) = &mut self.implicit {
                    implicit.linearise(sys, self.t, &self.y, k0, t_lim - self.t, &mut self.stats);
                }
                self.fsal_valid = true;
            }
            let n_guards = sys.guard_count();
            if n_guards > 0 {
                self.ev
                    .ensure_start(sys, self.t, &self.y, n_guards, &mut self.stats);
            }

            let rem = t_lim - self.t;
            let h_prop = match self.ctl.h {
                Some(h) => h,
                None => self.initial_step(sys, rem),
            }
            .min(self.opts.h_max);
            self.ctl.h = Some(h_prop);
            if !(h_prop > 10.0 * f64::EPSILON * self.t.abs()) || h_prop < f64::MIN_POSITIVE {
                return Err(if self.ctl.nonfinite_trials > 0 {
                    SolveError::NonFinite { t: self.t }
                } else {
                    SolveError::StepSizeTooSmall {
                        t: self.t,
                        h: h_prop,
                    }
                });
            }
            attempts += 1;
            if attempts > self.opts.max_steps {
                return Err(SolveError::TooManySteps {
                    t: self.t,
                    max_steps: self.opts.max_steps,
                });
            }
            if work::over_limit(|| self.work(), self.work_until) {
                return Err(SolveError::OverBudget {
                    t: self.t,
                    message: String::new(),
                });
            }

            // Land on t_lim when close; split the remainder evenly when a full step would
            // leave a sliver (a sliver step wastes a step and upsets the controller).
            let (mut h, mut t_new) = if rem <= STRETCH * h_prop {
                (rem, t_lim)
            } else if rem < 2.0 * h_prop {
                (0.5 * rem, self.t + 0.5 * rem)
            } else {
                (h_prop, self.t + h_prop)
            };
            if t_new >= t_lim {
                (h, t_new) = (rem, t_lim);
            }

            if !self.trial_step(sys, h, t_new) {
                // `I/(hγ) − J` singular: treated like a non-finite trial (shrink and retry).
                self.y1.fill(f64::NAN);
            }
            let y1_finite = self.y1.iter().all(|v| v.is_finite());
            let err = if y1_finite {
                control::error_norm(
                    self.opts.method,
                    h,
                    &self.y,
                    &self.y1,
                    &self.k,
                    self.opts.atol,
                    self.opts.rtol,
                )
            } else {
                f64::NAN
            };
            if !err.is_finite() {
                if self.ctl.nonfinite_trials >= MAX_NONFINITE_TRIALS {
                    return Err(SolveError::NonFinite { t: self.t });
                }
                self.ctl.nonfinite_trials += 1;
                self.stats.rejected += 1;
                self.ctl.last_rejected = true;
                self.ctl.h = Some(h * self.ctl.c.fac_min);
                continue;
            }
            self.ctl.nonfinite_trials = 0;
            if err > 1.0 {
                self.stats.rejected += 1;
                self.reject(h, err);
                continue;
            }
            self.accept(sys, (h, h_prop, t_new), err)?;
            let t0 = self.t;
            if n_guards > 0 || self.opts.dense_output || O::ACTIVE {
                self.build_dense(sys, t0, h, t_new);
            } else {
                self.dense.valid = false;
            }
            if n_guards > 0 {
                if let Some((t_ev, index)) = self.ev.locate(
                    sys,
                    n_guards,
                    self.opts.guard_samples,
                    (t0, h, t_new),
                    &self.y1,
                    (self.opts.method, &self.dense.r),
                    &mut self.ytmp,
                    &mut self.stats,
                ) {
                    if O::ACTIVE {
                        self.observe(&*sys, t0, t_ev, observer);
                    }
                    self.handle_event(sys, t_ev, t_new, index)?;
                    continue;
                }
            }
            if O::ACTIVE {
                self.observe(&*sys, t0, t_new, observer);
            }
            // Commit the step: the FSAL stage becomes stage 0 of the next step (the Rosenbrock
            // method evaluates `f` and `J` afresh at the new start).
            std::mem::swap(&mut self.y, &mut self.y1);
            self.t = t_new;
            match self.tab {
                Some(tab) => {
                    let fsal = tab.fsal();
                    self.k.copy_within(fsal * self.n..(fsal + 1) * self.n, 0);
                }
                None => self.fsal_valid = false,
            }
            if t_new == stop {
                self.land_on_stop(sys)?;
            }
        }
    }

    /// Stages 1..stages, `y1`, and for DP5 the FSAL stage its error estimate needs. `false`
    /// when the Rosenbrock matrix could not be factored.
    fn trial_step<S: HybridSystem>(&mut self, sys: &S, h: f64, t_new: f64) -> bool {
        let Some(tab) = self.tab else {
            return self.rosenbrock_step(sys, h, t_new);
        };
        let n = self.n;
        for i in 1..tab.stages {
            self.stage(sys, tab, i, h, t_new);
        }
        self.y1.copy_from_slice(&self.y);
        for (j, &bj) in tab.b.iter().enumerate() {
            if bj != 0.0 {
                let hb = h * bj;
                for (y1m, &kjm) in self.y1.iter_mut().zip(&self.k[j * n..(j + 1) * n]) {
                    *y1m += hb * kjm;
                }
            }
        }
        if self.opts.method == Method::Dp5 {
            self.eval_fsal(sys, tab, t_new);
        }
        true
    }

    /// One RODAS4 step ([`rosenbrock`]): stages `u_1 … u_6` into rows 1–6 of `k`, `y1`. The
    /// stage times never pass `t_new` (`c_i ≤ 1`).
    fn rosenbrock_step<S: HybridSystem>(&mut self, sys: &S, h: f64, t_new: f64) -> bool {
        let n = self.n;
        let Some(implicit) = self.implicit.as_mut() else {
            return false;
        };
        if !implicit.factor(h) {
            return false;
        }
        let (k0, stages) = self.k.split_at_mut(n);
        for i in 0..rosenbrock::STAGES {
            let (done, rest) = stages.split_at_mut(i * n);
            let u = &mut rest[..n];
            if i == 0 {
                u.copy_from_slice(k0);
            } else {
                self.ytmp.copy_from_slice(&self.y);
                for (j, &a) in rosenbrock::A[i].iter().enumerate() {
                    for (ym, &ujm) in self.ytmp.iter_mut().zip(&done[j * n..(j + 1) * n]) {
                        *ym += a * ujm;
                    }
                }
                let c = rosenbrock::C[i];
                let ts = if c == 1.0 {
                    t_new
                } else {
                    (self.t + c * h).min(t_new)
                };
                sys.rhs(ts, &self.ytmp, u);
                self.stats.rhs_evals += 1;
                for (j, &cij) in rosenbrock::CIJ[i].iter().enumerate() {
                    let w = cij / h;
                    for (um, &ujm) in u.iter_mut().zip(&done[j * n..(j + 1) * n]) {
                        *um += w * ujm;
                    }
                }
            }
            let hd = h * rosenbrock::D[i];
            if hd != 0.0 {
                for (um, &ft) in u.iter_mut().zip(implicit.f_t()) {
                    *um += hd * ft;
                }
            }
            implicit.solve(u);
        }
        self.y1.copy_from_slice(&self.y);
        for (j, &mj) in rosenbrock::M.iter().enumerate() {
            for (y1m, &ujm) in self.y1.iter_mut().zip(&stages[j * n..(j + 1) * n]) {
                *y1m += mj * ujm;
            }
        }
        true
    }

    /// `k_i = f(t + c_i h, y + h Σ a_ij k_j)`, with stage times never beyond `t_new` (the
    /// c = 1 stages are evaluated at `t_new` itself, which is the stop when landing).
    fn stage<S: HybridSystem>(&mut self, sys: &S, tab: &Tableau, i: usize, h: f64, t_new: f64) {
        let n = self.n;
        self.ytmp.copy_from_slice(&self.y);
        let (done, rest) = self.k.split_at_mut(i * n);
        for (j, &aij) in tab.a[i].iter().enumerate() {
            if aij != 0.0 {
                let ha = h * aij;
                for (ym, &kjm) in self.ytmp.iter_mut().zip(&done[j * n..(j + 1) * n]) {
                    *ym += ha * kjm;
                }
            }
        }
        let c = tab.c[i];
        let ts = if c == 1.0 {
            t_new
        } else {
            (self.t + c * h).min(t_new)
        };
        sys.rhs(ts, &self.ytmp, &mut rest[..n]);
        self.stats.rhs_evals += 1;
    }

    fn eval_fsal<S: HybridSystem>(&mut self, sys: &S, tab: &Tableau, t_new: f64) {
        let n = self.n;
        let fsal = tab.fsal();
        sys.rhs(t_new, &self.y1, &mut self.k[fsal * n..(fsal + 1) * n]);
        self.stats.rhs_evals += 1;
    }

    fn reject(&mut self, h: f64, err: f64) {
        let c = &self.ctl.c;
        let fac11 = err.powf(c.expo);
        self.ctl.h = Some(h / (1.0 / c.fac_min).min(fac11 / c.safe));
        self.ctl.last_rejected = true;
    }

    /// Step-size update after an accepted step (Hairer's PI form). A step shortened to land on
    /// a stop or `t_end` says little about larger steps, so it may not pull the proposal below
    /// what its own error allows, nor below the proposal it was cut from: otherwise every
    /// communication point would restart the controller from a sliver.
    fn accept<S: HybridSystem>(
        &mut self,
        sys: &S,
        (h, h_prop, t_new): (f64, f64, f64),
        err: f64,
    ) -> Result<(), SolveError> {
        if let Some(tab) = self.tab {
            if self.opts.method == Method::Dop853 {
                // DOP853's error estimate does not need f(t + h, y1); it is paid for only here.
                self.eval_fsal(sys, tab, t_new);
            }
            let fsal = tab.fsal();
            if self.k[fsal * self.n..(fsal + 1) * self.n]
                .iter()
                .any(|v| !v.is_finite())
            {
                return Err(SolveError::NonFinite { t: t_new });
            }
        }
        self.stats.steps += 1;
        let c = &self.ctl.c;
        let fac11 = err.powf(c.expo);
        let fac = (fac11 / self.ctl.err_old.powf(c.beta) / c.safe)
            .clamp(1.0 / c.fac_max, 1.0 / c.fac_min);
        let mut h_new = h / fac;
        if h < h_prop {
            let h_ideal = if fac11 > 0.0 {
                h * c.safe / fac11
            } else {
                f64::INFINITY
            };
            h_new = h_new.max(h_ideal.min(h_prop));
        } else {
            self.ctl.err_old = err.max(1e-4);
        }
        h_new = h_new.min(self.opts.h_max);
        if self.ctl.last_rejected {
            // Right after a rejection do not grow again (HNW I §II.4): avoids reject cycles.
            h_new = h_new.min(h.max(h_prop));
        }
        self.ctl.last_rejected = false;
        self.ctl.h = Some(h_new);
        Ok(())
    }

    /// Hands the accepted step `[t0, t1]` (its dense output just built) to `observer`.
    fn observe<S, O: StepObserver<S>>(&mut self, sys: &S, t0: f64, t1: f64, observer: &mut O) {
        let mut step = DenseStep {
            method: self.opts.method,
            r: &self.dense.r,
            t0,
            h: self.dense.h,
            t1,
            work: &mut self.observer_units,
            guard_eval: self.prices.guard_eval,
        };
        observer.step(sys, &mut step);
    }

    fn build_dense<S: HybridSystem>(&mut self, sys: &S, t0: f64, h: f64, t_new: f64) {
        if let (Method::Dop853, Some(tab)) = (self.opts.method, self.tab) {
            for i in tab.stages + 1..tab.total {
                self.stage(sys, tab, i, h, t_new);
            }
        }
        dense::build(
            self.opts.method,
            h,
            &self.y,
            &self.y1,
            &self.k,
            &mut self.dense.r,
        );
        self.dense.valid = true;
        self.dense.t0 = t0;
        self.dense.h = h;
        self.dense.t1 = t_new;
    }

    fn handle_event<S: HybridSystem>(
        &mut self,
        sys: &mut S,
        t_ev: f64,
        t_new: f64,
        index: usize,
    ) -> Result<(), SolveError> {
        if t_ev == t_new {
            std::mem::swap(&mut self.y, &mut self.y1);
        } else {
            let theta = (t_ev - self.dense.t0) / self.dense.h;
            dense::eval(self.opts.method, theta, &self.dense.r, &mut self.y);
        }
        self.dense.t1 = t_ev;
        let scale = t_ev.abs().max(self.dense.h);
        let storm = self.ev.note_event(t_ev, scale);
        self.t = t_ev;
        if storm > MAX_EVENTS_WITHOUT_PROGRESS {
            return Err(SolveError::EventStorm {
                t: t_ev,
                events: storm,
            });
        }
        sys.on_event(t_ev, &mut self.y, index);
        self.stats.events += 1;
        self.fsal_valid = false;
        self.ev.invalidate();
        if self.y.iter().any(|v| !v.is_finite()) {
            return Err(SolveError::NonFinite { t: t_ev });
        }
        Ok(())
    }

    fn land_on_stop<S: HybridSystem>(&mut self, sys: &mut S) -> Result<(), SolveError> {
        sys.on_stop(self.t, &mut self.y);
        self.stats.stops += 1;
        self.fsal_valid = false;
        self.ev.invalidate();
        let next = sys.next_stop();
        if !(next > self.t) {
            return Err(SolveError::StopNotAhead {
                t: self.t,
                stop: next,
            });
        }
        if self.y.iter().any(|v| !v.is_finite()) {
            return Err(SolveError::NonFinite { t: self.t });
        }
        Ok(())
    }

    /// Hairer's starting step (HNW I §II.4, `hinit`): balance `h·|f0|` against `|y0|`, then
    /// correct with a finite-difference estimate of `y''` from one explicit Euler probe. The
    /// probe is kept within `rem` so no evaluation lands beyond the current limit.
    fn initial_step<S: HybridSystem>(&mut self, sys: &S, rem: f64) -> f64 {
        let n = self.n;
        let (atol, rtol) = (self.opts.atol, self.opts.rtol);
        let (mut dnf, mut dny) = (0.0, 0.0);
        for m in 0..n {
            let sk = atol + rtol * self.y[m].abs();
            dnf += (self.k[m] / sk).powi(2);
            dny += (self.y[m] / sk).powi(2);
        }
        let mut h = if dnf <= 1e-10 || dny <= 1e-10 {
            1e-6
        } else {
            (dny / dnf).sqrt() * 0.01
        };
        h = h.min(self.opts.h_max);
        let probe = h.min(rem);
        for m in 0..n {
            self.ytmp[m] = self.y[m] + probe * self.k[m];
        }
        let (k0, rest) = self.k.split_at_mut(n);
        let f1 = &mut rest[..n];
        sys.rhs(self.t + probe, &self.ytmp, f1);
        self.stats.rhs_evals += 1;
        let mut der2 = 0.0;
        for m in 0..n {
            let sk = atol + rtol * self.y[m].abs();
            der2 += ((f1[m] - k0[m]) / sk).powi(2);
        }
        let der2 = der2.sqrt() / probe;
        let der12 = der2.abs().max(dnf.sqrt());
        let h1 = if !(der12 > 1e-15) {
            (h * 1e-3).max(1e-6)
        } else {
            (0.01 / der12).powf(1.0 / control::hinit_order(self.opts.method) as f64)
        };
        (100.0 * h).min(h1).min(self.opts.h_max)
    }
}
