//! Transition operators of one LTI mode `z' = A z`, applied to vectors without a matrix
//! exponential per segment.
//!
//! Segment durations recur: whole stiffness pieces and output intervals at constant speed,
//! and in a periodic steady state also the times to and from contact events. `Φ(τ) = e^{Aτ}`
//! is therefore cached per mode and duration bin (Padé scaling-and-squaring on the stack,
//! Higham 2005, on the balanced matrix), together with the first two remainder terms, so a
//! steady run pays one fused mat-vec per segment and a matrix exponential only for a duration
//! it has not met before. The guard sample step `e^{Ah} − I` is cached per mode too.
//!
//! Every result is a pure function of the mode and the duration (the cache only saves
//! work), so a run restored into a fresh propagator continues bit for bit.

use nalgebra::DMatrix;

use super::balanced::BalancedMatrix;
use super::guard_series::DerivativeRows;
use super::recurrence::{Decision, ModeOperators, Recurrences, SearchedSegment};
use crate::solve::SolverStats;

/// Duration bins kept per mode with their own `e^{Aτ}`; replaced round-robin.
const RECURRING_CAPACITY: usize = 32;
/// Low mantissa bits rounded away by the duration bins (relative bin width 2^(LOW−52) = 2⁻³²).
const BIN_LOW_BITS: u32 = 20;

/// `out = m · z` for a column-major `n × n` matrix (the single pair's augmented sizes
/// `3 + 2H` get a fixed-size, unrolled loop).
#[inline]
pub fn mat_vec(m: &[f64], z: &[f64], out: &mut [f64]) {
    match z.len() {
        3 => mat_vec_fixed::<3>(m, z, out),
        5 => mat_vec_fixed::<5>(m, z, out),
        7 => mat_vec_fixed::<7>(m, z, out),
        9 => mat_vec_fixed::<9>(m, z, out),
        n => {
            out.fill(0.0);
            for (column, &zj) in m[..n * n].chunks_exact(n).zip(z) {
                for (o, &mij) in out.iter_mut().zip(column) {
                    *o += mij * zj;
                }
            }
        }
    }
}

#[inline(always)]
fn mat_vec_fixed<const N: usize>(m: &[f64], z: &[f64], out: &mut [f64]) {
    let m = &m[..N * N];
    let z: &[f64; N] = z.try_into().expect("vector of the matrix size");
    let mut acc = [0.0; N];
    for (j, &zj) in z.iter().enumerate() {
        for (i, a) in acc.iter_mut().enumerate() {
            *a += m[j * N + i] * zj;
        }
    }
    out[..N].copy_from_slice(&acc);
}

/// `out = (m + δ·p) z` in one pass (a binned transition with its remainder).
#[inline]
fn mat_vec_shifted(m: &[f64], p: &[f64], delta: f64, z: &[f64], out: &mut [f64]) {
    match z.len() {
        3 => mat_vec_shifted_fixed::<3>(m, p, delta, z, out),
        5 => mat_vec_shifted_fixed::<5>(m, p, delta, z, out),
        7 => mat_vec_shifted_fixed::<7>(m, p, delta, z, out),
        9 => mat_vec_shifted_fixed::<9>(m, p, delta, z, out),
        n => {
            out.fill(0.0);
            for (j, &zj) in z.iter().enumerate() {
                for (i, o) in out[..n].iter_mut().enumerate() {
                    let k = j * n + i;
                    *o += (m[k] + delta * p[k]) * zj;
                }
            }
        }
    }
}

#[inline(always)]
fn mat_vec_shifted_fixed<const N: usize>(
    m: &[f64],
    p: &[f64],
    delta: f64,
    z: &[f64],
    out: &mut [f64],
) {
    let (m, p) = (&m[..N * N], &p[..N * N]);
    let z: &[f64; N] = z.try_into().expect("vector of the matrix size");
    let mut acc = [0.0; N];
    for (j, &zj) in z.iter().enumerate() {
        for (i, a) in acc.iter_mut().enumerate() {
            let k = j * N + i;
            *a += (m[k] + delta * p[k]) * zj;
        }
    }
    out[..N].copy_from_slice(&acc);
}

/// A duration bin: `(centre bits of τ_c, Φ = e^{A τ_c}, ΦA)`.
type TransitionBin = (u64, DMatrix<f64>, DMatrix<f64>);

