//! Locating the first guard crossing inside one exactly propagated segment.
//!
//! The guards are linear in `z`, so each one is a sum of damped exponentials and sinusoids in
//! τ. They are sampled every `h` (a quarter of the fastest period of the mode, one cached
//! mat-vec `z + D_0 z` per sample; a sample's guard value and rate serve both intervals it
//! ends). Within each sample interval a guard that is not below zero at its start is decided
//! in the cheapest way that is still rigorous:
//!
//! 1. a bound `|g''| ≤ C` (per-mode weights, [`DerivativeRows::plain_curvature_bound`],
//!    then if needed [`DerivativeRows::tightened_curvature_bound`], one or two dots) and the
//!    two-sided Taylor minorant from the ends prove most intervals free;
//! 2. an interval that starts falling and ends below zero (the usual event interval) gets the
//!    guard's Taylor series ([`GuardSeries`]), a safeguarded Newton search on it from the root
//!    of the ends' cubic Hermite interpolant, and the same Taylor bound on `[0, root]`, whose
//!    right end is a guard value `>= 0`: if it holds, the root found is the first crossing;
//! 3. otherwise the rigorous search on the series: a curvature enclosure proves it
//!    non-negative, or bisection (left half first) brackets its first crossing
//!    ([`enclosure`]), also for a dip between two non-negative samples (grazing contact, a
//!    short excursion); Brent then locates the crossing on the series.
//!
//! With the sampled weights, step 1 decides the intervals after an event and step 2 the
//! event intervals of the `spur_pair` example, which separates every mesh period (the
//! term-by-term weights were ~5× above `max |g''|` and sent four intervals per period to step
//! 3; see `benches/features.rs`). A crossing needs a guard value `< 0`: a touch is not an
//! event, as in the RK event search (`src/solve/rk/graze.rs`).
//!
//! [`DerivativeRows::plain_curvature_bound`]: super::guard_series::DerivativeRows::plain_curvature_bound
//! [`DerivativeRows::tightened_curvature_bound`]: super::guard_series::DerivativeRows::tightened_curvature_bound
//! [`enclosure`]: super::enclosure

use super::enclosure::{taylor_lower_bound, GuardOnInterval, Point};
use super::guard_series::{dot, GuardSeries};
use super::mat_vec::mat_vec;
use super::transition::ModeTransitions;
use crate::solve::roots::{brent_bracket, newton_bracket};
use crate::solve::SolverStats;

/// Buffers of the crossing search, sized once per state dimension (no allocation per
/// segment).
#[derive(Default)]
pub struct Workspace {
    z_left: Vec<f64>,
    z_right: Vec<f64>,
    /// Per guard `(g, dg/dτ)` at the current interval's right end: the next interval's left
    /// end (the same state and row), so each sample costs two dots per guard, not four.
    right_ends: Vec<(f64, f64)>,
}

/// The first crossing: `τ*` just past it and the guard.
pub struct Crossing {
    pub tau: f64,
    pub index: usize,
}

