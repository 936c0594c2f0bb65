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
//! Touching (`min G = 0`) is not an event, as for the exact propagator
//! (`src/solve/exact.rs`, `dip`: a crossing needs a guard value `< 0`): every decision here
//! rests on an evaluated guard value below zero; bounds only prune.

use super::dense::{self, MAX_DEGREE};
use super::Method;
use crate::solve::roots::brent_bracket;
use crate::solve::{HybridSystem, SolverStats};

/// Bisections allowed per guard and step before an undecided interval is given up (it is
/// then at the rounding level of the guard: a touch).
const MAX_BISECTIONS: u32 = 64;

/// The guard and its slope `dG/dθ` at `θ`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Point {
    pub theta: f64,
    pub g: f64,
    pub slope: f64,
}

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
        Point { theta, g, slope }
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
        let (lower, upper) = self.curvature(a.theta, b.theta);
        let width = b.theta - a.theta;
        let resolvable = self.budget > 0
            && self.time(a.theta + 0.5 * width) > self.time(a.theta)
            && self.time(a.theta + 0.5 * width) < self.time(b.theta);
        if b.g < 0.0 {
            if upper <= 0.0 && a.slope > 0.0 && b.slope < 0.0 {
                // Concave and rising first: the crossing lies after the maximum. Bracketing
                // from the maximum keeps the root search away from a start on the surface (a
                // guard snapped onto it at an event), where the guard is rounding noise and a
                // secant step would stop right there (an event storm).
                let top = self.stationary(a, b, false);
                return Some(if top.g >= 0.0 { (top, b) } else { (a, top) });
            }
            // Convex or concave: the set where G < 0 (resp. >= 0) is one interval, so there is
            // one crossing from >= 0 to < 0.
            if lower >= 0.0 || upper <= 0.0 || !resolvable {
                return Some((a, b));
            }
        } else {
            if lower >= 0.0 {
                return self.convex_dip(a, b);
            }
            if taylor_lower_bound(a, b, lower) >= 0.0 || !resolvable {
                return None;
            }
        }
        self.budget -= 1;
        let mid = self.point(a.theta + 0.5 * width, None);
        if mid.g < 0.0 {
            return self.first_crossing(a, mid);
        }
        self.first_crossing(a, mid)
            .or_else(|| self.first_crossing(mid, b))
    }

    /// On a convex interval with `G >= 0` at both ends, the only possible crossing is around
    /// the minimum, where `G'` changes sign from − to +.
    fn convex_dip(&mut self, a: Point, b: Point) -> Option<(Point, Point)> {
        if !(a.slope < 0.0 && b.slope > 0.0) {
            return None;
        }
        let lowest = self.stationary(a, b, true);
        (lowest.g < 0.0).then_some((a, lowest))
    }

    /// The stationary point between `a` and `b`, whose slopes have opposite signs (Brent on
    /// `G'`): of the two ends of the final bracket, the one with the lower (`minimum`) or
    /// higher guard value.
    fn stationary(&mut self, a: Point, b: Point, minimum: bool) -> Point {
        let mut slope = |theta: f64| {
            self.interpolate(theta);
            self.slope_at(theta, false)
        };
        let tol = 1e-12 * (b.theta - a.theta);
        let (before, after) = brent_bracket(&mut slope, a.theta, b.theta, a.slope, b.slope, tol);
        let [p, r] = [before, after].map(|theta| self.point(theta, None));
        if (p.g <= r.g) == minimum {
            p
        } else {
            r
        }
    }
}

/// `j (j − 1) ⋯ (j − k + 1)`.
fn falling(j: usize, k: usize) -> f64 {
    (0..k).map(|i| (j - i) as f64).product()
}

/// Enclosure of the polynomial with monomial coefficients `c` (overwritten) on `[a, b]`: its
/// Taylor expansion about the midpoint `m`, `p(m) ± Σ_{k≥1} |p^{(k)}(m)/k!| r^k`.
fn polynomial_range(c: &mut [f64], a: f64, b: f64) -> (f64, f64) {
    let m = 0.5 * (a + b);
    let r = 0.5 * (b - a);
    let n = c.len() - 1;
    // Taylor shift: c becomes the coefficients of p(m + s).
    for i in 0..n {
        for j in (i..n).rev() {
            c[j] += m * c[j + 1];
        }
    }
    let mut spread = 0.0;
    let mut rk = 1.0;
    for ck in &c[1..] {
        rk *= r;
        spread += ck.abs() * rk;
    }
    (c[0] - spread, c[0] + spread)
}

/// Lower bound of `G` on `[a, b]` when `G'' >= lower` (`lower < 0`): the minimum of the larger
/// of the two Taylor minorants from the ends. Their difference is linear in `s = θ − a`, so the
/// larger one switches once, at `s*`, and the bound is `min(G(a), G(b), A(s*))`.
fn taylor_lower_bound(a: Point, b: Point, lower: f64) -> f64 {
    let w = b.theta - a.theta;
    let ends = a.g.min(b.g);
    // A(s) − B(s) = a.g − b.g + b.slope w − L w²/2 + s (a.slope − b.slope + L w).
    let kappa = a.slope - b.slope + lower * w;
    let offset = a.g - b.g + b.slope * w - 0.5 * lower * w * w;
    if kappa == 0.0 {
        return ends;
    }
    let s = -offset / kappa;
    if !(s > 0.0 && s < w) {
        return ends;
    }
    ends.min(a.g + a.slope * s + 0.5 * lower * s * s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn polynomial_range_encloses_the_values() {
        // p(θ) = 1 − 3θ + 2θ³ on [0.2, 0.9].
        let coefficients = [1.0, -3.0, 0.0, 2.0];
        let (lo, hi) = polynomial_range(&mut coefficients.clone(), 0.2, 0.9);
        for i in 0..=100 {
            let x = 0.2 + 0.7 * i as f64 / 100.0;
            let p = 1.0 - 3.0 * x + 2.0 * x * x * x;
            assert!(lo <= p && p <= hi, "{lo} <= {p} <= {hi}");
        }
        // Enclosures tighten on small intervals.
        let (lo, hi) = polynomial_range(&mut coefficients.clone(), 0.5, 0.5 + 1e-6);
        assert!(hi - lo < 1e-5);
    }

    #[test]
    fn taylor_bound_is_below_the_function_and_decides_a_parabola() {
        // G(θ) = (θ − 0.5)² − d has G'' = 2; with L = −1 the bound must still lie below it.
        for d in [-0.3, -0.01, 0.01, 0.1] {
            let g = |x: f64| (x - 0.5) * (x - 0.5) - d;
            let point = |x: f64| Point {
                theta: x,
                g: g(x),
                slope: 2.0 * (x - 0.5),
            };
            let bound = taylor_lower_bound(point(0.0), point(1.0), -1.0);
            assert!(bound <= -d, "d = {d}: bound {bound}");
            // With a curvature bound close to the true one, the bound is close to the minimum.
            let close = taylor_lower_bound(point(0.0), point(1.0), 1.99);
            assert!(close <= -d && close >= -d - 0.01, "d = {d}: {close}");
        }
    }
}
