//! Segments of a mode whose transitions are not built: the state's Taylor series on the
//! balanced matrix, and each guard's first crossing on its polynomial.
//!
//! A drivetrain with contact loss on many meshes meets thousands of modes (the 8-mesh
//! benchmark chain: 16 stiffness patterns × 2⁸ contact states), each a few times per thousand
//! mesh periods and in no periodic order. Building a mode's transitions
//! ([`super::transition::ModeTransitions`]: the Padé sample step `e^{Ah}`, its duration
//! bins, the guards' curvature weights and derivative rows, the equilibrium directions) costs
//! ~100 µs there, and when the mode comes back its data is cold. A segment of such a scene is
//! short against the fastest period (`θ = ‖B‖₁ τ ≈ 0.3` on the chain), so the series of
//! `e^{Bτ}` applied to the state settles in about a dozen mat-vecs, and the guards'
//! polynomials come with it: one dot per guard and term.
//!
//! Per sub-step of width `w` (`θ = ‖B‖₁ w ≤` [`THETA_MAX`], `B = D⁻¹ A D` the mode's balanced
//! matrix): `u_0 = D⁻¹ z`, `u_k = B u_{k−1} w / k`, until the rigorous bound of the remaining
//! terms from the last one, `‖u_K‖₁ (θ/(K+1)) / (1 − θ/(K+2))`, is below `2⁻⁵⁴ ‖u_0‖₁`
//! ([`super::balanced::BalancedMatrix::taylor_terms`]). Guard `i`'s polynomial in `σ = s / w ∈ [0, 1]` is `p(σ) = Σ d_k σ^k`,
//! `d_k = (c_i ∘ D) · u_k`, and is decided as in [`super::crossing`], cheapest proof first:
//!
//! 1. a start on the surface that is not rising is a crossing at once;
//! 2. `d_0 − Σ_{k≥1} |d_k| ≥ 0` (the guard cannot move further than its terms): free;
//! 3. the two-sided Taylor minorant from the ends with `C = Σ_{k≥2} k(k−1)|d_k| ≥ |p''|`:
//!    free if it stays `≥ 0`;
//! 4. otherwise the root search on the polynomial ([`super::crossing::crossing_on_series`]).
//!
//! The state at a crossing or at the sub-step's end is `D Σ u_k σ^k`. Both paths are exact to
//! rounding (the bins' Padé exponential and this series agree to a few ulps), not to the same
//! last bit. Which one a mode takes is fixed at its first meeting: the full path while the
//! modes promoted to it stay within their memory budget (`ModeCache::PROMOTED_BUDGET`), the
//! series beyond; so it depends only on the order in which modes were met since the cache was
//! last cleared, and a restored run repeats it ([`super::ExactPropagator`]).

use super::balanced::{sum_terms, MAX_TERMS};
use super::crossing::{crossing_on_series, root_tolerance, Crossing};
use super::enclosure::{taylor_lower_bound, Point};
use super::guard_series::{dot_in_lanes, GuardSeries};
use super::transition::ModeTransitions;
use crate::solve::SolverStats;

/// Largest `θ = ‖B‖₁ w` of one sub-step: about the guard sample step of a built mode
/// (`‖B‖₁ h ≈ 1.5` on the drivetrains), so the curvature bound of step 3, which grows like
/// `e^θ` over the guard's true curvature, stays within a few times of it; ~22 terms.
pub const THETA_MAX: f64 = 2.0;

/// Buffers of the series search, sized once per state dimension.
#[derive(Default)]
pub struct SeriesWorkspace {
    /// The balanced Taylor terms `u_k` of the current sub-step, `k`-th at `[k n, (k+1) n)`.
    terms: Vec<f64>,
    /// One guard's coefficients `d_k`.
    coefficients: Vec<f64>,
    /// Per state component `Σ_{k≥1} |u_k|` of the current sub-step.
    travel: Vec<f64>,
}

