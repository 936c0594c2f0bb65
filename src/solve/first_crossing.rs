//! Rigorous search for the first zero crossing of one guard over one interval, shared by the
//! RK event search (`rk/graze.rs`: the guard along a step's interpolant) and the exact
//! propagator (`exact/enclosure.rs`: the guard's Taylor polynomial over a sample interval), so
//! that a dip between two samples (a grazing contact, a short excursion) is not missed however
//! deep or narrow it is (numerics notes §5, S7/S9).
//!
//! On `[a, b]` the guard's curvature is enclosed, `L ≤ G'' ≤ U` ([`GuardAlong::curvature_range`]);
//! with the end values and slopes the guard is bounded below by the larger of its two Taylor
//! minorants `G(a) + G'(a)(x − a) + L(x − a)²/2` and `G(b) − G'(b)(b − x) + L(b − x)²/2`, whose
//! difference is linear, so the bound is one closed-form value ([`taylor_lower_bound`]). A
//! bound `≥ 0` proves there is no crossing (the usual case); a convex interval (`L ≥ 0`) is
//! decided by the root of `G'` (Brent) and the guard there; otherwise the interval is bisected,
//! left half first, so the crossing found is the first one. A bracket never ends at a point
//! where the guard returns to the surface: on a concave interval rising first it starts at the
//! maximum, on a convex one rising at the end it stops at the minimum (at such points the guard
//! is rounding noise of either sign, on which a root search may stop).
//!
//! Touching (`min G = 0`) is not an event: every decision rests on an evaluated guard value
//! below zero; bounds only prune.

use super::roots::brent_bracket;

/// Bisections allowed per guard and interval before an undecided interval is given up (it is
/// then at the rounding level of the guard: a touch).
pub const MAX_BISECTIONS: u32 = 64;

/// The guard and its slope at the local coordinate `at`.
#[derive(Debug, Clone, Copy)]
pub struct Point {
    pub at: f64,
    pub g: f64,
    pub slope: f64,
}

/// One guard along one interval of a local coordinate.
pub trait GuardAlong {
    /// The guard and its slope at `at`.
    fn evaluate(&mut self, at: f64) -> Point;
    /// Only the slope at `at` (stationary-point search).
    fn slope(&mut self, at: f64) -> f64;
    /// Enclosure `[L, U]` of the guard's curvature on `[a, b]` (`L = −∞` when unknown).
    fn curvature_range(&self, a: f64, b: f64) -> (f64, f64);
    /// A bound `C ≥ |G''|` on the whole interval, if known: the cheap first test.
    fn curvature_bound(&self) -> Option<f64> {
        None
    }
    /// Whether `mid` splits `[a, b]` into two non-empty pieces.
    fn splits(&self, a: f64, mid: f64, b: f64) -> bool {
        mid > a && mid < b
    }
    /// Width-relative tolerance of the stationary-point search.
    fn stationary_tolerance(&self) -> f64;
    /// Bisections left.
    fn budget(&mut self) -> &mut u32;
}

/// A bracket `(lo, hi)` of the first crossing in `[a, b]` (`G(lo) >= 0 > G(hi)`, one crossing
/// inside), or `None` when `G` stays `>= 0` there. Requires `a.g >= 0`.
pub fn first_crossing<G: GuardAlong>(guard: &mut G, a: Point, b: Point) -> Option<(Point, Point)> {
    if let Some(c) = guard.curvature_bound() {
        if b.g >= 0.0 && taylor_lower_bound(a, b, -c) >= 0.0 {
            return None;
        }
    }
    let (lower, upper) = guard.curvature_range(a.at, b.at);
    let mid_at = a.at + 0.5 * (b.at - a.at);
    let resolvable = *guard.budget() > 0 && guard.splits(a.at, mid_at, b.at);
    if b.g < 0.0 {
        if upper <= 0.0 && a.slope > 0.0 && b.slope < 0.0 {
            // Concave and rising first: the crossing lies after the maximum. Bracketing from
            // the maximum keeps the root search away from a start on the surface (a guard
            // snapped onto it at an event, where it is rounding noise and a secant step would
            // stop right there: an event storm).
            let top = stationary(guard, a, b, false);
            return Some(if top.g >= 0.0 { (top, b) } else { (a, top) });
        }
        if lower >= 0.0 && a.slope < 0.0 && b.slope > 0.0 {
            // Convex and rising at the end: the crossing lies before the minimum. Bracketing
            // to the minimum keeps the root search away from an end where the guard returns
            // to the surface (a grazing dip that closes at the sample point: there it is
            // rounding noise of either sign, and a root search may stop on it).
            let bottom = stationary(guard, a, b, true);
            return Some(if bottom.g < 0.0 {
                (a, bottom)
            } else {
                (bottom, b)
            });
        }
        // Convex or concave: the set where G < 0 (resp. >= 0) is one interval, so there is one
        // crossing from >= 0 to < 0.
        if lower >= 0.0 || upper <= 0.0 || !resolvable {
            return Some((a, b));
        }
    } else {
        if lower >= 0.0 {
            return convex_dip(guard, a, b);
        }
        // (An unbounded curvature proves nothing: bisect.)
        if (lower.is_finite() && taylor_lower_bound(a, b, lower) >= 0.0) || !resolvable {
            return None;
        }
    }
    *guard.budget() -= 1;
    let mid = guard.evaluate(mid_at);
    if mid.g < 0.0 {
        return first_crossing(guard, a, mid);
    }
    first_crossing(guard, a, mid).or_else(|| first_crossing(guard, mid, b))
}

