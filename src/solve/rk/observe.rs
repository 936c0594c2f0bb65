//! The accepted steps of an RK advance, for an observer of the propagation (issue 31: the
//! statistics of a `simulate` run on the RK path from its solution, not from the output rows,
//! [`crate::analysis::orbit_statistics::RunStatistics`]).
//!
//! Each accepted step `[t₀, t₁]` carries its continuous extension (HNW I §II.6; RODAS4's, HW
//! II §IV.7): a polynomial in `θ = (t − t₀)/h` of degree 7 (DOP853), 4 (DP5) or 3 (RODAS4),
//! the very interpolant the stepper locates its events on. The observer sees a step before the
//! event or stop at its end changes the mode (`t₁` is the event time when one cut the step), so
//! the model is still in the step's mode. Its values are those of the RK solution: accurate to
//! the integration tolerance (`solver.rtol`, `solver.atol`) plus the interpolant's error
//! (its order is the method's dense order), not to a sampling error.

use super::{dense, Method};

/// What sees each accepted step of an observed advance ([`super::RkStepper::advance_observed`]).
pub trait StepObserver<S> {
    /// Whether steps are handed over at all (the plain advance's observer is not).
    const ACTIVE: bool = true;
    fn step(&mut self, sys: &S, step: &mut DenseStep);
}

/// The plain advance: nothing observes it.
pub(super) struct Unobserved;

impl<S> StepObserver<S> for Unobserved {
    const ACTIVE: bool = false;
    #[inline(always)]
    fn step(&mut self, _sys: &S, _step: &mut DenseStep) {}
}

/// One accepted step with its dense output.
pub struct DenseStep<'a> {
    pub(super) method: Method,
    pub(super) r: &'a [f64],
    pub(super) t0: f64,
    pub(super) h: f64,
    pub(super) t1: f64,
    /// The stepper's observer work, in work units, and the price of one guard evaluation: a
    /// dense evaluation is a Horner sum over the interpolant's rows (rows × dimension units,
    /// the budget's unit being one multiply-add), an observer's evaluation of an output a
    /// guard evaluation; nothing on an unpriced stepper.
    pub(super) work: &'a mut f64,
    pub(super) guard_eval: f64,
}

impl DenseStep<'_> {
    pub fn start(&self) -> f64 {
        self.t0
    }

    pub fn end(&self) -> f64 {
        self.t1
    }

    /// The state at `t` (clamped to the step) into `y`, which has the system's dimension.
    pub fn state(&mut self, t: f64, y: &mut [f64]) {
        let rows = dense::rows(self.method);
        debug_assert_eq!(y.len() * rows, self.r.len(), "the system's dimension");
        let t = t.clamp(self.t0, self.t1);
        dense::eval(self.method, (t - self.t0) / self.h, self.r, y);
        if self.guard_eval > 0.0 {
            *self.work += (rows * y.len()) as f64;
        }
    }

    /// Charges `count` evaluations of the observer's own (outputs of the model at a state of
    /// the step) to the run's work budget.
    pub fn charge_evaluations(&mut self, count: usize) {
        *self.work += count as f64 * self.guard_eval;
    }
}
