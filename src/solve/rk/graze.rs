//! Rigorous search for the first crossing of an affine guard along a step's interpolant, so
//! that a grazing dip (an interior minimum below zero with the guard positive at both step
//! ends) is not missed however long the step is (numerics notes §5, S7).
//!
//! For a guard `g(t, y) = w·y + c(t)` declared by [`HybridSystem::affine_guard`], the guard
//! along the interpolant `u(θ)`, `θ = (t − t0)/h`, is `G(θ) = q(θ) + c(t0 + θh)` with `q = w·u`
//! a polynomial of degree ≤ 7 whose coefficients follow exactly from the dense-output rows
//! ([`dense::functional_polynomial`]), and `|c''| ≤ C` from the system. So on any interval
//! `[a, b]` of θ the curvature is enclosed, `L ≤ G'' ≤ U`, with `L, U` = the range of `q''`
//! (centred Taylor form) `∓ h²C`, and with the end values and slopes (`G' = q' + h ∂g/∂t`)
//! the guard is bounded below by the larger of its two Taylor minorants
//! `G(a) + G'(a)(θ − a) + L(θ − a)²/2` and `G(b) − G'(b)(b − θ) + L(b − θ)²/2`; their
//! difference is linear in θ, so the bound is one closed-form value. A bound `≥ 0` proves
//! there is no crossing (the usual case: one test per step, no interior evaluation); a convex
//! interval (`L ≥ 0`) is decided exactly by the root of `G'` (Brent) and the guard there;
//! otherwise the interval is bisected, left half first, so the crossing found is the first.
//! Without STE (`C = 0`) `G` is the polynomial itself and the search is exact up to rounding.
//!
//! The search is [`crate::solve::first_crossing`], shared with the exact propagator; this
//! module supplies the guard along the interpolant to it.
//!
//! Touching (`min G = 0`) is not an event, as for the exact propagator
//! (`src/solve/exact.rs`, `dip`: a crossing needs a guard value `< 0`): every decision here
//! rests on an evaluated guard value below zero; bounds only prune.

use super::dense::{self, MAX_DEGREE};
use super::Method;
use crate::solve::first_crossing::{self, polynomial_range, GuardAlong, Point, MAX_BISECTIONS};
use crate::solve::{HybridSystem, SolverStats};

/// One affine guard over one accepted step, with what evaluating it on the interpolant needs.
pub(crate) struct GuardOnStep<'a, S: HybridSystem> {
    pub sys: &'a S,
    pub index: usize,
    /// `(t0, h, t1)` of the step (`t1` is the exact step end).
    pub step: (f64, f64, f64),
    pub interp: (Method, &'a [f64]),
    /// The state at `t1` (the guard there is evaluated on it, as without this search).
    pub y1: &'a [f64],
    pub ytmp: &'a mut [f64],
    /// Guard values (all guards of the mode) and gradient scratch.
    pub g: &'a mut [f64],
    pub grad: &'a mut [f64],
    pub stats: &'a mut SolverStats,
    /// Monomial coefficients of `q = w·u(θ)`.
    pub q: [f64; MAX_DEGREE + 1],
    /// `h² C`: bound of the explicit time part's curvature in θ units.
    pub time_curvature: f64,
    budget: u32,
}

impl<'a, S: HybridSystem> GuardOnStep<'a, S> {
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        sys: &'a S,
        index: usize,
        step: (f64, f64, f64),
        interp: (Method, &'a [f64]),
        y1: &'a [f64],
        ytmp: &'a mut [f64],
        g: &'a mut [f64],
        grad: &'a mut [f64],
        stats: &'a mut SolverStats,
        w: &[f64],
        time_curvature_bound: f64,
    ) -> Self {
        let mut q = [0.0; MAX_DEGREE + 1];
        dense::functional_polynomial(interp.0, interp.1, w, &mut q);
        let h = step.1;
        GuardOnStep {
            sys,
            index,
            step,
            interp,
            y1,
            ytmp,
            g,
            grad,
            stats,
            q,
            time_curvature: h * h * time_curvature_bound,
            budget: MAX_BISECTIONS,
        }
    }

