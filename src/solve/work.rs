//! The propagators' own work meter (issue 34): each propagator prices what its counters
//! already count (step attempts or segments, guard evaluations, modes built, the metered
//! matrix exponentials) and stops an advance once that cumulative work reaches a limit its
//! owner set. The owner ([`crate::simulation::Driver`] and its work budget,
//! [`crate::simulation::budget`]) sets the limit when a budget scope starts and reads the
//! work when it reports; nothing is snapshotted per advance, so a bounded run pays one
//! comparison per step or segment for its bound.

/// Work units of one step attempt (RK) or segment (exact propagator), of one guard
/// evaluation (or guard sample of a crossing search) and of one mode built (exact
/// propagator: balancing, rates, its first exponentials). All zero until the owner prices
/// them: an unpriced propagator meters nothing.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct WorkPrices {
    pub step: f64,
    pub guard_eval: f64,
    pub mode: f64,
}

/// Stops an advance whose propagator has spent `until` units in all (its cumulative work,
/// not the advance's): [`crate::solve::SolveError::OverBudget`] with an empty message, the
/// state at the last step or segment end (the owner words the message). `work` is computed
/// only under a limit: an unbounded step pays one test for the meter.
#[inline(always)]
pub fn over_limit(work: impl FnOnce() -> f64, until: Option<f64>) -> bool {
    matches!(until, Some(until) if work() >= until)
}
