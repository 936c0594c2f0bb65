//! The state inside an exact segment, for an observer of the propagation (issue 31: the
//! statistics of a recorded stretch from the solution, [`crate::analysis::orbit_statistics`]).
//!
//! A segment `[t₀, t₁]` of one mode is `z(t) = e^{A(t−t₀)} z₀` with its start state `z₀` and
//! the mode's balanced matrix `B = D⁻¹AD` already at hand ([`super::ExactPropagator`]), so
//! `z(t)` anywhere in it needs neither a restart of the run nor a matrix exponential: the
//! segment is cut into windows of `θ = ‖B‖₁ w ≤` [`WINDOW_THETA`], each window's Taylor terms
//! `u_k = (Bw)^k u₀ / k!` are summed to the rigorous tail bound of
//! [`BalancedMatrix::taylor_terms`] (below `2⁻⁵⁴ ‖u₀‖₁`), and `z(t₀ + jw + σw) = D Σ u_k σ^k`
//! by Horner. The terms are built on the first evaluation (about 20 mat-vecs per window) and
//! every further point costs one Horner sum. The window starts are chained by the series
//! itself, so `z(t₁)` agrees with the propagator's own end state to rounding (both exact,
//! not to the same last bit).

use super::balanced::{sum_terms, BalancedMatrix, MAX_TERMS};
use crate::solve::work::WorkPrices;

/// Largest `θ = ‖B‖₁ w` of one window: the terms then never grow above the first
/// (`θ^k/k! ≤ 2`), so their sum loses nothing to cancellation, and settle in ~22 terms.
pub const WINDOW_THETA: f64 = 2.0;

/// The most memory a segment's windows may hold, in bytes.
const MAX_SERIES_BYTES: usize = 1 << 30;

/// Buffers of the windows' terms, kept by the propagator (no allocation per segment once
/// they have held the longest segment).
#[derive(Default)]
pub struct SeriesBuffers {
    /// Window `j`'s terms from `starts[j]`, `counts[j]` terms of `nz` each.
    terms: Vec<f64>,
    starts: Vec<usize>,
    counts: Vec<usize>,
    sum: Vec<f64>,
    /// Work units of the observation since the propagator last took them
    /// ([`SeriesBuffers::take_work`]): the observer's work is charged to the run's budget
    /// like the propagator's own (issue 31: a summary cannot run unbounded).
    work: f64,
}

impl SeriesBuffers {
    /// The work of the observations since the last call, in work units.
    pub(super) fn take_work(&mut self) -> f64 {
        std::mem::take(&mut self.work)
    }
}

/// One segment of an observed advance: `[start, end]` of one mode, with the model still in
/// that mode when the observer sees it.
pub struct Segment<'a> {
    t0: f64,
    t1: f64,
    z0: &'a [f64],
    /// The propagator's own `z(t₁)` (before the jump of an event at `t₁`).
    z1: &'a [f64],
    balanced: &'a BalancedMatrix,
    buffers: &'a mut SeriesBuffers,
    /// Window width; 0 until the terms are built.
    width: f64,
    /// The propagator's prices: a Taylor term is a mat-vec of the mode's `n_z × n_z` matrix
    /// (`n_z²` units, the budget's unit being one multiply-add), a state evaluation a Horner
    /// sum over the terms of the entries asked for (terms × entries), an observer's
    /// evaluation of an output ([`Segment::charge_evaluations`]) a guard evaluation; nothing
    /// on an unpriced propagator.
    prices: WorkPrices,
}