/// Guard samples of a built mode ([`super::MAX_GUARD_SAMPLES_PER_ADVANCE`]) one sub-step is
/// charged as: a sample costs one mat-vec and a few dots per guard, a sub-step ~20 mat-vecs
/// and its coefficients, so the bound of one advance stays a bound on its time.
pub const SAMPLES_PER_SUB_STEP: f64 = 16.0;

/// The work of a segment of `tau` in `mode` in guard samples ([`SAMPLES_PER_SUB_STEP`]).
pub fn work_in_samples(mode: &ModeTransitions, tau: f64) -> f64 {
    (tau * mode.balanced().norm() / THETA_MAX).ceil().max(1.0) * SAMPLES_PER_SUB_STEP
}

/// Whether the series can propagate `mode` (its balanced matrix is finite).
pub fn applies(mode: &ModeTransitions) -> bool {
    mode.balanced().norm().is_finite()
}

/// The earliest crossing of a guard of `mode` in `(0, tau]` of the segment from `z` (at time
/// `t`), skipping the guards in `excluded`. `z_out` receives the state at the crossing, or
/// at `tau` when there is none.
#[allow(clippy::too_many_arguments)]
pub fn first_crossing_by_series(
    mode: &ModeTransitions,
    ws: &mut SeriesWorkspace,
    stats: &mut SolverStats,
    t: f64,
    z: &[f64],
    z_out: &mut [f64],
    tau: f64,
    excluded: u64,
) -> Option<Crossing> {
    let balanced = mode.balanced();
    let (scale, norm) = (balanced.scale(), balanced.norm());
    let n = z.len();
    let m = mode.guard_rows.len();
    ws.terms.resize((MAX_TERMS + 1) * n, 0.0);

    ws.coefficients.resize(MAX_TERMS + 1, 0.0);
    ws.travel.resize(n, 0.0);
    let rows = mode.balanced_guard_rows();
    // The balanced state at the sub-step's start.
    for ((u, &x), &d) in ws.terms[..n].iter_mut().zip(z).zip(scale) {
        *u = x / d;
    }
    let width_max = if norm > 0.0 {
        THETA_MAX / norm
    } else {
        f64::INFINITY
    };
    let tol = root_tolerance(t, tau);
    let mut left = 0.0;
    loop {
        let last = left + width_max >= tau;
        let w = if last { tau - left } else { width_max };
        let count = balanced.taylor_terms(w, n, &mut ws.terms);

        // Step 2 for every guard at once, before any coefficient beyond `d_0`:
        // `Σ_{k≥1} |d_k| ≤ |c_i ∘ D| · Σ_{k≥1} |u_k|`.
        ws.travel.fill(0.0);
        for term in ws.terms[n..count * n].chunks_exact(n) {
            for (t, &u) in ws.travel.iter_mut().zip(term) {
                *t += u.abs();
            }
        }
        let mut best: Option<(f64, usize)> = None;
        for i in 0..m {
            if i < 64 && excluded & (1 << i) != 0 {
                continue;
            }
            let row = &rows[i * n..(i + 1) * n];
            let d0 = dot_in_lanes(row, &ws.terms[..n]);
            stats.guard_evals += 1;
            if d0 > 0.0 {
                let reach: f64 = row.iter().zip(&ws.travel).map(|(c, t)| c.abs() * t).sum();
                if d0 - reach >= 0.0 {
                    continue;
                }
            }
            let d = &mut ws.coefficients[..count];
            d[0] = d0;
            for (k, dk) in d.iter_mut().enumerate().skip(1) {
                *dk = dot_in_lanes(row, &ws.terms[k * n..(k + 1) * n]);
            }
            stats.guard_evals += count as u64 - 1;
            let d1 = d.get(1).copied().unwrap_or(0.0);
            if d0 <= 0.0 && d1 <= 0.0 {
                // On the surface and not rising (right after an event, or grazing): the
                // mode is invalid from the start, switch at once (as `crossing.rs`).
                best = Some((0.0, i));
                break;
            }
            // A start on the surface, rising, counts as zero (as `crossing.rs`).
            let g0 = d0.max(0.0);
            let travel: f64 = d[1..].iter().map(|x| x.abs()).sum();
            if g0 - travel >= 0.0 {
                continue;
            }
            let (mut g1, mut slope1, mut curvature) = (0.0, 0.0, 0.0);
            for (k, &dk) in d.iter().enumerate() {
                g1 += dk;
                slope1 += k as f64 * dk;
                curvature += (k * k.saturating_sub(1)) as f64 * dk.abs();
            }
            let start = Point {
                at: 0.0,
                g: g0,
                slope: d1,
            };
            let end = Point {
                at: 1.0,
                g: g1,
                slope: slope1,
            };
            if g1 >= 0.0 && taylor_lower_bound(start, end, -curvature) >= 0.0 {
                continue;
            }
            let series = GuardSeries::from_coefficients(d, w);
            if let Some(after) =
                crossing_on_series(&series, start, end, Some(curvature), tol, stats)
            {
                if best.is_none_or(|(s_best, _)| after < s_best) {
                    best = Some((after, i));
                }
            }
        }
        if let Some((after, index)) = best {
            let sigma = if w > 0.0 { after / w } else { 0.0 };
            sum_terms(&ws.terms[..count * n], n, sigma, z_out);
            for (x, &d) in z_out.iter_mut().zip(scale) {
                *x *= d;
            }
            return Some(Crossing {
                tau: left + after,
                index,
            });
        }
        // The next sub-step starts from this one's end (balanced).
        sum_terms(&ws.terms[..count * n], n, 1.0, z_out);
        if last {
            for (x, &d) in z_out.iter_mut().zip(scale) {
                *x *= d;
            }
            return None;
        }
        ws.terms[..n].copy_from_slice(z_out);
        left += w;
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::DVector;

    use super::super::test_support::{forced_oscillator, max_rel_diff};
    use super::*;
    use crate::solve::exact::guard_series::DerivativeRows;

    /// The forced, damped mesh of the transitions' tests (static deflection 7.4e-6 m) with
    /// guards on the deflection.
    fn mode(guards: &[[f64; 5]]) -> ModeTransitions {
        let mut mode = ModeTransitions::new(forced_oscillator(), 3.5e8f64.sqrt());
        mode.guard_rows = guards
            .iter()
            .map(|g| {
                let mut rows = DerivativeRows::default();
                rows.set_row(g);
                rows
            })
            .collect();
        mode
    }

    /// The state at `s` by nalgebra's Padé `expm` of the unbalanced `A s` (independent of the
    /// series and of the balancing).
    fn expm_state(mode: &ModeTransitions, z: &[f64], s: f64) -> DVector<f64> {
        (mode.a() * s).exp() * DVector::from_column_slice(z)
    }

    /// The first time in `(0, tau]` where `row · z(s) < 0`, from 4000 samples of the `expm`
    /// state and bisection to 1e-16 s: an oracle that shares no code with the series search.
    fn oracle_crossing(mode: &ModeTransitions, z: &[f64], row: &[f64], tau: f64) -> Option<f64> {
        let g = |s: f64| {
            row.iter()
                .zip(expm_state(mode, z, s).iter())
                .map(|(r, x)| r * x)
                .sum::<f64>()
        };
        let samples = 4000;
        let mut lo = 0.0;
        for i in 1..=samples {
            let hi = tau * i as f64 / samples as f64;
            if g(hi) < 0.0 {
                let (mut a, mut b) = (lo, hi);
                while b - a > 1e-16 {
                    let mid = 0.5 * (a + b);
                    if g(mid) < 0.0 {
                        b = mid;
                    } else {
                        a = mid;
                    }
                }
                return Some(b);
            }
            lo = hi;
        }
        None
    }

    /// Segments from a fraction of the fastest period to ten of them (one to many sub-steps):
    /// the state at the segment's end, or the crossing time and the state there, against the
    /// `expm` oracle. Guard 0 is contact loss (`x > 2e-6 m`), guard 1 a wall never reached
    /// (`x < 1 m`).
    #[test]
    fn series_segments_match_the_expm_oracle() {
        let loss = [1.0, 0.0, 0.0, 0.0, -2e-6];
        let wall = [-1.0, 0.0, 0.0, 0.0, 1.0];
        let mode = mode(&[loss, wall]);
        let period = std::f64::consts::TAU / 3.5e8f64.sqrt();
        let mut ws = SeriesWorkspace::default();
        let mut stats = SolverStats::default();
        let (mut crossings, mut free) = (0, 0);
        let (mut worst_state, mut worst_time) = (0.0f64, 0.0f64);
        // Starts in contact with different velocities: small ones stay in contact, large
        // ones separate within the first oscillation.
        for &v in &[0.0, 0.02, 0.05, 0.1, 0.2] {
            for &periods in &[0.03, 0.2, 0.7, 2.5, 10.0] {
                let z = [7.4e-6, v, 0.6, 0.8, 1.0];
                let tau = periods * period;
                let mut out = [0.0; 5];
                let found =
                    first_crossing_by_series(&mode, &mut ws, &mut stats, 0.1, &z, &mut out, tau, 0);
                let expected = oracle_crossing(&mode, &z, &loss, tau);
                match (found, expected) {
                    (None, None) => {
                        free += 1;
                        let reference = expm_state(&mode, &z, tau);
                        let err = max_rel_diff(&out, reference.as_slice());
                        assert!(err < 1e-13, "v {v}, {periods} periods: state {err:e}");
                        worst_state = worst_state.max(err);
                    }
                    (Some(c), Some(t)) => {
                        crossings += 1;
                        assert_eq!(c.index, 0);
                        assert!((c.tau - t).abs() < 1e-14, "v {v}: {} against {t}", c.tau);
                        worst_time = worst_time.max((c.tau - t).abs() / period);
                        let reference = expm_state(&mode, &z, c.tau);
                        let err = max_rel_diff(&out, reference.as_slice());
                        assert!(err < 1e-13, "v {v}, {periods} periods: event state {err:e}");
                        worst_state = worst_state.max(err);
                        assert!(out[0] - 2e-6 < 1e-18, "just past the surface: {}", out[0]);
                    }
                    (found, expected) => panic!(
                        "v {v}, {periods} periods: found {:?}, oracle {expected:?}",
                        found.map(|c| c.tau)
                    ),
                }
            }
        }
        eprintln!(
            "{crossings} crossings, {free} free; state within {worst_state:.1e} of expm, \
             crossing times within {worst_time:.1e} periods"
        );
        assert!(
            crossings >= 5 && free >= 5,
            "{crossings} crossings, {free} free"
        );
    }

    /// The rules shared with the sampled search: an excluded guard is never reported, and a
    /// start on the surface that is not rising is a crossing at once.
    #[test]
    fn excluded_guards_and_starts_on_the_surface() {
        let loss = [1.0, 0.0, 0.0, 0.0, -2e-6];
        let mode = mode(&[loss]);
        let (mut ws, mut stats) = (SeriesWorkspace::default(), SolverStats::default());
        let mut out = [0.0; 5];
        let separating = [7.4e-6, 0.2, 0.6, 0.8, 1.0];
        let tau = 1e-3;
        let found = first_crossing_by_series(
            &mode,
            &mut ws,
            &mut stats,
            0.0,
            &separating,
            &mut out,
            tau,
            1,
        );
        assert!(found.is_none(), "guard 0 excluded");
        let reference = expm_state(&mode, &separating, tau);
        assert!(max_rel_diff(&out, reference.as_slice()) < 1e-13);
        let on_surface_falling = [2e-6, -0.1, 0.6, 0.8, 1.0];
        let found = first_crossing_by_series(
            &mode,
            &mut ws,
            &mut stats,
            0.0,
            &on_surface_falling,
            &mut out,
            tau,
            0,
        )
        .expect("a crossing at once");
        assert_eq!((found.tau, found.index), (0.0, 0));
    }
}