/// The earliest crossing of a guard of `mode` (its `guard_rows`) in `(0, tau]` of the segment
/// from `z` (at time `t`), skipping guards in `excluded` (proved positive on the whole
/// segment). Without a crossing,
/// `z_end` receives the state at `tau` (computed only then: a segment cut short by an event
/// never pays for its end state).
#[allow(clippy::too_many_arguments)]
pub fn first_crossing(
    mode: &mut ModeTransitions,
    ws: &mut Workspace,
    stats: &mut SolverStats,
    t: f64,
    z: &[f64],
    z_end: &mut [f64],
    tau: f64,
    excluded: u64,
) -> Option<Crossing> {
    let nz = z.len();
    // The mode's guard rows were set when the mode was first met (the mode key fixes them).
    let m = mode.guard_rows.len();
    ws.z_left.resize(nz, 0.0);
    ws.z_right.resize(nz, 0.0);
    ws.right_ends.resize(m, (0.0, 0.0));
    let h = mode.sample_step;
    let tol = root_tolerance(t, tau);
    ws.z_left.copy_from_slice(z);
    let mut k = 0u64;
    loop {
        let left = k as f64 * h;
        let last = left + h >= tau;
        let width = if last { tau - left } else { h };
        if last {
            mode.apply(tau, z, z_end);
            ws.z_right.copy_from_slice(z_end);
        } else {
            mat_vec(mode.sample_increment(), &ws.z_left, &mut ws.z_right);
            for (r, l) in ws.z_right.iter_mut().zip(&ws.z_left) {
                *r += l;
            }
        }
        let mut best: Option<(f64, usize)> = None;
        for i in 0..m {
            if i < 64 && excluded & (1 << i) != 0 {
                continue;
            }
            let (rows, a, null_space) = mode.guard_rows_with_a(i);
            let (g_left, d_left) = if k == 0 {
                stats.guard_evals += 2;
                (
                    dot(rows.row(0), &ws.z_left),
                    rows.coefficient(a, 1, &ws.z_left),
                )
            } else {
                ws.right_ends[i]
            };
            let g_right = dot(rows.row(0), &ws.z_right);
            let d_right = rows.coefficient(a, 1, &ws.z_right);
            stats.guard_evals += 2;
            ws.right_ends[i] = (g_right, d_right);
            if g_left <= 0.0 && d_left <= 0.0 {
                // Only right after an event: the state sits on the surface, so the guard is
                // zero up to rounding and its direction decides. Not rising: the new mode is
                // invalid from the start (grazing): switch at once.
                best = Some((0.0, i));
                break;
            }
            // The cheap proof: the larger of the two Taylor minorants from the ends bounds
            // the guard below for |g''| ≤ C (σ units: C width²; a start on the surface,
            // rising, counts as zero).
            let ends = |sigma: f64, g: f64, slope: f64| Point {
                at: sigma,
                g,
                slope: slope * width,
            };
            let proves_free = |c: f64| {
                let start = ends(0.0, g_left.max(0.0), d_left);
                taylor_lower_bound(start, ends(1.0, g_right, d_right), -c) >= 0.0
            };
            // First with the weights alone: if that holds, the tightened bound (never larger)
            // would hold too, so the decision is the same.
            let plain = rows.plain_curvature_bound(a, null_space, h, &ws.z_left);
            stats.guard_evals += 1;
            if let Some(p) = plain.filter(|_| g_right >= 0.0) {
                if proves_free(p * width * width) {
                    continue;
                }
            }
            // Then with the mode's equilibrium directions removed from z.
            let curvature = plain.map(|p| {
                stats.guard_evals += 1;
                rows.tightened_curvature_bound(&ws.z_left, p) * width * width
            });
            let tighter = |c: &f64| plain.is_some_and(|p| *c < p * width * width);
            if let Some(c) = curvature.filter(|c| g_right >= 0.0 && tighter(c)) {
                if proves_free(c) {
                    continue;
                }
            }
            let series = GuardSeries::from_rows(rows, a, &ws.z_left, width);
            stats.guard_evals += series.terms() as u64;
            let start = Point {
                at: 0.0,
                g: g_left.max(0.0),
                slope: d_left * width,
            };
            let end = Point {
                at: 1.0,
                g: g_right,
                slope: d_right * width,
            };
            let found = crossing_on_series(&series, start, end, curvature, tol, stats);
            if let Some(after) = found {
                if best.is_none_or(|(s_best, _)| after < s_best) {
                    best = Some((after, i));
                }
            }
        }
        if let Some((after, index)) = best {
            return Some(Crossing {
                tau: left + after,
                index,
            });
        }
        if last {
            return None;
        }
        std::mem::swap(&mut ws.z_left, &mut ws.z_right);
        k += 1;
    }
}

