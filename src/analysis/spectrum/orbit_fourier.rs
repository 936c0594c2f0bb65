//! Alias-free lines of a periodic orbit (issue 31 item 2): the Fourier coefficients
//! `c_k = (1/T) ∫₀ᵀ x(t) e^{−i2πkt/T} dt` of each output column, integrated over each segment
//! of the run rather than taken from samples.
//!
//! The exact propagator hands each segment with its start state and mode matrix
//! ([`Driver::advance_observed`], [`crate::solve::exact::segment_series`]); the segment is cut
//! into pieces with `h·(ω_max + ω_K) ≤ 3` (`ω_max` the fastest mode, `ω_K` the highest line)
//! and each piece is integrated by the 10-point Gauss–Legendre rule, whose error on
//! `e^{iωt}` at `h·ω ≤ 3` is below 1e-14 of the integrand (the bound in
//! [`crate::analysis::orbit_statistics`]). A segment ends at every stop and contact event, so
//! a force that jumps there (contact loss) is integrated piece by piece and nothing folds back
//! from above the highest line: the lines do not depend on how many there are.

use std::f64::consts::TAU;

use super::dft::Spectrum;
use super::window::Window;
use crate::model::Drivetrain;
use crate::simulation::Driver;
use crate::solve::exact::segment_series::{Segment, SegmentObserver};

/// 10-point Gauss–Legendre rule on [−1, 1] (Abramowitz & Stegun, Table 25.4), half of it: the
/// nodes `±x` share a weight.
const GAUSS10_HALF: [(f64, f64); 5] = [
    (0.148_874_338_981_631_2, 0.295_524_224_714_752_9),
    (0.433_395_394_129_247_2, 0.269_266_719_309_996_4),
    (0.679_409_568_299_024_4, 0.219_086_362_515_982),
    (0.865_063_366_688_984_5, 0.149_451_349_150_580_6),
    (0.973_906_528_517_171_7, 0.066_671_344_308_688_1),
];

/// Largest `h·ω` of one piece.
const PIECE_OMEGA: f64 = 3.0;

/// Most node-line products of one integration (about 0.2 s, what the sampled spectrum of a
/// long response period costs).
const MAX_PRODUCTS: f64 = 2e8;

struct Integrator<'a> {
    columns: &'a [usize],
    t0: f64,
    duration: f64,
    lines: usize,
    /// `ω_max + ω_K`, rad/s.
    omega: f64,
    /// `∫ x e^{−iω_k (t − t0)} dt` per column and line, `[c·(lines+1) + k]`.
    sums: Vec<(f64, f64)>,
    /// Each column's value at the first node, taken out of the integrand: a line far below
    /// the mean (a DTE's harmonics beside its static deflection) would otherwise carry the
    /// rounding of the mean's integral (added back to line 0).
    reference: Vec<f64>,
    y: Vec<f64>,
    row: Vec<f64>,
}

impl Integrator<'_> {
    fn node<M: Drivetrain>(&mut self, model: &M, segment: &mut Segment, t: f64, w: f64) {
        segment.state(t, &mut self.y);
        model.output_row(t, &self.y, &mut self.row);
        let theta = TAU * (t - self.t0) / self.duration;
        // e^{−ikθ} by rotation, renormalised every few lines so rounding does not build up.
        let (s1, c1) = (-theta).sin_cos();
        let stride = self.lines + 1;
        if self.reference.is_empty() {
            self.reference = self.columns.iter().map(|&col| self.row[col]).collect();
        }
        for (c, &col) in self.columns.iter().enumerate() {
            let x = w * (self.row[col] - self.reference[c]);
            let sums = &mut self.sums[c * stride..(c + 1) * stride];
            let (mut re, mut im) = (1.0, 0.0);
            for (k, acc) in sums.iter_mut().enumerate() {
                if k % 32 == 0 && k > 0 {
                    let (s, c) = (-(k as f64) * theta).sin_cos();
                    (re, im) = (c, s);
                }
                acc.0 += x * re;
                acc.1 += x * im;
                (re, im) = (re * c1 - im * s1, re * s1 + im * c1);
            }
        }
    }
}

