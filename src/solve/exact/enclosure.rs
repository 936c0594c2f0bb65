//! Rigorous first-crossing search of one guard over one sample interval, on its Taylor
//! polynomial ([`GuardSeries`]), so that a dip between two samples (a short excursion: a
//! separation and the return to the same flank, or a shallow touch during a flight) is not
//! missed whatever its depth or width (numerics notes §5, S9).
//!
//! In `σ = s/h ∈ [0, 1]` the guard is the polynomial `p(σ) = Σ d_k σ^k` up to a truncation
//! below `1e-20` of its largest term. On `[a, b]` the curvature is enclosed, `L ≤ p'' ≤ U`, by
//! the centred Taylor form of `p''` about the midpoint; with the end values and slopes the
//! guard is bounded below by the larger of the two Taylor minorants from the ends (their
//! difference is linear, so the bound is one closed-form value). A bound `≥ 0` proves that
//! there is no crossing (the usual case: one test per interval and guard); a convex interval
//! (`L ≥ 0`) is decided by the root of `p'` and the guard there; otherwise the interval is
//! bisected, left half first, so the crossing found is the first one. The search itself is
//! the one of the RK event search ([`crate::solve::first_crossing`]); this module supplies the
//! guard's Taylor polynomial to it.
//!
//! Touching (`min p = 0`) is not an event: every decision rests on an evaluated guard value
//! below zero; bounds only prune.

use super::guard_series::GuardSeries;
use crate::solve::first_crossing::{self, GuardAlong, MAX_BISECTIONS};
pub use crate::solve::first_crossing::{taylor_lower_bound, Point};

/// One guard's polynomial over one sample interval, in `σ = s/h ∈ [0, 1]`.
pub struct GuardOnInterval<'s, 'a> {
    series: &'s GuardSeries<'a>,
    /// `C ≥ |p''|` on the whole interval, if known (one bound for every sub-interval: the
    /// cheap first test before the centred enclosure).
    curvature_bound: Option<f64>,
    /// Series evaluations (counted as guard evaluations by the caller).
    pub evals: u64,
    budget: u32,
}

impl<'s, 'a> GuardOnInterval<'s, 'a> {
    pub fn new(series: &'s GuardSeries<'a>, curvature_bound: Option<f64>) -> Self {
        GuardOnInterval {
            series,
            curvature_bound,
            evals: 0,
            budget: MAX_BISECTIONS,
        }
    }

    /// A bracket `(lo, hi)` of the first crossing in `[a, b]` (`p(lo) >= 0 > p(hi)`, one
    /// crossing inside), or `None` when `p` stays `>= 0` there. Requires `a.g >= 0`.
    pub fn first_crossing(&mut self, a: Point, b: Point) -> Option<(Point, Point)> {
        first_crossing::first_crossing(self, a, b)
    }
}

impl GuardAlong for GuardOnInterval<'_, '_> {
    fn evaluate(&mut self, sigma: f64) -> Point {
        self.evals += 2;
        Point {
            at: sigma,
            g: self.series.value_sigma(sigma),
            slope: self.series.slope_sigma(sigma),
        }
    }

    fn slope(&mut self, sigma: f64) -> f64 {
        self.evals += 1;
        self.series.slope_sigma(sigma)
    }

    fn curvature_range(&self, a: f64, b: f64) -> (f64, f64) {
        self.series.curvature_range(a, b)
    }

    fn curvature_bound(&self) -> Option<f64> {
        self.curvature_bound
    }

    fn stationary_tolerance(&self) -> f64 {
        1e-13
    }

    fn budget(&mut self) -> &mut u32 {
        &mut self.budget
    }
}
