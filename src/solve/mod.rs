//! Integrators for piecewise-smooth systems.
//!
//! Problem definitions implement [`HybridSystem`]; integrators ([`rk`], [`exact`]) only see
//! that trait (the split follows diffsol: solver traits apart from problem definitions).
//!
//! Discipline (see `shared/reference/numerics-notes.md` §2.1): the discrete mode (stiffness
//! segment, contact state) is *frozen* inside a step; known-time switches are stops the
//! integrator lands on exactly; state events are located on the dense output and the state is
//! snapped onto the switching surface by the system before integration restarts.

pub mod exact;
pub mod first_crossing;
pub mod polynomial;
pub mod rk;
pub mod roots;
pub mod variational;
pub mod work;

use std::fmt;

/// A piecewise-smooth ODE `y' = f(t, y; mode)`.
///
/// The discrete mode lives inside the system. It changes only through [`HybridSystem::on_stop`]
/// (at a known time returned by [`HybridSystem::next_stop`]) or [`HybridSystem::on_event`]
/// (when a guard function crosses zero). Between those calls `rhs` must be a smooth function of
/// `(t, y)`, evaluated with the mode frozen even slightly outside the segment (RK stages may
/// touch the segment end).
pub trait HybridSystem {
    /// Number of continuous states.
    fn dim(&self) -> usize;

    /// `dy = f(t, y)` in the current (frozen) mode.
    fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]);

    /// Number of guard functions in the current mode. Zero means the scene has no state
    /// events and the integrator does no event work at all.
    fn guard_count(&self) -> usize {
        0
    }

    /// Guard values `g_i(t, y)`, `i < guard_count()`. Every guard is `>= 0` while the current
    /// mode is valid; a guard that becomes negative marks a mode change.
    fn guards(&self, _t: f64, _y: &[f64], _g: &mut [f64]) {}

    /// The first known switching time strictly after the start of the current segment, or
    /// `f64::INFINITY`. The integrator never steps past it.
    fn next_stop(&self) -> f64 {
        f64::INFINITY
    }

    /// Called when the integrator has landed exactly on `next_stop()`: advance to the next
    /// segment. The system may modify `y` (it must not, for continuous models).
    fn on_stop(&mut self, _t: f64, _y: &mut [f64]) {}

    /// Called at a located state event: guard `index` crossed zero at `t`. The system snaps `y`
    /// onto the switching surface and switches mode.
    fn on_event(&mut self, _t: f64, _y: &mut [f64], _index: usize) {}

    /// The Jacobian `∂f/∂y` of the current mode, row-major `n × n`, for variational equations.
    /// Returns `false` when the system does not provide it.
    fn jacobian(&self, _t: f64, _y: &[f64], _jac: &mut [f64]) -> bool {
        false
    }

    /// Gradient `∂g_i/∂y` of guard `index` into `grad`, returning `∂g_i/∂t`; `None` when the
    /// system does not provide it. Needed for saltation matrices.
    fn guard_gradient(&self, _t: f64, _y: &[f64], _index: usize, _grad: &mut [f64]) -> Option<f64> {
        None
    }

    /// Declares guard `index` of the current mode affine in the state with a constant gradient,
    /// `g(t, y) = w·y + c(t)`: fills `w` and returns a bound of `|c''(t)|` on `[t0, t1]`
    /// (`c'` is the `∂g/∂t` of [`HybridSystem::guard_gradient`], which such a system must
    /// provide). `None` (the default): no such structure is known.
    ///
    /// With it the RK event search bounds the guard along each step's interpolant rigorously
    /// (the interpolant is a polynomial in the step fraction, so `w·u(θ)` is one too) and
    /// cannot miss a grazing dip; without it the guard is only sampled
    /// ([`rk::RkOptions::guard_samples`]).
    fn affine_guard(&self, _index: usize, _t0: f64, _t1: f64, _w: &mut [f64]) -> Option<f64> {
        None
    }
}

/// Counters every integrator keeps (work measures for benchmarks).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SolverStats {
    /// Accepted steps (for the exact propagator: segments propagated).
    pub steps: u64,
    /// Rejected steps.
    pub rejected: u64,
    /// Right-hand-side evaluations.
    pub rhs_evals: u64,
    /// Guard (root-function) evaluations, including those on the interpolant.
    pub guard_evals: u64,
    /// State events located and handled.
    pub events: u64,
    /// Known-time stops landed on.
    pub stops: u64,
    /// Segments whose guards were all proved positive by a bound, so no root function was
    /// evaluated in them (exact propagator, [`exact::PiecewiseLti::guard_excluded`]).
    pub guard_exclusions: u64,
    /// Segments whose crossing (or its absence) an earlier segment of the same mode decided
    /// (exact propagator, recurring segments of a periodic orbit).
    pub recurring_segments: u64,
    /// Segments propagated by their Taylor series, their mode not built (exact propagator,
    /// a mode beyond the memory budget of the full path: `exact::series_segment`).
    pub series_segments: u64,
    /// Modes built from their band of rows alone, balanced by the band frame of their
    /// contact combinations (exact propagator, a free train's modes beyond the memory budget
    /// of the full path: `exact::balanced::BandFrame`).
    pub frame_modes: u64,
    /// Transition matrices built (exact propagator: Padé exponentials of a duration bin), in
    /// the advances under a work limit: the meter's sign that an exponential was paid for
    /// (its full check, [`crate::simulation::budget`]). An unbounded advance meters nothing,
    /// so it does not count them either.
    pub transitions: u64,
}

