//! Transition operators of one LTI mode `z' = A z`, applied to vectors without a matrix
//! exponential per segment.
//!
//! Segment durations recur: whole stiffness pieces and output intervals at constant speed,
//! and in a periodic steady state also the times to and from contact events. `Φ(τ) = e^{Aτ}`
//! is therefore cached per mode and duration bin (Padé scaling-and-squaring on the stack,
//! Higham 2005, on the balanced matrix), so a steady run pays one mat-vec per segment (two
//! off the bin's centre). A duration met for the first time (the event
//! times of an orbit that is not periodic to 2⁻³², a transient) builds no matrix: it is
//! applied to the vector by cached sample steps `e^{Ah}` and a Taylor series with a rigorous
//! tail bound (a few tens of mat-vecs instead of `n_z³`·~20 flops); only its second meeting
//! pays the Padé exponential of its bin. The guard sample step `e^{Ah} − I` is cached per mode
//! too. Both are built only once the mode is promoted to this full path
//! ([`ModeTransitions::promote`]); before, its segments go by their series
//! ([`super::series_segment`]).
//!
//! Every result is a function of the mode, the duration and the durations met before in the
//! mode (which of the two paths, both exact to rounding); a state capture drops that history
//! ([`ModeTransitions::forget_recurring`]), so a run restored into a fresh propagator
//! continues bit for bit.

use std::cell::OnceCell;

use nalgebra::DMatrix;

use super::balanced::{BalancedMatrix, TaylorWork};
use super::guard_series::{DerivativeRows, NullSpace};
use super::mat_vec::mat_vec;
use super::recurrence::{Decision, ModeOperators, Recurrences, SearchedSegment};
use crate::solve::SolverStats;

/// Duration bins kept per mode with their own `e^{Aτ}` at most; replaced round-robin.
const RECURRING_CAPACITY: usize = 32;
/// Bytes of bin matrices per mode that set its number of bins (between 2 and
/// [`RECURRING_CAPACITY`]): 16 bins of the 19-state drivetrains, 32 of the single pair, 2 of a
/// 195-DOF chain (1.2 MB each), so a train with thousands of contact combinations keeps
/// thousands of modes in the cache's budget.
const BIN_BYTES_PER_MODE: usize = 48 << 10;
/// Bytes of bin matrices a mode may grow to, one bin at a time beyond its first
/// [`Bins::slots`] and only when a recurring duration finds every bin taken, if the mode cache
/// granted it the room at its promotion ([`ModeTransitions::promote`]): a fine output grid cuts
/// every visit of a mode into an entry, a whole output interval and an exit, so a mode meets
/// more recurring durations than 48 KiB holds once its states number more than 45 (2 bins of
/// the 67-state modes of `examples/planetary/ev_reducer_3p.toml` against their ~6 durations
/// at 32 rows per mesh period: 7–14 Padé exponentials rebuilt per period; `docs/planetary.md`).
const GROWN_BIN_BYTES_PER_MODE: usize = 1 << 20;
/// Low mantissa bits rounded away by the duration bins (relative bin width 2^(LOW−52) = 2⁻³²).
const BIN_LOW_BITS: u32 = 20;
/// Durations met once and applied without a matrix, remembered so that the second meeting
/// builds the bin ([`ModeTransitions::apply`]); replaced round-robin.
const SEEN_CAPACITY: usize = 16;
/// Sample steps `e^{Ah}` a duration met once may take before its Taylor remainder; a longer
/// one gets the Padé matrix (`n_z³`·~20 flops against `n_z²` per step).
const MAX_ONE_OFF_STEPS: f64 = 64.0;

