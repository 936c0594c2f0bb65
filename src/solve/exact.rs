//! Exact piecewise-LTI propagation (numerics-notes §2.3).
//!
//! Between stops and events every segment of an eligible scene is `z' = A_mode z` with an
//! augmented state `z` (harmonic and constant forcing folded in), so
//! `z(t + τ) = expm(A τ) z(t)` exactly. `expm` is nalgebra's Padé scaling-and-squaring
//! (Higham 2005; Al-Mohy & Higham 2009): no eigendecomposition, so the separated mode, whose
//! matrix has a Jordan block, is handled like any other. Transition matrices are cached per
//! (mode, duration).
//!
//! Events inside a segment: the guards are linear in `z`, so each one is a sum of damped
//! exponentials and sinusoids in τ. They are sampled at a spacing of at most a quarter of the
//! shortest period of the segment (π/(2ω_max)); a sign change is bracketed, and so is a dip
//! between two samples (a minimum of the guard, found from its derivative `w·A·z`, that lies
//! below zero: grazing contact), then Brent locates the crossing on the analytic solution and
//! the system snaps the state onto the surface.

use std::collections::HashMap;

use nalgebra::{DMatrix, DVector};

use super::roots::brent_bracket;
use super::{HybridSystem, SolveError, SolverStats};

/// A hybrid system whose segments are linear time-invariant in an augmented state.
pub trait PiecewiseLti: HybridSystem {
    /// Size of the augmented state `z` (`>= dim()`, the first `dim()` entries are `y`).
    fn lti_dim(&self) -> usize;
    /// Lifts `y` at time `t` into `z`.
    fn lift(&self, t: f64, y: &[f64], z: &mut [f64]);
    /// The matrix `A` of the current mode, `z' = A z`.
    fn lti_matrix(&self, a: &mut DMatrix<f64>);
    /// Guard `index` of the current mode as a row: `g = w·z`.
    fn guard_row(&self, index: usize, w: &mut [f64]);
    /// A key that identifies the current mode's matrix among the modes of one parameter set.
    fn mode_key(&self) -> u64;
    /// An upper bound of the fastest angular frequency in any mode, rad/s.
    fn max_frequency(&self) -> f64;
}

/// Cached transition matrices; cleared when parameters or inputs change.
#[derive(Default)]
struct TransitionCache {
    map: HashMap<(u64, u64), DMatrix<f64>>,
}

impl TransitionCache {
    /// Partial segments (first and last of a run, FMU steps of any length) create new
    /// durations; the cache is bounded so a long co-simulation cannot grow it without limit.
    const CAPACITY: usize = 512;

    fn get(&mut self, key: u64, tau: f64, a: &DMatrix<f64>) -> &DMatrix<f64> {
        if self.map.len() >= Self::CAPACITY && !self.map.contains_key(&(key, tau.to_bits())) {
            self.map.clear();
        }
        self.map
            .entry((key, tau.to_bits()))
            .or_insert_with(|| (a * tau).exp())
    }
}

/// The exact propagator: same stateful interface as the RK stepper.
pub struct ExactPropagator {
    t: f64,
    y: Vec<f64>,
    stats: SolverStats,
    cache: TransitionCache,
    a: DMatrix<f64>,
    z: DVector<f64>,
    z_next: DVector<f64>,
    rows: Vec<DVector<f64>>,
    /// Mode key of the cached matrix `a` (`u64::MAX`: stale).
    a_key: u64,
    /// Events without time progress, to stop a Zeno cascade.
    stalled_events: u64,
    /// `∂y(t)/∂y(t_track)` when tracking is on: the product of the `y` blocks of the applied
    /// transition matrices (the forcing rows of `z` do not depend on `y`).
    sensitivity: Option<DMatrix<f64>>,
}

/// Events allowed at one instant before the propagation gives up (Zeno guard).
const MAX_STALLED_EVENTS: u64 = 64;

impl ExactPropagator {
    pub fn new<S: PiecewiseLti>(sys: &S) -> Self {
        let n = sys.lti_dim();
        ExactPropagator {
            t: 0.0,
            y: vec![0.0; sys.dim()],
            stats: SolverStats::default(),
            cache: TransitionCache::default(),
            a: DMatrix::zeros(n, n),
            z: DVector::zeros(n),
            z_next: DVector::zeros(n),
            rows: Vec::new(),
            a_key: u64::MAX,
            stalled_events: 0,
            sensitivity: None,
        }
    }