impl<'a> Segment<'a> {
    pub(super) fn new(
        t0: f64,
        t1: f64,
        (z0, z1): (&'a [f64], &'a [f64]),
        balanced: &'a BalancedMatrix,
        buffers: &'a mut SeriesBuffers,
        prices: WorkPrices,
    ) -> Segment<'a> {
        Segment {
            t0,
            t1,
            z0,
            z1,
            balanced,
            buffers,
            width: 0.0,
            prices,
        }
    }

    /// Charges `count` evaluations of the observer's own (outputs of the model at a state of
    /// the segment) to the run's work budget.
    pub fn charge_evaluations(&mut self, count: usize) {
        self.buffers.work += count as f64 * self.prices.guard_eval;
    }

    pub fn start(&self) -> f64 {
        self.t0
    }

    pub fn end(&self) -> f64 {
        self.t1
    }

    /// The lifted state `z(t₀)` ([`super::PiecewiseLti::lift`]'s layout).
    pub fn start_state(&self) -> &[f64] {
        self.z0
    }

    /// The lifted state `z(t₁)` as the propagator computed it (at an event: before its jump).
    pub fn end_state(&self) -> &[f64] {
        self.z1
    }

    /// The mode's balanced matrix `B = D⁻¹AD` (`z' = Az`).
    pub fn balanced_matrix(&self) -> &nalgebra::DMatrix<f64> {
        self.balanced.matrix()
    }

    /// The diagonal of `D` (`z = D u` for the balanced state `u`).
    pub fn balance(&self) -> &[f64] {
        self.balanced.scale()
    }

    fn build(&mut self) {
        let nz = self.z0.len();
        let tau = self.t1 - self.t0;
        let theta = self.balanced.norm() * tau;
        let capacity = (MAX_TERMS + 1) * nz;
        let b = &mut *self.buffers;
        let wanted = (theta / WINDOW_THETA).ceil().max(1.0);
        let windows = if wanted <= (MAX_SERIES_BYTES / (8 * capacity)) as f64 {
            wanted as usize
        } else {
            // More windows than memory holds (a state or forcing beyond any physical scale,
            // e.g. an input torque of 1e300 N·m, makes ‖B‖ huge): their work, at least one
            // term per state per window, is charged, and the run's work budget stops the run
            // before its next segment instead of filling memory. The one window built here
            // is only a placeholder for what is observed until then.
            b.work += wanted * (nz * nz) as f64;
            1
        };
        let w = tau / windows as f64;
        b.starts.clear();
        b.counts.clear();
        b.sum.resize(nz, 0.0);
        let scale = self.balanced.scale();
        // The terms buffer only grows (the windows' terms are written before they are read:
        // no clearing per segment).
        let mut start = 0;
        for j in 0..windows {
            if b.terms.len() < start + capacity {
                b.terms.resize(start + capacity, 0.0);
            }
            let window = &mut b.terms[start..start + capacity];
            if j == 0 {
                for ((u, &z), &d) in window[..nz].iter_mut().zip(self.z0).zip(scale) {
                    *u = z / d;
                }
            } else {
                window[..nz].copy_from_slice(&b.sum);
            }
            // To a tail of [`TAIL`] `‖u₀‖₁`, not `2⁻⁵⁴ ‖u₀‖₁`: a state's components differ by
            // orders of magnitude (a deflection of micrometres beside a forcing state of order
            // one), and a norm-wise truncation at the rounding of the largest would leave the
            // smallest accurate only to `2⁻⁵⁴` of the largest; with `θ ≤ 2` the extra terms are
            // about five per window.
            let count = self.balanced.taylor_terms_within(w, nz, window, TAIL);
            b.starts.push(start);
            b.counts.push(count);
            if self.prices.step > 0.0 {
                b.work += (count * nz * nz) as f64;
            }
            // The next window's start, in balanced coordinates.
            sum_terms(&b.terms[start..start + count * nz], nz, 1.0, &mut b.sum);
            start += count * nz;
        }
        self.width = w;
    }

    /// The first `y.len()` entries of `z(t)` (`t` clamped to the segment).
    pub fn state(&mut self, t: f64, y: &mut [f64]) {
        if self.width == 0.0 {
            if self.t1 <= self.t0 {
                y.copy_from_slice(&self.z0[..y.len()]);
                return;
            }
            self.build();
        }
        let nz = self.z0.len();
        let b = &mut *self.buffers;
        let windows = b.starts.len();
        let s = ((t - self.t0) / self.width).clamp(0.0, windows as f64);
        let j = (s.floor() as usize).min(windows - 1);
        let sigma = s - j as f64;
        let (start, count) = (b.starts[j], b.counts[j]);
        if self.prices.step > 0.0 {
            b.work += (count * y.len()) as f64;
        }
        // Only the entries asked for (the model's state, not the forcing states beyond it).
        let sum = &mut b.sum[..y.len()];
        sum_terms(&b.terms[start..start + count * nz], nz, sigma, sum);
        for ((o, &u), &d) in y.iter_mut().zip(sum.iter()).zip(self.balanced.scale()) {
            *o = u * d;
        }
    }
}

/// The tail bound of a window's series relative to its start: `2⁻⁵⁴ · 10⁻⁸`.
const TAIL: f64 = f64::EPSILON / 4.0 * 1e-8;

/// What sees each segment of an observed advance ([`super::ExactPropagator::advance_observed`]),
/// before the stop or event at its end changes the mode.
pub trait SegmentObserver<S> {
    /// Whether segments are handed over at all (the plain advance's observer is not).
    const ACTIVE: bool = true;
    fn segment(&mut self, sys: &S, segment: &mut Segment);
}

/// The plain advance: nothing observes it.
pub(super) struct Unobserved;

impl<S> SegmentObserver<S> for Unobserved {
    const ACTIVE: bool = false;
    #[inline(always)]
    fn segment(&mut self, _sys: &S, _segment: &mut Segment) {}
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, DVector};

    /// Inside a long segment (six windows) of a lightly damped oscillator with forcing
    /// states, the series matches `e^{Aτ} z₀` from the Padé exponential of the balanced
    /// matrix (scaling and squaring: another method than the series) to 1e-13 of the
    /// response's size.
    #[test]
    fn states_inside_a_segment_match_the_exponential() {
        let (w0, zeta) = (3.0e4, 0.02);
        let a = DMatrix::from_row_slice(
            4,
            4,
            &[
                0.0,
                1.0,
                0.0,
                0.0, //
                -w0 * w0,
                -2.0 * zeta * w0,
                1.0e3,
                0.0, //
                0.0,
                0.0,
                0.0,
                5.0e3, //
                0.0,
                0.0,
                -5.0e3,
                0.0,
            ],
        );
        let balanced = BalancedMatrix::new(&a);
        let z0 = [1e-6, 2e-2, 1.0, 0.0];
        let mut buffers = SeriesBuffers::default();
        let tau = 6.0 / w0;
        let z1 = [0.0; 4];
        let mut segment = Segment::new(
            0.5,
            0.5 + tau,
            (&z0, &z1),
            &balanced,
            &mut buffers,
            WorkPrices::default(),
        );
        let mut y = [0.0; 2];
        for k in 0..=20 {
            let t = 0.5 + tau * k as f64 / 20.0;
            segment.state(t, &mut y);
            // The time as the segment sees it (`t − t₀` rounded in `t`).
            let s = t - 0.5;
            let exact = balanced.exp(s) * DVector::from_column_slice(&z0);
            for i in 0..2 {
                let scale = if i == 0 { 1e-6 } else { 1e-6 * w0 };
                assert!(
                    (y[i] - exact[i]).abs() <= 1e-13 * scale,
                    "at τ = {s:e}: {} vs {}",
                    y[i],
                    exact[i]
                );
            }
        }
    }
}