/// On a convex interval with `G >= 0` at both ends, the only possible crossing is around the
/// minimum, where `G'` changes sign from − to +.
fn convex_dip<G: GuardAlong>(guard: &mut G, a: Point, b: Point) -> Option<(Point, Point)> {
    if !(a.slope < 0.0 && b.slope > 0.0) {
        return None;
    }
    let lowest = stationary(guard, a, b, true);
    (lowest.g < 0.0).then_some((a, lowest))
}

/// The stationary point between `a` and `b`, whose slopes have opposite signs (Brent on `G'`):
/// of the two ends of the final bracket, the one with the lower (`minimum`) or higher value.
fn stationary<G: GuardAlong>(guard: &mut G, a: Point, b: Point, minimum: bool) -> Point {
    let tol = guard.stationary_tolerance() * (b.at - a.at);
    let (before, after) = brent_bracket(|x| guard.slope(x), a.at, b.at, a.slope, b.slope, tol);
    let [p, r] = [before, after].map(|x| guard.evaluate(x));
    if (p.g <= r.g) == minimum {
        p
    } else {
        r
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

/// Lower bound of `G` on `[a, b]` when `G'' >= lower` (`lower < 0`): the minimum of the larger
/// of the two Taylor minorants from the ends. Their difference is linear in `s = x − a`, so the
/// larger one switches once, at `s*`, and the bound is `min(G(a), G(b), A(s*))`.
pub fn taylor_lower_bound(a: Point, b: Point, lower: f64) -> f64 {
    let w = b.at - a.at;
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
        // p(x) = 1 − 3x + 2x³ on [0.2, 0.9].
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
        // G(x) = (x − 0.5)² − d has G'' = 2; with L = −1 the bound must still lie below it.
        for d in [-0.3, -0.01, 0.01, 0.1] {
            let g = |x: f64| (x - 0.5) * (x - 0.5) - d;
            let point = |x: f64| Point {
                at: x,
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

    /// A parabola dipping below zero in the middle of an interval whose ends are positive
    /// with slopes of opposite sign is found; one that stays above is not.
    struct Parabola {
        depth: f64,
        budget: u32,
    }

    impl GuardAlong for Parabola {
        fn evaluate(&mut self, at: f64) -> Point {
            Point {
                at,
                g: (at - 0.5) * (at - 0.5) - self.depth,
                slope: 2.0 * (at - 0.5),
            }
        }
        fn slope(&mut self, at: f64) -> f64 {
            2.0 * (at - 0.5)
        }
        fn curvature_range(&self, _: f64, _: f64) -> (f64, f64) {
            (2.0, 2.0)
        }
        fn stationary_tolerance(&self) -> f64 {
            1e-13
        }
        fn budget(&mut self) -> &mut u32 {
            &mut self.budget
        }
    }

    #[test]
    fn a_dip_between_positive_ends_is_found() {
        for (depth, crosses) in [(1e-6, true), (0.2, true), (-1e-6, false)] {
            let mut guard = Parabola {
                depth,
                budget: MAX_BISECTIONS,
            };
            let (a, b) = (guard.evaluate(0.0), guard.evaluate(1.0));
            let found = first_crossing(&mut guard, a, b);
            assert_eq!(found.is_some(), crosses, "depth {depth}");
            if let Some((lo, hi)) = found {
                assert!(lo.g >= 0.0 && hi.g < 0.0 && lo.at < 0.5, "{lo:?} {hi:?}");
            }
        }
    }
}