    /// Starts (or stops) tracking `∂y/∂y0` from the current time: after `advance_to`,
    /// [`ExactPropagator::sensitivity`] is the state-transition matrix of the linearised flow,
    /// e.g. the monodromy matrix after one period (Floquet analysis, shooting). State events
    /// contribute their saltation matrix; a grazing event, where it is unbounded, is an error
    /// ([`SolveError::SingularSaltation`]).
    pub fn track_sensitivity(&mut self, on: bool) {
        let n = self.y.len();
        self.sensitivity = on.then(|| DMatrix::identity(n, n));
    }

    pub fn sensitivity(&self) -> Option<&DMatrix<f64>> {
        self.sensitivity.as_ref()
    }

    /// (Re)starts at `(t, y)`.
    pub fn set_state(&mut self, t: f64, y: &[f64]) {
        self.t = t;
        self.y.copy_from_slice(y);
        self.stalled_events = 0;
    }

    /// The system's parameters or inputs changed: drop every cached matrix.
    pub fn invalidate(&mut self) {
        self.cache.map.clear();
        self.a_key = u64::MAX;
    }

    pub fn t(&self) -> f64 {
        self.t
    }

    pub fn y(&self) -> &[f64] {
        &self.y
    }

    pub fn stats(&self) -> &SolverStats {
        &self.stats
    }

    /// Propagates exactly to `t_end`, stopping at every known switch and state event.
    pub fn advance_to<S: PiecewiseLti>(
        &mut self,
        sys: &mut S,
        t_end: f64,
    ) -> Result<(), SolveError> {
        if t_end < self.t {
            return Err(SolveError::BackwardTime { t: self.t, t_end });
        }
        let n = sys.dim();
        while self.t < t_end {
            let stop = sys.next_stop();
            let target = stop.min(t_end);
            let tau = target - self.t;
            if !(tau > 0.0) {
                // The stop coincides with the current time (a segment of zero length in
                // floating point): just switch.
                if stop <= self.t {
                    sys.on_stop(self.t, &mut self.y);
                    self.stats.stops += 1;
                    self.a_key = u64::MAX;
                    continue;
                }
                return Err(SolveError::StepSizeTooSmall { t: self.t, h: tau });
            }
            sys.lift(self.t, &self.y, self.z.as_mut_slice());
            let key = sys.mode_key();
            if key != self.a_key {
                sys.lti_matrix(&mut self.a);
                self.a_key = key;
            }
            let phi = self.cache.get(key, tau, &self.a);
            phi.mul_to(&self.z, &mut self.z_next);
            let phi_y = self
                .sensitivity
                .is_some()
                .then(|| phi.view((0, 0), (n, n)).clone_owned());
            self.stats.steps += 1;

            if sys.guard_count() > 0 {
                if let Some((tau_event, index)) = self.first_crossing(sys, tau)? {
                    let phi_event = (&self.a * tau_event).exp();
                    let z_event = &phi_event * &self.z;
                    let t_event = self.t + tau_event;
                    self.stalled_events = if t_event > self.t {
                        0
                    } else {
                        self.stalled_events + 1
                    };
                    if self.stalled_events > MAX_STALLED_EVENTS {
                        return Err(SolveError::EventStorm {
                            t: self.t,
                            events: self.stalled_events,
                        });
                    }
                    // Before the switch: the flow and the guard's rate of the old mode.
                    let before = self.sensitivity.is_some().then(|| {
                        let mut w = DVector::zeros(self.z.len());
                        sys.guard_row(index, w.as_mut_slice());
                        let flow = &self.a * &z_event;
                        let rate = w.dot(&flow);
                        (w, flow, rate)
                    });
                    self.t = t_event;
                    self.y.copy_from_slice(&z_event.as_slice()[..n]);
                    sys.on_event(self.t, &mut self.y, index);
                    if let Some((w, flow_before, rate)) = before {
                        self.apply_saltation(sys, &phi_event, &w, &flow_before, rate)?;
                    }
                    self.stats.events += 1;
                    self.a_key = u64::MAX;
                    continue;
                }
            }
            self.y.copy_from_slice(&self.z_next.as_slice()[..n]);
            if let (Some(s), Some(phi_y)) = (&mut self.sensitivity, &phi_y) {
                *s = phi_y * &*s;
            }
            if !self.y.iter().all(|v| v.is_finite()) {
                return Err(SolveError::NonFinite { t: self.t });
            }
            self.t = target;
            if target == stop {
                sys.on_stop(self.t, &mut self.y);
                self.stats.stops += 1;
                self.a_key = u64::MAX;
            }
        }
        Ok(())
    }