impl SolverStats {
    /// Adds another counter set to this one.
    pub fn accumulate(&mut self, other: &SolverStats) {
        self.steps += other.steps;
        self.rejected += other.rejected;
        self.rhs_evals += other.rhs_evals;
        self.guard_evals += other.guard_evals;
        self.events += other.events;
        self.stops += other.stops;
        self.guard_exclusions += other.guard_exclusions;
        self.recurring_segments += other.recurring_segments;
        self.series_segments += other.series_segments;
        self.frame_modes += other.frame_modes;
        self.transitions += other.transitions;
    }
}

/// Why an integration could not continue.
#[derive(Debug, Clone, PartialEq)]
pub enum SolveError {
    /// The step size fell below the floating-point resolution of `t`.
    StepSizeTooSmall { t: f64, h: f64 },
    /// More steps than `max_steps` were needed for one `advance_to`.
    TooManySteps { t: f64, max_steps: u64 },
    /// A state or derivative became NaN or infinite.
    NonFinite { t: f64 },
    /// More state events at (almost) the same time than can be physical (Zeno behaviour).
    EventStorm { t: f64, events: u64 },
    /// The requested end time lies before the current time.
    BackwardTime { t: f64, t_end: f64 },
    /// The requested end time is NaN or infinite.
    InvalidEndTime { t: f64, t_end: f64 },
    /// The system's `next_stop()` lies before the current time (or is NaN), or did not move
    /// past it after `on_stop`: the segment bookkeeping of the system is inconsistent.
    StopNotAhead { t: f64, stop: f64 },
    /// The system's `dim()` differs from the integrator's.
    DimensionMismatch { expected: usize, got: usize },
    /// A grazing state event (the guard's rate vanishes) while the sensitivity `∂y/∂y0` was
    /// tracked: the saltation matrix is unbounded there.
    SingularSaltation { t: f64 },
    /// The advance would exceed a documented limit of one advance (mesh periods, phase or
    /// time resolution: [`crate::model::PhaseClock::check_advance`]); refused before any work,
    /// so the state is unchanged.
    BeyondLimits { t: f64, reason: String },
    /// The exact propagator's crossing search would need more guard samples than one advance
    /// may take ([`exact::MAX_GUARD_SAMPLES_PER_ADVANCE`]): the mode's fastest rate is far
    /// above the time span asked for (e.g. a tiny equivalent mass under heavy damping).
    TooManyGuardSamples {
        t: f64,
        tau: f64,
        samples: f64,
        rate: f64,
    },
    /// The driver's work budget ran out ([`crate::simulation::budget`]); the message names
    /// the likely cause. The state is the last one reached.
    OverBudget { t: f64, message: String },
}

impl fmt::Display for SolveError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SolveError::BeyondLimits { t, reason } => {
                write!(f, "refused at t = {t:e} s: {reason}")
            }
            SolveError::OverBudget { message, .. } => f.write_str(message),
            SolveError::TooManyGuardSamples {
                t,
                tau,
                samples,
                rate,
            } => write!(
                f,
                "at t = {t:e} s the contact search over {tau:e} s would need {samples:e} guard \
                 samples (fastest rate of the mode {rate:e} 1/s), more than the {:e} one \
                 advance may take: shorten the step, or check inertias, base radii, damping \
                 and stiffness (a tiny equivalent mass makes the mode extremely fast)",
                exact::MAX_GUARD_SAMPLES_PER_ADVANCE
            ),
            SolveError::SingularSaltation { t } => write!(
                f,
                "grazing contact at t = {t:e} s: the sensitivity (monodromy) is unbounded there"
            ),
            SolveError::StepSizeTooSmall { t, h } => {
                write!(f, "step size {h:e} too small at t = {t:e} s")
            }
            SolveError::TooManySteps { t, max_steps } => {
                write!(
                    f,
                    "more than {max_steps} steps needed, stopped at t = {t:e} s (the work \
                     bound of one advance: shorten the step)"
                )
            }
            SolveError::NonFinite { t } => write!(f, "state became non-finite at t = {t:e} s"),
            SolveError::EventStorm { t, events } => {
                write!(f, "{events} state events without progress at t = {t:e} s")
            }
            SolveError::BackwardTime { t, t_end } => {
                write!(f, "end time {t_end:e} s lies before current time {t:e} s")
            }
            SolveError::InvalidEndTime { t, t_end } => {
                write!(f, "end time {t_end} is not finite (current time {t:e} s)")
            }
            SolveError::StopNotAhead { t, stop } => {
                write!(
                    f,
                    "next stop {stop:e} s is not after the current time {t:e} s"
                )
            }
            SolveError::DimensionMismatch { expected, got } => {
                write!(
                    f,
                    "system has {got} states, integrator was built for {expected}"
                )
            }
        }
    }
}

impl std::error::Error for SolveError {}