/// Everything the propagator needs of one mode.
pub struct ModeTransitions {
    /// `A` of the mode.
    pub a: DMatrix<f64>,
    /// `A` balanced, for its exponentials.
    balanced: BalancedMatrix,
    /// Guard sample spacing `h`: a quarter of the fastest period of the mode (`|λh| ≤ π/2`,
    /// so a guard's Taylor series over one interval settles within a few tens of terms).
    pub sample_step: f64,
    /// `e^{A h} − I`.
    sample_increment: DMatrix<f64>,
    /// Per guard index: its row and derivative rows along this mode's flow (crossing search).
    pub guard_rows: Vec<DerivativeRows>,
    /// `(centre bits of τ_c, Φ = e^{A τ_c}, ΦA)` per duration bin.
    recurring: Vec<TransitionBin>,
    next_recurring_slot: usize,
    /// The two bins used last (a mode's segments of a periodic orbit alternate between a few
    /// durations; the bins of a transient before it can fill the rest).
    recent_bins: [usize; 2],
    /// Earlier segments of the mode that decide the crossings of recurring ones.
    recurrences: Recurrences,
}

impl ModeTransitions {
    /// The operators of the mode `a` whose fastest rate is bounded by `rate` (rad/s).
    pub fn new(a: DMatrix<f64>, rate: f64) -> ModeTransitions {
        let n = a.nrows();
        // The system's bound may miss a fast real eigenvalue (heavy damping): the diagonals
        // of A and A² estimate it from the mode itself.
        let a2 = &a * &a;
        let own = (0..n)
            .map(|i| a[(i, i)].abs().max(a2[(i, i)].abs().sqrt()))
            .fold(0.0, f64::max);
        let rate = rate.max(own);
        let sample_step = if rate > 0.0 && rate.is_finite() {
            std::f64::consts::FRAC_PI_2 / rate
        } else {
            // No dynamics at all (A nilpotent and zero rates): any step is exact.
            1.0
        };
        let balanced = BalancedMatrix::new(&a);
        let sample_increment = balanced.exp(sample_step) - DMatrix::identity(n, n);
        ModeTransitions {
            a,
            balanced,
            sample_step,
            sample_increment,
            guard_rows: Vec::new(),
            recurring: Vec::new(),
            next_recurring_slot: 0,
            recent_bins: [0; 2],
            recurrences: Recurrences::default(),
        }
    }

    /// The first crossing in the segment `(z, tau)` decided by a recurring reference of this
    /// mode, if one holds ([`super::recurrence`]).
    pub fn decide_recurring(
        &mut self,
        z: &[f64],
        tau: f64,
        tol: f64,
        stats: &mut SolverStats,
    ) -> Option<Decision> {
        self.recurrences
            .decide(&self.guard_rows, z, tau, tol, stats)
    }

    /// Keeps the segment `(z, tau)` whose full search found `outcome` (`(τ*, guard)`) as a
    /// reference for recurring ones.
    pub fn learn_recurring(&mut self, z: &[f64], tau: f64, outcome: Option<(f64, usize)>) {
        let mode = ModeOperators {
            a: &self.a,
            balanced: &self.balanced,
            sample_step: self.sample_step,
        };
        let segment = SearchedSegment { z, tau, outcome };
        self.recurrences.learn(mode, &mut self.guard_rows, segment);
    }

    /// Drops the references (see [`super::ExactPropagator::forget_recurrences`]).
    pub fn forget_recurring(&mut self) {
        self.recurrences = Recurrences::default();
    }

    /// `e^{A h} − I` (one guard sample step), column-major.
    pub fn sample_increment(&self) -> &[f64] {
        self.sample_increment.as_slice()
    }

    /// `out = e^{A·tau} z`, the transition of one segment: a pure function of the mode and
    /// `tau`, never of what the cache holds, so a run restored from a snapshot into a fresh
    /// propagator continues bit for bit (FMI 2.0.x §2.1.8).
    ///
    /// Durations recur: whole stiffness pieces and output intervals at constant speed, and
    /// in a periodic steady state also the times to and from contact events, so `e^{A τ_c}` is
    /// cached per duration bin (the exponential of the balanced matrix, once per bin) and a
    /// steady run pays one mat-vec per segment. Durations that differ only in their last bits
    /// (`t_stop − t` rounds differently every period) share one bin of relative width 2⁻³²;
    /// the remainder `δ = τ − τ_c` (`|δ| ≤ 2⁻³³ τ`) is applied in one pass as
    /// `(e^{Aτ_c} + δ e^{Aτ_c}A) z` — exact because `A` commutes with itself, truncation
    /// `|Aδ|²/2 ≤ (1.2e-10 |Aτ|)²/2`, below 2e-18 for `|Aτ| ≤ 15`. Wider bins would let the event times of a long
    /// run (jitter `4ε·t` of the root finding) share bins too, but one rounded `e^{Aτ_c}`
    /// reused for every event of a periodic orbit drifts coherently (the undamped rattle of
    /// `tests/backlash.rs` gains energy ~3× faster at 2⁻²⁶ than at 2⁻³²).
    pub fn apply(&mut self, tau: f64, z: &[f64], out: &mut [f64]) {
        let (slot, delta) = self.bin(tau);
        let (_, phi, phi_a) = &self.recurring[slot];
        if delta == 0.0 {
            mat_vec(phi.as_slice(), z, out);
        } else {
            mat_vec_shifted(phi.as_slice(), phi_a.as_slice(), delta, z, out);
        }
    }