    /// The time of step fraction `θ` (the step end exactly at `θ = 1`).
    pub fn time(&self, theta: f64) -> f64 {
        let (t0, h, t1) = self.step;
        if theta >= 1.0 {
            t1
        } else {
            (t0 + theta * h).min(t1)
        }
    }

    /// `q^{(k)}(θ)` by Horner on the monomial coefficients.
    fn q_derivative(&self, k: usize, theta: f64) -> f64 {
        let mut acc = 0.0;
        for j in (k..=MAX_DEGREE).rev() {
            acc = acc * theta + self.q[j] * falling(j, k);
        }
        acc
    }

    /// Guard slope `dG/dθ = q'(θ) + h ∂g/∂t`, with the state at `θ` already in `ytmp` (or `y1`).
    fn slope_at(&mut self, theta: f64, at_end: bool) -> f64 {
        let t = self.time(theta);
        let y = if at_end { self.y1 } else { &*self.ytmp };
        let dgdt = self
            .sys
            .guard_gradient(t, y, self.index, self.grad)
            .expect("affine guards provide guard_gradient (checked by the caller)");
        self.stats.guard_evals += 1;
        self.q_derivative(1, theta) + self.step.1 * dgdt
    }

    /// The guard and its slope at `θ`; `g_known` is the guard value when already evaluated.
    pub fn point(&mut self, theta: f64, g_known: Option<f64>) -> Point {
        let at_end = theta >= 1.0;
        let g = match g_known {
            Some(g) => {
                if !at_end {
                    self.interpolate(theta);
                }
                g
            }
            None => {
                let t = self.time(theta);
                if at_end {
                    self.sys.guards(t, self.y1, self.g);
                } else {
                    self.interpolate(theta);
                    self.sys.guards(t, self.ytmp, self.g);
                }
                self.stats.guard_evals += 1;
                self.g[self.index]
            }
        };
        let slope = self.slope_at(theta, at_end);
        Point {
            at: theta,
            g,
            slope,
        }
    }

    fn interpolate(&mut self, theta: f64) {
        dense::eval(self.interp.0, theta, self.interp.1, self.ytmp);
    }

    /// Enclosure `[L, U]` of `G''` on `[a, b]`.
    fn curvature(&self, a: f64, b: f64) -> (f64, f64) {
        // q'' as monomials, then its centred Taylor form about the midpoint.
        let mut c = [0.0; MAX_DEGREE - 1];
        for (j, cj) in c.iter_mut().enumerate() {
            *cj = self.q[j + 2] * ((j + 2) * (j + 1)) as f64;
        }
        let (lo, hi) = polynomial_range(&mut c, a, b);
        (lo - self.time_curvature, hi + self.time_curvature)
    }

    /// A bracket `(lo, hi)` of the first crossing in `[a, b]` (`G(lo) >= 0 > G(hi)`, one
    /// crossing inside), or `None` when `G` stays `>= 0` there. Requires `a.g >= 0`.
    pub fn first_crossing(&mut self, a: Point, b: Point) -> Option<(Point, Point)> {
        first_crossing::first_crossing(self, a, b)
    }
}

impl<S: HybridSystem> GuardAlong for GuardOnStep<'_, S> {
    fn evaluate(&mut self, theta: f64) -> Point {
        self.point(theta, None)
    }

    fn slope(&mut self, theta: f64) -> f64 {
        self.interpolate(theta);
        self.slope_at(theta, false)
    }

    fn curvature_range(&self, a: f64, b: f64) -> (f64, f64) {
        self.curvature(a, b)
    }

    /// The midpoint must split the step in time, not only in θ.
    fn splits(&self, a: f64, mid: f64, b: f64) -> bool {
        self.time(mid) > self.time(a) && self.time(mid) < self.time(b)
    }

    fn stationary_tolerance(&self) -> f64 {
        1e-12
    }

    fn budget(&mut self) -> &mut u32 {
        &mut self.budget
    }
}

/// `j (j − 1) ⋯ (j − k + 1)`.
fn falling(j: usize, k: usize) -> f64 {
    (0..k).map(|i| (j - i) as f64).product()
}