    /// Carries the tracked sensitivity across an event at `self.t`: the partial segment's
    /// transition, then the saltation matrix
    /// `S = I + (f⁺ − f⁻) ∇_y gᵀ / ġ⁻` (Aizerman & Gantmacher 1958; Leine & Nijmeijer 2004,
    /// eq. 3.74) with `ġ⁻ = w·A⁻z` the guard's total rate before the switch (the harmonic
    /// forcing states carry its explicit time dependence). The snap onto the surface only
    /// removes rounding, so the jump map is the identity.
    fn apply_saltation<S: PiecewiseLti>(
        &mut self,
        sys: &S,
        phi_event: &DMatrix<f64>,
        w: &DVector<f64>,
        flow_before: &DVector<f64>,
        rate: f64,
    ) -> Result<(), SolveError> {
        let n = self.y.len();
        let nz = self.z.len();
        let scale = w.abs().dot(&flow_before.abs());
        if !(rate.abs() > 1e-9 * scale) {
            return Err(SolveError::SingularSaltation { t: self.t });
        }
        let mut z_after = DVector::zeros(nz);
        sys.lift(self.t, &self.y, z_after.as_mut_slice());
        let mut a_after = DMatrix::zeros(nz, nz);
        sys.lti_matrix(&mut a_after);
        let flow_after = &a_after * &z_after;
        let mut saltation = DMatrix::<f64>::identity(n, n);
        for i in 0..n {
            let jump = (flow_after[i] - flow_before[i]) / rate;
            for j in 0..n {
                saltation[(i, j)] += jump * w[j];
            }
        }
        let phi_y = phi_event.view((0, 0), (n, n));
        if let Some(s) = &mut self.sensitivity {
            *s = &saltation * (phi_y * &*s);
        }
        Ok(())
    }

    /// The earliest guard crossing in `(0, tau]` of the segment starting at `self.z`, as
    /// `(τ*, guard index)` with τ* just past the crossing.
    fn first_crossing<S: PiecewiseLti>(
        &mut self,
        sys: &S,
        tau: f64,
    ) -> Result<Option<(f64, usize)>, SolveError> {
        let m = sys.guard_count();
        let nz = self.z.len();
        self.rows.resize(m, DVector::zeros(nz));
        let mut rows = std::mem::take(&mut self.rows);
        for (i, row) in rows.iter_mut().enumerate() {
            if row.len() != nz {
                *row = DVector::zeros(nz);
            }
            sys.guard_row(i, row.as_mut_slice());
        }
        let omega = sys.max_frequency().max(1.0 / tau);
        let samples =
            ((tau * omega * 2.0 / std::f64::consts::PI).ceil() as usize).clamp(1, 1 << 20);
        let dt = tau / samples as f64;
        let a = self.a.clone();
        let step = if samples == 1 {
            None
        } else {
            Some(
                self.cache
                    .get(sys.mode_key() ^ 0x8000_0000_0000_0000, dt, &a)
                    .clone(),
            )
        };

        let mut best: Option<(f64, usize)> = None;
        let mut z_left = self.z.clone();
        let mut z_right = DVector::zeros(nz);
        let time_scale = self.t.abs() + tau;
        let tol = 4.0 * f64::EPSILON * time_scale;
        for k in 0..samples {
            let left = k as f64 * dt;
            let right = if k + 1 == samples { tau } else { left + dt };
            match &step {
                Some(phi) if k + 1 < samples => phi.mul_to(&z_left, &mut z_right),
                _ => z_right.copy_from(&self.z_next),
            }
            for (i, row) in rows.iter().enumerate() {
                let g_left = row.dot(&z_left);
                let g_right = row.dot(&z_right);
                self.stats.guard_evals += 2;
                let width = right - left;
                let bracket = if g_left > 0.0 {
                    if g_right < 0.0 {
                        Some((0.0, width, g_left, g_right))
                    } else {
                        self.dip(row, &a, &z_left, &z_right, width, g_left, g_right)
                    }
                } else {
                    // Only at a segment start right after an event: the state sits on the
                    // surface, so the guard is zero up to rounding and its direction decides.
                    self.leave_surface(row, &a, &z_left, &z_right, width, g_right)
                };
                if let Some((lo, hi, g_lo, g_hi)) = bracket {
                    if hi == 0.0 {
                        // The new mode is invalid from the start (grazing): switch at once.
                        best = Some((0.0, i));
                        break;
                    }
                    let z0 = z_left.clone();
                    let mut evals = 0u64;
                    let (_, after) = brent_bracket(
                        |s| {
                            evals += 1;
                            row.dot(&((&a * s).exp() * &z0))
                        },
                        lo,
                        hi,
                        g_lo,
                        g_hi,
                        tol,
                    );
                    self.stats.guard_evals += evals;
                    let candidate = left + after;
                    if best.is_none_or(|(t_best, _)| candidate < t_best) {
                        best = Some((candidate, i));
                    }
                }
            }
            if best.is_some() {
                break;
            }
            std::mem::swap(&mut z_left, &mut z_right);
        }
        self.rows = rows;
        Ok(best)
    }