/// The first crossing of one guard on one interval of width `series.width()` (`σ ∈ [0, 1]`),
/// given its series, its ends `start` (value clamped to `>= 0`) and `end` (slopes in `σ`
/// units) and a curvature bound `C ≥ |d²g/dσ²|` if known: `τ` just past the crossing (from
/// the interval's start, in s), or `None` when the guard stays `>= 0`.
///
/// Root first, then the proof that it is the first: on a falling start the crossing the root
/// search finds is the first one when the guard provably stays `>= 0` before it (the cheap
/// Taylor bound on `[0, root]`, whose right end is a guard value `>= 0`). The usual event
/// interval needs no enclosure or bisection then. Otherwise the rigorous search: enclosures
/// and bisection, left half first, then Brent on its bracket (the bracket holds one crossing,
/// but an end at the rounding level of the guard can look like another: Brent's bisection
/// steps do not settle there, where a Newton iteration may).
pub(super) fn crossing_on_series(
    series: &GuardSeries,
    start: Point,
    end: Point,
    curvature: Option<f64>,
    tol: f64,
    stats: &mut SolverStats,
) -> Option<f64> {
    let width = series.width();
    let verified = match curvature {
        Some(c) if end.g < 0.0 && start.slope < 0.0 => {
            let (after, at_root) = newton_on_series(series, start, end, tol, stats);
            (at_root.g >= 0.0 && taylor_lower_bound(start, at_root, -c) >= 0.0).then_some(after)
        }
        _ => None,
    };
    verified.or_else(|| {
        let mut guard = GuardOnInterval::new(series, curvature);
        // Both ends' slopes from the series (they agree with the given ones up to rounding).
        let start = Point {
            slope: series.slope_sigma(0.0),
            ..start
        };
        let end = Point {
            slope: series.slope_sigma(1.0),
            ..end
        };
        let bracket = guard.first_crossing(start, end);
        stats.guard_evals += guard.evals;
        bracket.map(|(lo, hi)| {
            let mut evals = 0u64;
            let (_, after) = brent_bracket(
                |s| {
                    evals += 1;
                    series.value(s)
                },
                lo.at * width,
                hi.at * width,
                lo.g,
                hi.g,
                tol,
            );
            stats.guard_evals += evals;
            after
        })
    })
}

/// The tolerance of an event time in the segment of duration `tau` from `t`: a few ulps of
/// the time itself.
pub fn root_tolerance(t: f64, tau: f64) -> f64 {
    4.0 * f64::EPSILON * (t.abs() + tau)
}

/// The root of the cubic Hermite interpolant of the ends on `[0, 1]` (`start.g > 0 > end.g`),
/// by Newton from the secant point: the start of the root search on the series (it uses the
/// end slopes the sampling computed anyway, and saves about one series evaluation per event
/// over the secant point on `spur_pair`); NaN if it leaves the interval.
fn hermite_root(start: Point, end: Point) -> f64 {
    let (p0, m0, p1, m1) = (start.g, start.slope, end.g, end.slope);
    let mut x = p0 / (p0 - p1);
    for _ in 0..4 {
        let (x2, x3) = (x * x, x * x * x);
        let value = (2.0 * x3 - 3.0 * x2 + 1.0) * p0
            + (x3 - 2.0 * x2 + x) * m0
            + (3.0 * x2 - 2.0 * x3) * p1
            + (x3 - x2) * m1;
        let slope = (6.0 * x2 - 6.0 * x) * (p0 - p1)
            + (3.0 * x2 - 4.0 * x + 1.0) * m0
            + (3.0 * x2 - 2.0 * x) * m1;
        x -= value / slope;
    }
    if x > 0.0 && x < 1.0 {
        x
    } else {
        f64::NAN
    }
}

/// Safeguarded Newton on the series over the whole interval, `start` at `σ = 0` and `end` at
/// `σ = 1` (`start.g > 0 > end.g`):
/// `τ` just past the crossing it finds (from the segment's sample interval start, in s) and
/// the guard with its slope at the bracket's left end (Newton's own evaluation there, or the
/// start when the search never left it), for the proof that no crossing precedes it.
fn newton_on_series(
    series: &GuardSeries,
    start: Point,
    end: Point,
    tol: f64,
    stats: &mut SolverStats,
) -> (f64, Point) {
    debug_assert!(start.at == 0.0 && end.at == 1.0);
    let width = series.width();
    let mut last_nonnegative: Option<(f64, Point)> = None;
    let (before, after) = newton_bracket(
        |s| {
            stats.guard_evals += 2;
            let (g, slope) = series.value_and_slope(s);
            if g >= 0.0 {
                let at = s / width;
                last_nonnegative = Some((
                    s,
                    Point {
                        at,
                        g,
                        slope: slope * width,
                    },
                ));
            }
            (g, slope)
        },
        start.at * width,
        end.at * width,
        start.g,
        end.g,
        hermite_root(start, end) * width,
        tol,
    );
    let at_root = match last_nonnegative {
        Some((s, p)) if s == before => p,
        _ if before == start.at * width => start,
        _ => {
            stats.guard_evals += 2;
            let (g, slope) = series.value_and_slope(before);
            Point {
                at: before / width,
                g,
                slope: slope * width,
            }
        }
    };
    (after, at_root)
}
