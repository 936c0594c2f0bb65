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
//! bisected, left half first, so the crossing found is the first one. This is the method of
//! the RK event search (`src/solve/rk/graze.rs`), where the polynomial is the dense output;
//! the two helpers below are duplicated from there because the RK module is shared with the
//! step-size control and the exact propagator must not depend on it.
//!
//! Touching (`min p = 0`) is not an event: every decision rests on an evaluated guard value
//! below zero; bounds only prune.

use super::guard_series::GuardSeries;
use crate::solve::roots::brent_bracket;

/// Bisections allowed per guard and interval before an undecided interval is given up (it
/// is then at the rounding level of the guard: a touch).
const MAX_BISECTIONS: u32 = 64;

/// The guard and its slope `dp/dσ` at `σ`.
#[derive(Debug, Clone, Copy)]
pub struct Point {
    pub sigma: f64,
    pub g: f64,
    pub slope: f64,
}

/// One guard's polynomial over one sample interval.
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

    pub fn point(&mut self, sigma: f64) -> Point {
        self.evals += 2;
        Point {
            sigma,
            g: self.series.value_sigma(sigma),
            slope: self.series.slope_sigma(sigma),
        }
    }

    /// A bracket `(lo, hi)` of the first crossing in `[a, b]` (`p(lo) >= 0 > p(hi)`, one
    /// crossing inside), or `None` when `p` stays `>= 0` there. Requires `a.g >= 0`.
    pub fn first_crossing(&mut self, a: Point, b: Point) -> Option<(Point, Point)> {
        if let Some(c) = self.curvature_bound {
            if b.g >= 0.0 && taylor_lower_bound(a, b, -c) >= 0.0 {
                return None;
            }
        }
        let (lower, upper) = self.series.curvature_range(a.sigma, b.sigma);
        let width = b.sigma - a.sigma;
        let mid_sigma = a.sigma + 0.5 * width;
        let resolvable = self.budget > 0 && mid_sigma > a.sigma && mid_sigma < b.sigma;
        if b.g < 0.0 {
            if upper <= 0.0 && a.slope > 0.0 && b.slope < 0.0 {
                // Concave and rising first: the crossing lies after the maximum. Bracketing
                // from the maximum keeps Brent away from a start on the surface (a guard
                // snapped onto it at an event, where it is rounding noise).
                let top = self.stationary(a, b, false);
                return Some(if top.g >= 0.0 { (top, b) } else { (a, top) });
            }
            // Convex or concave: one crossing from >= 0 to < 0.
            if lower >= 0.0 || upper <= 0.0 || !resolvable {
                return Some((a, b));
            }
        } else {
            if lower >= 0.0 {
                return self.convex_dip(a, b);
            }
            // (An unbounded curvature, the `expm` fallback, proves nothing: bisect.)
            if (lower.is_finite() && taylor_lower_bound(a, b, lower) >= 0.0) || !resolvable {
                return None;
            }
        }
        self.budget -= 1;
        let mid = self.point(mid_sigma);
        if mid.g < 0.0 {
            return self.first_crossing(a, mid);
        }
        self.first_crossing(a, mid)
            .or_else(|| self.first_crossing(mid, b))
    }

    /// On a convex interval with `p >= 0` at both ends, the only possible crossing is around
    /// the minimum, where `p'` changes sign from − to +.
    fn convex_dip(&mut self, a: Point, b: Point) -> Option<(Point, Point)> {
        if !(a.slope < 0.0 && b.slope > 0.0) {
            return None;
        }
        let lowest = self.stationary(a, b, true);
        (lowest.g < 0.0).then_some((a, lowest))
    }

    /// The stationary point between `a` and `b`, whose slopes have opposite signs (Brent on
    /// `p'`): of the two ends of the final bracket, the one with the lower (`minimum`) or
    /// higher guard value.
    fn stationary(&mut self, a: Point, b: Point, minimum: bool) -> Point {
        let series = self.series;
        let mut evals = 0;
        let tol = 1e-13 * (b.sigma - a.sigma);
        let (before, after) = brent_bracket(
            |sigma| {
                evals += 1;
                series.slope_sigma(sigma)
            },
            a.sigma,
            b.sigma,
            a.slope,
            b.slope,
            tol,
        );
        self.evals += evals;
        let [p, r] = [before, after].map(|sigma| self.point(sigma));
        if (p.g <= r.g) == minimum {
            p
        } else {
            r
        }
    }
}

/// Enclosure of the polynomial with monomial coefficients `c` (overwritten) on `[a, b]`: its
/// Taylor expansion about the midpoint `m`, `p(m) ± Σ_{k≥1} |p^{(k)}(m)/k!| r^k`.
pub fn polynomial_range(c: &mut [f64], a: f64, b: f64) -> (f64, f64) {
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

/// Lower bound of `p` on `[a, b]` when `p'' >= lower` (`lower < 0`): the minimum of the larger
/// of the two Taylor minorants from the ends. Their difference is linear in `s = σ − a`, so
/// the larger one switches once, at `s*`, and the bound is `min(p(a), p(b), A(s*))`.
pub fn taylor_lower_bound(a: Point, b: Point, lower: f64) -> f64 {
    let w = b.sigma - a.sigma;
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
        let coefficients = [1.0, -3.0, 0.0, 2.0];
        let (lo, hi) = polynomial_range(&mut coefficients.clone(), 0.2, 0.9);
        for i in 0..=100 {
            let x = 0.2 + 0.7 * i as f64 / 100.0;
            let p = 1.0 - 3.0 * x + 2.0 * x * x * x;
            assert!(lo <= p && p <= hi, "{lo} <= {p} <= {hi}");
        }
    }

    #[test]
    fn taylor_bound_is_below_a_parabola() {
        for d in [-0.3, -0.01, 0.01, 0.1] {
            let g = |x: f64| (x - 0.5) * (x - 0.5) - d;
            let point = |x: f64| Point {
                sigma: x,
                g: g(x),
                slope: 2.0 * (x - 0.5),
            };
            assert!(taylor_lower_bound(point(0.0), point(1.0), -1.0) <= -d);
            let close = taylor_lower_bound(point(0.0), point(1.0), 1.99);
            assert!(close <= -d && close >= -d - 0.01, "d = {d}: {close}");
        }
    }
}