    /// A guard that starts on its surface (`g <= 0` by rounding after a snap). If it rises, a
    /// later return below zero inside the interval is bracketed from its maximum; if it does
    /// not rise, the mode is left at once (returned as the bracket `(0, 0, 0, 0)`).
    #[allow(clippy::too_many_arguments)]
    fn leave_surface(
        &mut self,
        row: &DVector<f64>,
        a: &DMatrix<f64>,
        z_left: &DVector<f64>,
        z_right: &DVector<f64>,
        width: f64,
        g_right: f64,
    ) -> Option<(f64, f64, f64, f64)> {
        let slope_row = a.tr_mul(row);
        let d_left = slope_row.dot(z_left);
        self.stats.guard_evals += 1;
        if d_left <= 0.0 {
            return Some((0.0, 0.0, 0.0, 0.0));
        }
        if g_right > 0.0 {
            return None;
        }
        let d_right = slope_row.dot(z_right);
        self.stats.guard_evals += 1;
        if d_right >= 0.0 {
            return None;
        }
        let mut evals = 0u64;
        let (s_max, _) = brent_bracket(
            |s| {
                evals += 1;
                slope_row.dot(&((a * s).exp() * z_left))
            },
            0.0,
            width,
            d_left,
            d_right,
            1e-13 * width,
        );
        let g_max = row.dot(&((a * s_max).exp() * z_left));
        self.stats.guard_evals += evals + 1;
        if g_max > 0.0 {
            Some((s_max, width, g_max, g_right))
        } else {
            Some((0.0, 0.0, 0.0, 0.0))
        }
    }

    /// A guard that is non-negative at both ends of a sample interval may still dip below zero
    /// in between (grazing). With a quarter-period spacing the guard has at most one interior
    /// minimum; it is located from the derivative `w·A·z` and, if negative, returned as a
    /// bracket `(lo, hi, g(lo), g(hi))` of the first crossing.
    #[allow(clippy::too_many_arguments)]
    fn dip(
        &mut self,
        row: &DVector<f64>,
        a: &DMatrix<f64>,
        z_left: &DVector<f64>,
        z_right: &DVector<f64>,
        width: f64,
        g_left: f64,
        g_right: f64,
    ) -> Option<(f64, f64, f64, f64)> {
        let slope_row = a.tr_mul(row);
        let d_left = slope_row.dot(z_left);
        let d_right = slope_row.dot(z_right);
        self.stats.guard_evals += 2;
        if !(d_left < 0.0 && d_right > 0.0) {
            return None;
        }
        // Cubic Hermite estimate of the minimum; only a near-zero estimate is worth the search.
        let hermite_min = {
            let mut lowest = g_left.min(g_right);
            for j in 1..16 {
                let s = j as f64 / 16.0;
                let h00 = 2.0 * s.powi(3) - 3.0 * s * s + 1.0;
                let h10 = s.powi(3) - 2.0 * s * s + s;
                let h01 = -2.0 * s.powi(3) + 3.0 * s * s;
                let h11 = s.powi(3) - s * s;
                let g = h00 * g_left + h10 * width * d_left + h01 * g_right + h11 * width * d_right;
                lowest = lowest.min(g);
            }
            lowest
        };
        let scale = g_left.abs() + g_right.abs() + width * (d_left.abs() + d_right.abs());
        if hermite_min > 0.05 * scale {
            return None;
        }
        let mut evals = 0u64;
        let (s_min, _) = brent_bracket(
            |s| {
                evals += 1;
                slope_row.dot(&((a * s).exp() * z_left))
            },
            0.0,
            width,
            d_left,
            d_right,
            1e-13 * width,
        );
        let g_min = row.dot(&((a * s_min).exp() * z_left));
        self.stats.guard_evals += evals + 1;
        (g_min < 0.0).then_some((0.0, s_min, g_left.max(0.0), g_min))
    }
}