impl<M: Drivetrain> SegmentObserver<M> for Integrator<'_> {
    fn segment(&mut self, model: &M, segment: &mut Segment) {
        let (lo, hi) = (segment.start(), segment.end());
        if !(hi > lo) {
            return;
        }
        let pieces = ((hi - lo) * self.omega / PIECE_OMEGA).ceil().max(1.0) as usize;
        let h = (hi - lo) / pieces as f64;
        for p in 0..pieces {
            let a = lo + p as f64 * h;
            let b = if p + 1 == pieces { hi } else { a + h };
            let (mid, half) = (0.5 * (a + b), 0.5 * (b - a));
            for &(x, w) in &GAUSS10_HALF {
                self.node(model, segment, mid - half * x, w * half);
                self.node(model, segment, mid + half * x, w * half);
            }
        }
    }
}

/// The lines `k/duration`, k = 0..=`lines`, of each output column in `columns` over
/// `duration` from the run's current state (an integer number of periods of the orbit it is
/// on), which the run advances to its end; `None` (nothing advanced) where the run's segments
/// are not observable (RK, profiles) or the quadrature would exceed [`MAX_PRODUCTS`] (many
/// lines over a long period): the caller then samples. The amplitude of line 0 is the
/// magnitude of the mean, of line k ≥ 1 `2|c_k|`; the phase is that of the cosine at the
/// record's start, as [`super::exact_dft`] gives them.
pub fn orbit_lines<M: Drivetrain>(
    sim: &mut Driver<M>,
    columns: &[usize],
    duration: f64,
    lines: usize,
) -> Result<Option<Vec<Spectrum>>, String> {
    if !sim.observes_segments() {
        return Ok(None);
    }
    let omega_max = sim.model().max_frequency();
    // The quadrature costs nodes × lines: it grows with the square of the lines over a long
    // response period (a countershaft's 36 ms at 1024 samples per mesh period: 4e11 products),
    // beyond which the sampled DFT is kept.
    let omega = omega_max + TAU * lines as f64 / duration;
    let nodes = 10.0 * (duration * omega / PIECE_OMEGA).ceil();
    if nodes * (lines + 1) as f64 * columns.len() as f64 > MAX_PRODUCTS {
        return Ok(None);
    }
    let mut integrator = Integrator {
        columns,
        t0: sim.t(),
        duration,
        lines,
        omega,
        sums: vec![(0.0, 0.0); columns.len() * (lines + 1)],
        reference: Vec::new(),
        y: vec![0.0; sim.y().len()],
        row: Vec::new(),
    };
    let t_end = sim.t() + duration;
    sim.advance_observed(t_end, &mut integrator)
        .map_err(|e| format!("integration failed: {e}"))?;
    let resolution = 1.0 / duration;
    let stride = lines + 1;
    let spectra = (0..columns.len())
        .map(|c| {
            let sums = &integrator.sums[c * stride..(c + 1) * stride];
            let mut spectrum = Spectrum {
                frequency: Vec::with_capacity(stride),
                amplitude: Vec::with_capacity(stride),
                phase: Vec::with_capacity(stride),
                resolution,
                window: Window::Rectangular,
            };
            let reference = integrator.reference.get(c).copied().unwrap_or(0.0);
            for (k, &(re, im)) in sums.iter().enumerate() {
                let (mut re, im) = (re / duration, im / duration);
                if k == 0 {
                    re += reference;
                }
                spectrum.frequency.push(k as f64 * resolution);
                let scale = if k == 0 { 1.0 } else { 2.0 };
                spectrum.amplitude.push(scale * re.hypot(im));
                spectrum.phase.push(im.atan2(re));
            }
            spectrum
        })
        .collect();
    Ok(Some(spectra))
}