/// The duration bins of one mode: the centre bits of `τ_c` per slot, and the matrices
/// `Φ = e^{A τ_c}` of every slot in one allocation of [`Bins::slots`] slots, made when the
/// mode is promoted to the full path ([`ModeTransitions::promote`]), with the capacity of the
/// cache's grant ([`Bins::grow`], at most [`GROWN_BIN_BYTES_PER_MODE`]) reserved then too and
/// filled only as recurring durations need it. A mode's memory is then fixed at its build and
/// at its promotion: the bins a long run fills do not take more memory than those of a short
/// one (`tests/simulate_memory.rs`; the reserved pages a mode never fills are not touched).
#[derive(Default)]
struct Bins {
    centres: Vec<u64>,
    /// Slot `s`: `Φ` at `[s·n², (s+1)·n²)`, column-major.
    matrices: Vec<f64>,
    /// Slots the bins may grow to ([`Bins::grown_slots`] if the cache granted the room at
    /// the promotion, else [`Bins::slots`]); their capacity is reserved with the first slots
    /// ([`Bins::allocate`]) and filled as they are used.
    granted: usize,
    /// One bin only, never grown: a large mode without guards ([`ModeTransitions::lean`]).
    lean: bool,
}

impl Bins {
    /// The bins of a mode of `n` states taken at its promotion.
    fn slots(n: usize) -> usize {
        (BIN_BYTES_PER_MODE / (8 * n * n).max(1)).clamp(2, RECURRING_CAPACITY)
    }

    /// The bins a mode of `n` states may grow to with the cache's grant.
    fn grown_slots(n: usize) -> usize {
        (GROWN_BIN_BYTES_PER_MODE / (8 * n * n).max(1)).clamp(Self::slots(n), RECURRING_CAPACITY)
    }

    fn phi(&self, slot: usize, n: usize) -> &[f64] {
        let nn = n * n;
        &self.matrices[slot * nn..(slot + 1) * nn]
    }

    /// Takes the memory of the first [`Bins::slots`] of a mode of `n` states and reserves
    /// that of the granted ones (once per grant).
    fn allocate(&mut self, n: usize) {
        let first = if self.lean { 1 } else { Self::slots(n) };
        self.granted = self.granted.max(first);
        self.centres
            .reserve_exact(self.granted.saturating_sub(self.centres.len()));
        self.matrices
            .reserve_exact((self.granted * n * n).saturating_sub(self.matrices.len()));
        if self.matrices.is_empty() {
            self.matrices.resize(first * n * n, 0.0);
        }
    }

    /// Slots in use or ready.
    fn ready(&self, n: usize) -> usize {
        self.matrices.len() / (n * n).max(1)
    }

    /// One more slot within the grant (its capacity reserved at the promotion): `false` if
    /// the grant is used up.
    fn grow(&mut self, n: usize) -> bool {
        let ready = self.ready(n);
        if ready >= self.granted {
            return false;
        }
        self.matrices.resize((ready + 1) * n * n, 0.0);
        true
    }

    /// Heap bytes held, and those granted but not taken yet.
    fn heap_bytes(&self, n: usize) -> usize {
        self.centres.capacity() * 8 + self.matrices.capacity().max(self.granted * n * n) * 8
    }
}

/// `A` of a mode, assembled from its balanced form at the first use where it was not kept
/// (a mode of a band frame). A function of the two fields rather than a method, so that a
/// caller may hold `A` beside a mutable borrow of the mode's other fields.
fn a_of<'a>(a: &'a OnceCell<DMatrix<f64>>, balanced: &BalancedMatrix) -> &'a DMatrix<f64> {
    a.get_or_init(|| balanced.unbalanced())
}