    /// The matrix [`ModeTransitions::apply`] applies for `tau`: `e^{Aτ_c} + δ e^{Aτ_c}A`.
    pub fn transition_matrix(&mut self, tau: f64) -> DMatrix<f64> {
        let (slot, delta) = self.bin(tau);
        let (_, phi, phi_a) = &self.recurring[slot];
        if delta == 0.0 {
            phi.clone()
        } else {
            phi + phi_a * delta
        }
    }

    /// The duration bin of `tau` (built on first use) and the remainder `δ = τ − τ_c`.
    fn bin(&mut self, tau: f64) -> (usize, f64) {
        const LOW: u32 = BIN_LOW_BITS;
        let bits = tau.to_bits();
        let centre_bits = bits.wrapping_add(1 << (LOW - 1)) & !((1u64 << LOW) - 1);
        let is_bin = |slot: usize| self.recurring.get(slot).is_some_and(|e| e.0 == centre_bits);
        let found = if is_bin(self.recent_bins[0]) {
            Some(self.recent_bins[0])
        } else if is_bin(self.recent_bins[1]) {
            Some(self.recent_bins[1])
        } else {
            self.recurring.iter().position(|e| e.0 == centre_bits)
        };
        let slot = match found {
            Some(slot) => slot,
            None => {
                let (phi, phi_a) = self
                    .balanced
                    .exp_with_product(f64::from_bits(centre_bits), true);
                let entry = (centre_bits, phi, phi_a);
                if self.recurring.len() < RECURRING_CAPACITY {
                    self.recurring.push(entry);
                    self.recurring.len() - 1
                } else {
                    let slot = self.next_recurring_slot;
                    self.recurring[slot] = entry;
                    self.next_recurring_slot = (slot + 1) % RECURRING_CAPACITY;
                    slot
                }
            }
        };
        if self.recent_bins[0] != slot {
            self.recent_bins = [slot, self.recent_bins[0]];
        }
        (slot, tau - f64::from_bits(centre_bits))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A damped oscillator with harmonic and constant forcing in the augmented form.
    fn forced_oscillator() -> DMatrix<f64> {
        let (k, c, w) = (3.5e8, 2.0e3, 1.8e4);
        #[rustfmt::skip]
        let a = DMatrix::from_row_slice(5, 5, &[
            0.0, 1.0, 0.0, 0.0, 0.0,
            -k, -c, 350.0, -20.0, 2.6e3,
            0.0, 0.0, 0.0, -w, 0.0,
            0.0, 0.0, w, 0.0, 0.0,
            0.0, 0.0, 0.0, 0.0, 0.0,
        ]);
        a
    }

    fn max_rel_diff(x: &[f64], y: &[f64]) -> f64 {
        let scale = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        x.iter()
            .zip(y)
            .map(|(a, b)| (a - b).abs() / scale)
            .fold(0.0, f64::max)
    }

    /// The binned transitions against nalgebra's `expm` of the full step (an independent
    /// evaluation: Padé scaling-and-squaring of the unbalanced `Aτ` itself), at the bin
    /// centre and off it (the remainder terms), and the same result from a fresh cache.
    #[test]
    fn binned_transitions_match_expm() {
        let a = forced_oscillator();
        let mut modes = ModeTransitions::new(a.clone(), (3.5e8f64).sqrt());
        let z0 = [1e-5, 0.2, 0.6, 0.8, 1.0];
        for &tau in &[1.3e-9, 3.1e-5, 8.7e-5, 1.75e-4, 3.3e-4, 2.1e-3] {
            for shift in [0.0, 3e-16, 1e-9, -1e-8, 1.1e-7] {
                let tau = tau * (1.0 + shift);
                let reference = (&a * tau).exp() * nalgebra::DVector::from_column_slice(&z0);
                let mut out = [0.0; 5];
                modes.apply(tau, &z0, &mut out);
                let err = max_rel_diff(&out, reference.as_slice());
                assert!(err < 1e-13, "tau = {tau:e}: {err:e}");
                let mut fresh = ModeTransitions::new(a.clone(), (3.5e8f64).sqrt());
                let mut again = [0.0; 5];
                fresh.apply(tau, &z0, &mut again);
                assert_eq!(out, again, "history-independent");
            }
        }
    }
}