/// Everything the propagator needs of one mode.
pub struct ModeTransitions {
    /// `A` of the mode (built at its first use for a mode of a band frame,
    /// [`super::balanced::BandFrame`]).
    a: OnceCell<DMatrix<f64>>,
    /// The system's bound of the fastest rate ([`super::PiecewiseLti::max_frequency`]).
    rate: f64,
    /// `A` balanced, for its exponentials.
    balanced: BalancedMatrix,
    /// Guard sample spacing `h`: a quarter of the fastest period of the mode (`|λh| ≤ π/2`,
    /// so a guard's Taylor series over one interval settles within a few tens of terms).
    pub sample_step: f64,
    /// `e^{A h} − I`, built at its first use: a mode propagated by its series alone
    /// ([`super::series_segment`]) never pays its Padé exponential.
    sample_increment: OnceCell<DMatrix<f64>>,
    /// Per guard index: its row and derivative rows along this mode's flow (crossing search).
    pub guard_rows: Vec<DerivativeRows>,
    /// The guard rows times `D` (balanced), guard `i` at `[i n, (i+1) n)`: the series search's
    /// rows in one allocation, built at its first use.
    balanced_guard_rows: OnceCell<Vec<f64>>,
    /// The mode's equilibrium directions (for the guards' curvature bounds).
    pub null_space: NullSpace,
    /// The duration bins.
    recurring: Bins,
    next_recurring_slot: usize,
    /// The two bins used last (a mode's segments of a periodic orbit alternate between a few
    /// durations; the bins of a transient before it can fill the rest).
    recent_bins: [usize; 2],
    /// Centre bits of durations met once and applied without a bin, and the next slot.
    seen: [u64; SEEN_CAPACITY],
    next_seen_slot: usize,
    taylor: TaylorWork,
    taylor_state: Vec<f64>,
    taylor_next: Vec<f64>,
    /// Whether the mode is on the full path (sample steps, bins, curvature bounds,
    /// references; [`ModeTransitions::promote`]); until then its segments go by their series
    /// ([`super::series_segment`]).
    promoted: bool,
    /// Bins built (Padé exponentials; the driver's work budget counts them).
    builds: u64,
    /// Earlier segments of the mode that decide the crossings of recurring ones.
    recurrences: Recurrences,
}

impl ModeTransitions {
    /// The operators of the mode `a` whose fastest rate is bounded by `rate` (rad/s).
    pub fn new(a: DMatrix<f64>, rate: f64) -> ModeTransitions {
        let sample_step = Self::own_sample_step(&a, rate);
        let balanced = BalancedMatrix::new(&a);
        Self::with(OnceCell::from(a), balanced, rate, sample_step)
    }

    /// The operators of a mode balanced by its band frame
    /// ([`super::balanced::BandFrame::balance`]): `A` and the sample step are built if the
    /// mode is promoted to the full path; until then its segments go by their series.
    pub fn in_frame(balanced: BalancedMatrix, rate: f64) -> ModeTransitions {
        Self::with(OnceCell::new(), balanced, rate, f64::NAN)
    }

    /// The guard sample step of mode `a`: a quarter of its fastest period, from `rate` or
    /// the mode's own estimate if faster.
    fn own_sample_step(a: &DMatrix<f64>, rate: f64) -> f64 {
        let n = a.nrows();
        // The system's bound may miss a fast real eigenvalue (heavy damping): the diagonals
        // of A and A² estimate it from the mode itself.
        // (A²)_ii = Σ_k a_ik a_ki: the diagonal alone, n² flops instead of the product's n³.
        let a2_diagonal = |i: usize| (0..n).map(|k| a[(i, k)] * a[(k, i)]).sum::<f64>();
        let own = (0..n)
            .map(|i| a[(i, i)].abs().max(a2_diagonal(i).abs().sqrt()))
            .fold(0.0, f64::max);
        let rate = rate.max(own);
        if rate > 0.0 && rate.is_finite() {
            std::f64::consts::FRAC_PI_2 / rate
        } else {
            // No dynamics at all (A nilpotent and zero rates): any step is exact.
            1.0
        }
    }

    fn with(
        a: OnceCell<DMatrix<f64>>,
        balanced: BalancedMatrix,
        rate: f64,
        sample_step: f64,
    ) -> ModeTransitions {
        ModeTransitions {
            a,
            rate,
            balanced,
            sample_step,
            sample_increment: OnceCell::new(),
            guard_rows: Vec::new(),
            balanced_guard_rows: OnceCell::new(),
            null_space: NullSpace::default(),
            // The bins' memory is taken at the promotion, all of it at once.
            recurring: Bins::default(),
            next_recurring_slot: 0,
            recent_bins: [0; 2],
            seen: [u64::MAX; SEEN_CAPACITY],
            next_seen_slot: 0,
            taylor: TaylorWork::default(),
            taylor_state: Vec::new(),
            taylor_next: Vec::new(),
            promoted: false,
            builds: 0,
            recurrences: Recurrences::default(),
        }
    }

    /// `A` of the mode.
    pub fn a(&self) -> &DMatrix<f64> {
        a_of(&self.a, &self.balanced)
    }

    /// Guard `i`'s rows, with `A` and the equilibrium directions they are read with (the
    /// crossing search of the full path).
    pub fn guard_rows_with_a(
        &mut self,
        i: usize,
    ) -> (&mut DerivativeRows, &DMatrix<f64>, &NullSpace) {
        let a = a_of(&self.a, &self.balanced);
        (&mut self.guard_rows[i], a, &self.null_space)
    }

    /// The number of states.
    pub fn dim(&self) -> usize {
        self.balanced.dim()
    }

    /// The fastest rate the guard sampling assumes, rad/s (a mode of a band frame before its
    /// promotion: the system's bound).
    pub fn fastest_rate(&self) -> f64 {
        if self.sample_step.is_nan() {
            self.rate
        } else {
            std::f64::consts::FRAC_PI_2 / self.sample_step
        }
    }

    /// Duration bins built so far (each a Padé exponential of the mode's matrix).
    pub fn bin_builds(&self) -> u64 {
        self.builds
    }

    /// Heap bytes held by the mode's operators, bins, guard rows and references (the mode
    /// cache's memory budget, [`super::ModeCache`]).
    pub fn heap_bytes(&self) -> usize {
        let n = self.dim();
        // `a`, the balanced matrix and the sample increment.
        (usize::from(self.a.get().is_some()) + usize::from(self.sample_increment.get().is_some()))
            * n
            * n
            * 8
            + self.balanced.heap_bytes()
            + self
                .balanced_guard_rows
                .get()
                .map_or(0, |r| r.capacity() * 8)
            + self.recurring.heap_bytes(n)
            + self
                .guard_rows
                .iter()
                .map(DerivativeRows::heap_bytes)
                .sum::<usize>()
            + self.null_space.heap_bytes()
            + self.recurrences.heap_bytes()
            + (self.taylor_state.capacity() + self.taylor_next.capacity()) * 8
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
            a: a_of(&self.a, &self.balanced),
            balanced: &self.balanced,
            null_space: &self.null_space,
            sample_step: self.sample_step,
        };
        let segment = SearchedSegment { z, tau, outcome };
        self.recurrences.learn(mode, &mut self.guard_rows, segment);
    }

    /// Drops the references and the duration history (see
    /// [`super::ExactPropagator::forget_recurrences`]): whether a duration is applied through
    /// its bin or once without one depends on what came before ([`ModeTransitions::apply`]).
    pub fn forget_recurring(&mut self) {
        self.recurrences = Recurrences::default();
        self.recurring.centres.clear();
        self.next_recurring_slot = 0;
        self.recent_bins = [0; 2];
        self.seen = [u64::MAX; SEEN_CAPACITY];
        self.next_seen_slot = 0;
    }

    /// Whether the mode is on the full path.
    pub fn promoted(&self) -> bool {
        self.promoted
    }

    /// Puts the mode on the full path and takes its memory now: the sample step and its
    /// first [`Bins::slots`] duration bins (so the run's memory does not grow later when the
    /// bins fill; `tests/simulate_memory.rs`). With `grow` (the cache's room for
    /// [`ModeTransitions::grown_bin_bytes`]) the bins may grow to [`Bins::grown_slots`] when a
    /// recurring duration finds them all taken; that memory counts as held from now on
    /// ([`ModeTransitions::heap_bytes`]). Its guard rows and references grow with use, within
    /// their own bounds.
    pub fn promote(&mut self, grow: bool) {
        if self.promoted {
            return;
        }
        self.promoted = true;
        let n = self.dim();
        if self.sample_step.is_nan() {
            // A mode of a band frame: its `A` and sample step now.
            self.sample_step = Self::own_sample_step(self.a(), self.rate);
        }
        if self.lean() {
            // No guards to sample and products to apply the recurring sequences: one bin
            // and no sample step (`docs/scaling.md`, "Memory").
            self.recurring.lean = true;
        } else {
            self.sample_increment();
        }
        if grow && !self.recurring.lean {
            self.recurring.granted = self.recurring.granted.max(Bins::grown_slots(n));
        }
        // (A mode whose guards were all excluded so far has applied bins already; its
        // grant is reserved now.)
        self.recurring.allocate(n);
    }

    /// Whether the mode is kept lean on the full path: it has no guards (its recurring
    /// sequences go by composite products, [`super::composite`]) and one matrix of it takes
    /// more than [`BIN_BYTES_PER_MODE`] (more than 78 states: the 64-mesh chains' 128
    /// stiffness pieces of 390 states then fit the mode cache's budget together). It keeps
    /// `A`, its balanced copy and one duration bin; a duration met once goes by the Taylor
    /// series in sub-steps instead of sample steps ([`ModeTransitions::apply_once`]).
    fn lean(&self) -> bool {
        let n = self.dim();
        self.guard_rows.is_empty() && 8 * n * n > BIN_BYTES_PER_MODE
    }

    /// Heap bytes the bins may grow by beyond their first [`Bins::slots`] (the cache's grant
    /// at the promotion).
    pub fn grown_bin_bytes(&self) -> usize {
        let n = self.dim();
        (Bins::grown_slots(n) - Bins::slots(n)) * n * n * 8
    }

    /// Heap bytes the full path will give this mode (its sample step, first bins and guard
    /// rows: what it keeps near the core in a steady run at one stop per mesh period; the
    /// bins grown for a fine output grid are not counted).
    pub fn full_bytes_estimate(&self) -> usize {
        let n = self.dim();
        if self.lean() {
            // `A`, its balanced copy and one bin.
            return 3 * n * n * 8;
        }
        3 * n * n * 8 + Bins::slots(n) * n * n * 8 + self.guard_rows.len() * 24 * n * 8
    }

    /// `e^{A h} − I` (one guard sample step), column-major.
    pub fn sample_increment(&self) -> &[f64] {
        self.sample_increment
            .get_or_init(|| {
                let n = self.dim();
                self.balanced.exp(self.sample_step) - DMatrix::identity(n, n)
            })
            .as_slice()
    }

    /// `A` balanced (the series propagation of [`super::series_segment`]).
    pub fn balanced(&self) -> &BalancedMatrix {
        &self.balanced
    }

    /// Every guard row times `D`, guard `i` at `[i n, (i+1) n)`.
    pub fn balanced_guard_rows(&self) -> &[f64] {
        self.balanced_guard_rows.get_or_init(|| {
            let scale = self.balanced.scale();
            self.guard_rows
                .iter()
                .flat_map(|rows| rows.row(0).iter().zip(scale).map(|(c, d)| c * d))
                .collect()
        })
    }

    /// `out = e^{A·tau} z`, the transition of one segment.
    ///
    /// Durations recur: whole stiffness pieces and output intervals at constant speed, and
    /// in a periodic steady state also the times to and from contact events, so `e^{A τ_c}` is
    /// cached per duration bin (the exponential of the balanced matrix, once per bin) and a
    /// steady run pays one mat-vec per segment. Durations that differ only in their last bits
    /// (`t_stop − t` rounds differently every period) share one bin of relative width 2⁻³²;
    /// the remainder `δ = τ − τ_c` (`|δ| ≤ 2⁻³³ τ`) is applied as `e^{Aτ_c}(z + δ A z)` —
    /// exact because `A` commutes with its exponential, truncation `|Aδ|²/2 ≤ (1.2e-10
    /// |Aτ|)²/2`, below 2e-18 for `|Aτ| ≤ 15`; a bin holds `e^{Aτ_c}` alone, so a mode's
    /// bins take half the memory of a stored `e^{Aτ_c}A`. Wider bins would let the event times of a long
    /// run (jitter `4ε·t` of the root finding) share bins too, but one rounded `e^{Aτ_c}`
    /// reused for every event of a periodic orbit drifts coherently (the undamped rattle of
    /// `tests/backlash.rs` gains energy ~3× faster at 2⁻²⁶ than at 2⁻³²).
    ///
    /// A duration whose bin is not built and that was not met before (the event times of an
    /// orbit that is not periodic to 2⁻³², a transient, the many contact combinations of a
    /// train met once each) is applied without a matrix ([`Self::apply_once`]); its second
    /// meeting builds the bin. The result is therefore a
    /// function of the mode, the duration and the durations met before in the mode (both
    /// paths are exact to rounding, not to the same last bit), so a state capture drops that
    /// history with the references ([`Self::forget_recurring`]) and a run restored into a
    /// fresh propagator continues bit for bit (FMI 2.0.x §2.1.8).
    pub fn apply(&mut self, tau: f64, z: &[f64], out: &mut [f64]) {
        let slot = match self.find_bin(tau) {
            Some(slot) => slot,
            None => {
                // A duration met once costs a few mat-vecs instead of a Padé exponential and
                // takes no bin, so it neither evicts a recurring duration nor makes a mode
                // that never recurs allocate bins.
                let centre_bits = Self::centre_bits(tau);
                if !self.seen.contains(&centre_bits) {
                    self.seen[self.next_seen_slot] = centre_bits;
                    self.next_seen_slot = (self.next_seen_slot + 1) % SEEN_CAPACITY;
                    if self.apply_once(tau, z, out) {
                        return;
                    }
                }
                self.build_bin(tau)
            }
        };
        let n = z.len();
        let delta = tau - f64::from_bits(self.recurring.centres[slot]);
        let phi = self.recurring.phi(slot, n);
        if delta == 0.0 {
            mat_vec(phi, z, out);
        } else {
            // e^{A(τ_c+δ)} z = e^{Aτ_c}(z + δ A z) + O(δ²): A commutes with its exponential.
            let a = a_of(&self.a, &self.balanced);
            let shifted = &mut self.taylor_next;
            shifted.resize(n, 0.0);
            mat_vec(a.as_slice(), z, shifted);
            for (s, &x) in shifted.iter_mut().zip(z) {
                *s = x + delta * *s;
            }
            mat_vec(phi, shifted, out);
        }
    }

    /// `out = e^{A·tau} z` without a matrix exponential: `q = ⌊τ/h⌋` cached sample steps
    /// `z ← z + (e^{Ah} − I) z` (the crossing search's own steps), then the Taylor series of
    /// the rest `r = τ − qh < h` on the vector ([`BalancedMatrix::exp_times`], with a rigorous
    /// truncation bound). `q + K` mat-vecs (`K` ≈ 20–40 terms) instead of a Padé
    /// scaling-and-squaring; `false` when the duration spans more than
    /// [`MAX_ONE_OFF_STEPS`] sample steps or the rest's norm is too large for the series.
    fn apply_once(&mut self, tau: f64, z: &[f64], out: &mut [f64]) -> bool {
        // (A mode of a band frame has no sample step before its promotion.)
        if (self.recurring.lean || self.sample_step.is_nan())
            && self.sample_increment.get().is_none()
        {
            return self.apply_once_by_series(tau, z, out);
        }
        let h = self.sample_step;
        let steps = (tau / h).floor();
        if !(0.0..=MAX_ONE_OFF_STEPS).contains(&steps) {
            return false;
        }
        let rest = tau - steps * h;
        // Ping-pong between `out` and a work vector; the series starts from the last step.
        let mut state = std::mem::take(&mut self.taylor_state);
        state.clear();
        state.extend_from_slice(z);
        let mut next = std::mem::take(&mut self.taylor_next);
        next.resize(z.len(), 0.0);
        for _ in 0..steps as u32 {
            mat_vec(self.sample_increment(), &state, &mut next);
            for (x, s) in next.iter_mut().zip(&state) {
                *x += s;
            }
            std::mem::swap(&mut state, &mut next);
        }
        let done = self.balanced.exp_times(rest, &state, out, &mut self.taylor);
        self.taylor_state = state;
        self.taylor_next = next;
        done
    }

    /// [`ModeTransitions::apply_once`] of a lean mode: the Taylor series in `k` equal
    /// sub-steps of `θ = ‖B‖₁ τ/k ≤ 2` ([`BalancedMatrix::exp_times`], each with its rigorous
    /// tail bound), no sample step built; `false` past [`MAX_ONE_OFF_STEPS`] sub-steps.
    fn apply_once_by_series(&mut self, tau: f64, z: &[f64], out: &mut [f64]) -> bool {
        let theta = self.balanced.norm() * tau;
        let steps = (theta / 2.0).ceil().max(1.0);
        if !(steps <= MAX_ONE_OFF_STEPS) {
            return false;
        }
        let sub = tau / steps;
        let mut state = std::mem::take(&mut self.taylor_state);
        state.clear();
        state.extend_from_slice(z);
        let mut done = true;
        for _ in 0..steps as u32 {
            done = self.balanced.exp_times(sub, &state, out, &mut self.taylor);
            if !done {
                break;
            }
            state.copy_from_slice(out);
        }
        self.taylor_state = state;
        done
    }

    /// The matrix of the binned path of [`ModeTransitions::apply`] for `tau`:
    /// `e^{Aτ_c}(I + δA)` (products of recurring sequences are built from it).
    pub fn transition_matrix(&mut self, tau: f64) -> DMatrix<f64> {
        let slot = match self.find_bin(tau) {
            Some(slot) => slot,
            None => self.build_bin(tau),
        };
        let n = self.dim();
        let delta = tau - f64::from_bits(self.recurring.centres[slot]);
        let phi = DMatrix::from_column_slice(n, n, self.recurring.phi(slot, n));
        if delta == 0.0 {
            phi
        } else {
            let phi_a = &phi * self.a();
            phi + phi_a * delta
        }
    }

    /// The centre of the duration bin of `tau`: its bits with the low [`BIN_LOW_BITS`]
    /// rounded away.
    fn centre_bits(tau: f64) -> u64 {
        const LOW: u32 = BIN_LOW_BITS;
        tau.to_bits().wrapping_add(1 << (LOW - 1)) & !((1u64 << LOW) - 1)
    }

    /// The slot of the built bin of `tau`, if there is one.
    fn find_bin(&mut self, tau: f64) -> Option<usize> {
        let centre_bits = Self::centre_bits(tau);
        let centres = &self.recurring.centres;
        let is_bin = |slot: usize| centres.get(slot).is_some_and(|&c| c == centre_bits);
        let found = if is_bin(self.recent_bins[0]) {
            Some(self.recent_bins[0])
        } else if is_bin(self.recent_bins[1]) {
            Some(self.recent_bins[1])
        } else {
            centres.iter().position(|&c| c == centre_bits)
        };
        if let Some(slot) = found {
            self.touch_bin(slot);
        }
        found
    }

    fn touch_bin(&mut self, slot: usize) {
        if self.recent_bins[0] != slot {
            self.recent_bins = [slot, self.recent_bins[0]];
        }
    }

    /// Builds the bin of `tau` (the Padé exponential of its centre) and returns its slot.
    fn build_bin(&mut self, tau: f64) -> usize {
        self.builds += 1;
        let centre_bits = Self::centre_bits(tau);
        let phi = self.balanced.exp(f64::from_bits(centre_bits));
        let n = self.dim();
        let bins = &mut self.recurring;
        // A mode used before its promotion: its guards all excluded by the model, or the
        // unit tests of the transitions alone.
        bins.allocate(n);
        let slot = if bins.centres.len() < bins.ready(n) || bins.grow(n) {
            bins.centres.push(centre_bits);
            bins.centres.len() - 1
        } else {
            // Every slot taken and the grant used up: replaced round-robin.
            let slot = self.next_recurring_slot;
            bins.centres[slot] = centre_bits;
            self.next_recurring_slot = (slot + 1) % bins.centres.len();
            slot
        };
        bins.matrices[slot * n * n..(slot + 1) * n * n].copy_from_slice(phi.as_slice());
        self.touch_bin(slot);
        slot
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_support::{forced_oscillator, max_rel_diff};
    use super::*;

    /// The transitions against nalgebra's `expm` of the full step (an independent
    /// evaluation: Padé scaling-and-squaring of the unbalanced `Aτ` itself): at a duration's
    /// first meeting (no matrix), its second (the bin, at its centre and off it: the
    /// remainder terms), and after the history is dropped the same result as a fresh cache.
    #[test]
    fn binned_transitions_match_expm() {
        let a = forced_oscillator();
        let mut modes = ModeTransitions::new(a.clone(), (3.5e8f64).sqrt());
        let z0 = [1e-5, 0.2, 0.6, 0.8, 1.0];
        for &tau in &[1.3e-9, 3.1e-5, 8.7e-5, 1.75e-4, 3.3e-4, 2.1e-3] {
            for shift in [0.0, 3e-16, 1e-9, -1e-8, 1.1e-7] {
                let tau = tau * (1.0 + shift);
                let reference = (&a * tau).exp() * nalgebra::DVector::from_column_slice(&z0);
                for meeting in 0..2 {
                    let mut out = [0.0; 5];
                    modes.apply(tau, &z0, &mut out);
                    let err = max_rel_diff(&out, reference.as_slice());
                    assert!(err < 1e-13, "tau = {tau:e}, meeting {meeting}: {err:e}");
                }
                let mut fresh = ModeTransitions::new(a.clone(), (3.5e8f64).sqrt());
                let mut again = [0.0; 5];
                fresh.apply(tau, &z0, &mut again);
                modes.forget_recurring();
                let mut replay = [0.0; 5];
                modes.apply(tau, &z0, &mut replay);
                assert_eq!(replay, again, "history dropped");
            }
        }
    }

    /// A duration met once (sample steps and the Taylor series on the vector, no matrix)
    /// against the Padé bin of the same duration, to rounding: from a fraction of a sample
    /// step to the most steps the path takes; beyond them the bin is built at once.
    #[test]
    fn one_off_durations_match_the_pade_bins() {
        let a = forced_oscillator();
        let z0 = [1e-5, 0.2, 0.6, 0.8, 1.0];
        let h = ModeTransitions::new(a.clone(), (3.5e8f64).sqrt()).sample_step;
        let mut worst = 0.0f64;
        for &steps in &[0.0, 0.37, 1.0, 2.61, 17.2, MAX_ONE_OFF_STEPS + 0.9] {
            let tau = (steps + 1e-3) * h;
            let mut once = full_bins(&a);
            let mut out = [0.0; 5];
            once.apply(tau, &z0, &mut out);
            assert_eq!(
                once.built_bins(),
                RECURRING_CAPACITY,
                "{steps} steps: no matrix built"
            );
            let phi = once.transition_matrix(tau);
            let binned = &phi * nalgebra::DVector::from_column_slice(&z0);
            let err = max_rel_diff(&out, binned.as_slice());
            worst = worst.max(err);
            assert!(err < 4e-15 * (1.0 + steps), "{steps} steps: {err:e}");
        }
        eprintln!("one-off against Padé: {worst:e}");
        let mut long = full_bins(&a);
        let mut out = [0.0; 5];
        long.apply((MAX_ONE_OFF_STEPS + 2.0) * h, &z0, &mut out);
        assert_eq!(
            long.built_bins(),
            RECURRING_CAPACITY + 1,
            "a long duration gets its bin"
        );
    }

    /// A mode that applied bins before its promotion (its guards all excluded) keeps them:
    /// promotion takes the bins' memory only if it was not taken yet.
    #[test]
    fn promotion_keeps_the_bins_built_before_it() {
        let a = forced_oscillator();
        let mut mode = ModeTransitions::new(a.clone(), (3.5e8f64).sqrt());
        let z0 = [1e-5, 0.2, 0.6, 0.8, 1.0];
        let tau = 3.1e-5;
        let (mut before, mut after) = ([0.0; 5], [0.0; 5]);
        for _ in 0..2 {
            mode.apply(tau, &z0, &mut before);
        }
        assert_eq!(mode.built_bins(), 1, "the second meeting built the bin");
        mode.promote(true);
        mode.apply(tau, &z0, &mut after);
        assert_eq!(after, before, "the same bin after the promotion");
        let reference = (&a * tau).exp() * nalgebra::DVector::from_column_slice(&z0);
        assert!(max_rel_diff(&after, reference.as_slice()) < 1e-13);
    }

    impl ModeTransitions {
        fn built_bins(&self) -> usize {
            self.builds as usize
        }
    }

    /// A mode whose bins are all in use (durations unlike the tested ones).
    fn full_bins(a: &DMatrix<f64>) -> ModeTransitions {
        let mut mode = ModeTransitions::new(a.clone(), (3.5e8f64).sqrt());
        let mut out = [0.0; 5];
        for k in 0..RECURRING_CAPACITY {
            // Met twice: the first meeting takes no bin, the second builds it.
            for _ in 0..2 {
                mode.apply(1e-7 * (1.0 + k as f64 / 7.0), &[1.0; 5], &mut out);
            }
        }
        assert_eq!(mode.recurring.centres.len(), RECURRING_CAPACITY);
        mode
    }
}
