//! Exact piecewise-LTI propagation (numerics-notes §2.3).
//!
//! Between stops and events every segment of an eligible scene is `z' = A_mode z` with an
//! augmented state `z` (harmonic and constant forcing folded in), so
//! `z(t + τ) = expm(A τ) z(t)` exactly. `expm` is a Padé scaling-and-squaring on the stack
//! ([`expm`]; Higham 2005) of the balanced matrix ([`balanced`]): no eigendecomposition, so the
//! separated mode, whose matrix has a Jordan block, is handled like any other.
//!
//! Cost (numerics-notes §2.3: O(1) per segment whatever the stiffness): each mode's `A` and
//! transition operators are built once ([`transition`]); a segment whose duration recurs
//! (stiffness pieces, output intervals, event times of a periodic steady state) costs one
//! fused mat-vec of a duration-binned `e^{Aτ}`; a matrix exponential is paid only for a
//! duration met twice. Nothing is allocated per segment. A mode met few times (a train with
//! contact loss meets thousands of contact combinations, each rarely) is not built at all:
//! its segments go by the Taylor series of the state and their guards' polynomials
//! ([`series_segment`]). A mode takes the full path from its first meeting while the modes
//! on it stay within a memory budget that keeps their data near the core ([`ModeCache`]), so a
//! scene with few modes never takes the series.
//!
//! Events inside a segment ([`crossing`]): guards a model can prove positive for the whole
//! segment ([`PiecewiseLti::guard_excluded`], e.g. an energy bound) are not evaluated at all;
//! the others are sampled at a quarter of the fastest period, each sample interval is proved
//! free of crossings by a curvature bound, or its crossing is located on the guard's Taylor
//! polynomial (Newton) and proved the first by the same bound, or the interval is searched
//! rigorously for its first crossing ([`enclosure`], then Brent); the system snaps the state
//! onto the surface. A segment that recurs (a periodic orbit repeats its segments) is decided
//! instead by an earlier one of its mode and a perturbation bound ([`recurrence`]); and where
//! the model's forcing states are continuous they are carried from a segment's end into the
//! next instead of lifted again ([`PiecewiseLti::forcing_carries_over`]).
//!
//! A run of guard-free segments whose stops do not depend on the state
//! ([`PiecewiseLti::stops_independent_of_state`], e.g. a drivetrain with linear contact) is
//! walked first and, when the same sequence of modes and switching instants recurs (a mesh
//! period of a train), applied as one product of its transitions ([`composite`]): one mat-vec
//! per recurring period instead of one per stiffness switch. A recurring run of guarded
//! segments whose stops the model can walk ahead of the state
//! ([`PiecewiseLti::stops_assume_contact`]: a train on the contact-loss law) is applied the
//! same way where a certificate from a reference run proves that no guard crosses in it
//! ([`guarded`]); elsewhere the walk is taken back. If the state turns non-finite in
//! such a run, the error is reported at the run's start while the model's stops have moved to
//! its end (the run is then over anyway).

mod balanced;
#[cfg(test)]
mod balanced_tests;
pub use balanced::exp_work;
#[cfg(test)]
mod budget_tests;
#[cfg(test)]
mod cache_tests;
mod composite;
mod crossing;
mod enclosure;
mod expm;
mod guard_series;
mod guarded;
pub mod mat_vec;
mod recurrence;
pub mod segment_series;
mod series_segment;
#[cfg(test)]
mod test_support;
pub mod transition;

use std::cell::Cell;
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};
use std::sync::Arc;

use nalgebra::DMatrix;

use super::work::WorkPrices;
use super::{HybridSystem, SolveError, SolverStats};
use balanced::BandFrame;
use composite::{Composites, Lookup, Step};
use crossing::{first_crossing, root_tolerance, Crossing, Workspace};
use guard_series::DerivativeRows;
use recurrence::Decision;
use segment_series::{Segment, SegmentObserver, SeriesBuffers, Unobserved};
use series_segment::SeriesWorkspace;
use transition::ModeTransitions;

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
    /// The rows of `A` in which the modes differ, if every other row of
    /// [`PiecewiseLti::lti_matrix`] is the same in every mode of the current parameters and
    /// inputs (a change of either clears the propagator's modes,
    /// [`ExactPropagator::invalidate`]): a mode met once can then be built from its band
    /// alone ([`PiecewiseLti::lti_band_rows`], `balanced::BandFrame`). `None` (the default):
    /// every mode builds its whole matrix.
    fn lti_band(&self) -> Option<std::ops::Range<usize>> {
        None
    }
    /// The rows [`PiecewiseLti::lti_band`] of the current mode's `A`, bit for bit those of
    /// [`PiecewiseLti::lti_matrix`], column-major (columns of the band's height) into `rows`,
    /// which holds zeros.
    fn lti_band_rows(&self, _rows: &mut [f64]) {}
    /// Writes a key that identifies the current mode among the modes of one parameter set
    /// (its matrix, its guard count and its guard rows) into `key`, which is cleared first.
    /// Any number of digits fits: there is no limit on meshes or contact states.
    fn mode_key(&self, key: &mut ModeKey);
    /// An upper bound of the fastest angular frequency in any mode, rad/s.
    fn max_frequency(&self) -> f64;
    /// Whether guard `index` of the current mode provably stays positive for all time from the
    /// lifted state `z` while the mode lasts (e.g. an energy bound of the free response around
    /// the forced one), so that no root function need be evaluated in this segment. Must never
    /// return `true` for a guard that can cross; `false` is always safe.
    fn guard_excluded(&self, _index: usize, _z: &[f64]) -> bool {
        false
    }
    /// [`HybridSystem::on_event`] with the lifted event state `z` at hand, so a jump map that
    /// needs a forcing value at the event (e.g. the STE, to snap onto the surface) can read
    /// it from the propagated forcing states instead of evaluating it again.
    fn on_event_lifted(&mut self, t: f64, _z: &[f64], y: &mut [f64], index: usize) {
        self.on_event(t, y, index)
    }
    /// Whether the entries of `z` beyond `y` (the forcing states) are continuous across stops
    /// and events, so that the propagator may carry them from a segment's end into the next
    /// segment instead of lifting again ([`ExactPropagator`] still lifts every
    /// [`RELIFT_EVERY`]-th segment). `false` (the default) for forcing states that restart at
    /// a stop, such as a ramp local to a stiffness piece.
    fn forcing_carries_over(&self) -> bool {
        false
    }
    /// Whether [`HybridSystem::on_stop`] neither reads nor changes `y` while the current mode
    /// has no guards (e.g. a drivetrain whose meshes all have a linear contact law: a stop
    /// only switches the stiffness piece), so that the propagator may walk the stops of a
    /// run of guard-free segments before it propagates the state through them and apply a
    /// recurring run as one composite transition ([`composite`]). `false` (the default) is
    /// always safe.
    fn stops_independent_of_state(&self) -> bool {
        false
    }
    /// Whether the model can walk its stops ahead of the state while its modes have guards
    /// ([`PiecewiseLti::on_stop_assuming_contact`]), so that a recurring guarded sequence (a
    /// mesh period of a train on the contact-loss law) can be decided whole ([`guarded`]).
    /// `false` (the default) is always safe.
    fn stops_assume_contact(&self) -> bool {
        false
    }
    /// [`HybridSystem::on_stop`] without the state: every contact the stop would decide from
    /// the state (a tooth pair that enters) is taken as closed. That contact's guard must be
    /// a guard of the next mode, so that it is positive at the mode's start exactly when the
    /// assumption holds ([`guarded`] proves it).
    fn on_stop_assuming_contact(&mut self, _t: f64) {}
    /// Writes into `out` (cleared first) what the stops change, for
    /// [`PiecewiseLti::restore_stops`].
    fn save_stops(&self, out: &mut Vec<u64>) {
        out.clear();
    }
    /// Restores the stops' part of the model saved by [`PiecewiseLti::save_stops`] (a walk
    /// of guarded stops that could not be proved is taken back).
    fn restore_stops(&mut self, _saved: &[u64]) {}
}

/// Segments after which the propagator lifts `z` afresh even when the model's forcing states
/// carry over: the carried `cos`/`sin` states pass through one rounded rotation per segment,
/// and a fresh lift from the clock bounds what they can accumulate.
pub const RELIFT_EVERY: u32 = 8;

/// The key of a mode: a mixed-radix number of any length (one digit per mesh interval, per
/// contact flag, …), packed into as many 64-bit words as it needs. Packing with the same
/// sequence of radices is injective, so two modes of one parameter set have equal keys only
/// if they are the same mode.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ModeKey {
    words: Vec<u64>,
    /// Product of the radices packed into the last word.
    capacity: u64,
}

impl Default for ModeKey {
    fn default() -> Self {
        ModeKey {
            words: vec![0],
            capacity: 1,
        }
    }
}

impl ModeKey {
    /// Empties the key (no allocation once the key has held a mode).
    pub fn clear(&mut self) {
        self.words.clear();
        self.words.push(0);
        self.capacity = 1;
    }

    /// Appends the digit `value` (`< radix`) of radix `radix >= 1`.
    pub fn push(&mut self, value: u64, radix: u64) {
        debug_assert!(
            radix >= 1 && value < radix,
            "digit {value} of radix {radix}"
        );
        let last = match self.capacity.checked_mul(radix) {
            Some(c) => {
                self.capacity = c;
                self.words.last_mut().expect("a key has a word")
            }
            None => {
                self.words.push(0);
                self.capacity = radix;
                self.words.last_mut().expect("just pushed")
            }
        };
        *last = *last * radix + value;
    }

    /// The packed words.
    pub fn words(&self) -> &[u64] {
        &self.words
    }

    /// A multiplicative hash of the words.
    fn hash(&self) -> u64 {
        let mut h = ModeKeyHasher::default();
        for &w in &self.words {
            h.write_u64(w);
        }
        h.finish()
    }
}

/// Mode keys are small integers chosen by the model: a multiplicative hash is enough (the
/// default SipHash would cost more than a whole-segment mat-vec).
#[derive(Default)]
struct ModeKeyHasher(u64);

impl Hasher for ModeKeyHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0.rotate_left(8) ^ b as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        }
    }
    fn write_u64(&mut self, v: u64) {
        self.0 = (self.0 ^ v).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    }
}

/// Transition operators per mode key; cleared when parameters or inputs change.
#[derive(Default)]
struct ModeCache {
    modes: Vec<ModeTransitions>,
    /// The keys of the modes in one allocation: mode `p`'s words and then its last word's
    /// capacity end at `key_ends[p]` (a lookup of a train's thousands of modes touches one
    /// line of keys rather than a separate allocation per key).
    key_words: Vec<u64>,
    key_ends: Vec<u32>,
    /// The first position in `modes` by key hash; the rare others of the same hash follow
    /// through `same_hash_next` (`u32::MAX`: none).
    index: HashMap<u64, u32, BuildHasherDefault<ModeKeyHasher>>,
    same_hash_next: Vec<u32>,
    /// Direct-mapped `(hash + 1, position)` by `hash mod RECENT`: a periodic orbit cycles
    /// through a few modes, and a segment then finds its mode without a map lookup (`0`:
    /// empty; the key itself is compared before a hit is used).
    recent: [(u64, usize); ModeCache::RECENT],
    /// The key of the current mode, reused so that writing it does not allocate.
    scratch: ModeKey,
    /// Products of recurring sequences of guard-free segments of these modes.
    composites: Composites,
    /// Heap bytes of the cached modes: exact after [`ModeCache::recount`], plus each new
    /// mode's bytes at its build (its bins, guard rows and references grow after it).
    bytes: usize,
    /// Modes built since the last recount.
    since_recount: u32,
    /// The system's bound of the fastest rate of any mode ([`PiecewiseLti::max_frequency`],
    /// a property of the parameter set), asked once per cache.
    max_rate: Option<f64>,
    /// Estimated heap bytes of the modes promoted to the full path.
    promoted_bytes: usize,
    /// The budget in bytes ([`ModeCache::MEMORY_BUDGET`] unless the owner sets one:
    /// `solver.exact_memory_mb`, smaller in tests).
    budget: Option<usize>,
    /// The largest heap bytes one mode of this cache has held (at its build, promotion or a
    /// recount): the room kept free for the next mode, so that building it cannot carry the
    /// cache over its budget.
    largest_mode: usize,
    /// The most bytes the cache has held ([`ModeCache::held`], as counted; never reset).
    peak: usize,
    /// Modes built and times the full cache was cleared (for benchmarks; never reset).
    builds: u64,
    clears: u64,
    /// The band frame of the modes met beyond the promoted budget
    /// ([`PiecewiseLti::lti_band`]), balanced by their envelope; cleared with the modes.
    frame: Option<Arc<BandFrame>>,
    /// Modes built in the band frame since the propagator last read the count.
    frame_builds: u64,
    /// `max |A|` entry by entry of the modes the frame was taken from
    /// ([`ModeCache::widen_frame`]).
    envelope: Option<DMatrix<f64>>,
}

/// The default bound of the mode cache in MiB ([`ModeCache::MEMORY_BUDGET`]; a scene's
/// `solver.exact_memory_mb`).
pub const MEMORY_BUDGET_MB: usize = 512;

impl ModeCache {
    /// Heap bytes the cached modes and their composite products may hold: one bound at
    /// every size (`docs/scaling.md`, "Memory"). Before a mode is built, the cache is
    /// cleared if its bytes plus the largest mode's would exceed it. A drivetrain with
    /// contact loss meets many contact combinations (the 8-mesh benchmark chain all 4096 of
    /// its 16 stiffness patterns × 2⁸ contact states, ~70 kB each), and rebuilding a mode
    /// costs ~100 µs, so the bound is in bytes rather than modes: small modes are cheap to
    /// keep, and a long co-simulation still cannot grow the cache without limit. A scene
    /// may raise or lower it (`solver.exact_memory_mb`).
    pub const MEMORY_BUDGET: usize = MEMORY_BUDGET_MB << 20;
    /// Modes at most, whatever their size (the index's own memory).
    const MAX_MODES: usize = 1 << 16;
    /// New modes between two exact recounts of the bytes, at least (and a quarter of the
    /// cached modes: a recount visits every mode, so a cache of thousands of modes recounts
    /// in proportion to its size, O(1) per build).
    const RECOUNT_EVERY: u32 = 64;
    const RECENT: usize = 16;
    /// Estimated heap bytes of the modes with guards on the full path (sample steps, duration
    /// bins, curvature bounds, recurring references) at most, about the L2 caches of a small
    /// machine: beyond them the full path's data is cold when its mode returns and its build
    /// is paid for few segments, and a segment by the series ([`series_segment`]) is cheaper
    /// (the 8-mesh chain with contact loss: 4096 modes; `docs/scaling.md`). A scene with few
    /// modes (the single pair, the idler) promotes every mode at its first meeting.
    const PROMOTED_BUDGET: usize = 4 << 20;

    /// Whether building one more mode would carry the cache over its budget (its bytes plus
    /// the largest mode's; recounted exactly first when the estimate says so).
    fn full(&mut self) -> bool {
        if self.modes.len() >= Self::MAX_MODES {
            return true;
        }
        if self.modes.is_empty() {
            return false;
        }
        // (No recount without a new mode since the last: the composite walk asks on every
        // segment while the cache is over its budget.)
        if self.since_recount > 0
            && (self.held() + self.largest_mode > self.budget()
                || self.since_recount as usize
                    >= (self.modes.len() / 4).max(Self::RECOUNT_EVERY as usize))
        {
            self.recount();
        }
        self.held() + self.largest_mode > self.budget()
    }

    fn budget(&self) -> usize {
        self.budget.unwrap_or(Self::MEMORY_BUDGET)
    }

    /// Heap bytes held: the modes' (as counted), the composite products' and the band
    /// frame's.
    fn held(&self) -> usize {
        self.bytes
            + self.composites.heap_bytes()
            + self.frame.as_ref().map_or(0, |f| f.heap_bytes())
            + self.envelope.as_ref().map_or(0, |e| e.len() * 8)
    }

    /// Whether a composite product of `nz` states fits beside the cached modes (a product
    /// is built where its modes recur, so no new mode is due: the next one clears the cache
    /// if the room for it is gone).
    fn product_fits(&self, nz: usize) -> bool {
        self.held() + nz * nz * 8 <= self.budget()
    }

    /// Whether a mode may take `bytes` more (its promotion to the full path) within the
    /// budget, beside the room kept for the next mode.
    fn fits(&self, bytes: usize) -> bool {
        self.held() + bytes + self.largest_mode <= self.budget()
    }

    /// Notes the bytes held now in [`ModeCache::peak`].
    fn note_peak(&mut self) {
        self.peak = self.peak.max(self.held());
    }

    fn recount(&mut self) {
        self.bytes = 0;
        for mode in &self.modes {
            let bytes = mode.heap_bytes();
            self.bytes += bytes;
            self.largest_mode = self.largest_mode.max(bytes);
        }
        self.since_recount = 0;
        self.note_peak();
    }

    /// The current mode of `sys`, built on first use (its `A` from `lti_matrix`).
    fn get<S: PiecewiseLti>(&mut self, sys: &S) -> &mut ModeTransitions {
        let position = self.get_position(sys);
        &mut self.modes[position]
    }

    /// Whether mode `position` has the key in `scratch`.
    fn has_scratch_key(&self, position: usize) -> bool {
        let start = match position {
            0 => 0,
            p => self.key_ends[p - 1] as usize,
        };
        let stored = &self.key_words[start..self.key_ends[position] as usize];
        let (capacity, words) = stored.split_last().expect("a key has its capacity");
        let scratch = self.scratch.words();
        // Word by word rather than a slice `==`, which calls `memcmp`: keys are a few words and
        // this runs once per segment.
        *capacity == self.scratch.capacity
            && words.len() == scratch.len()
            && words.iter().zip(scratch).all(|(a, b)| a == b)
    }

    /// The position in `modes` of the mode whose key is in `scratch`, if cached.
    fn find_scratch(&self) -> Option<usize> {
        let mut position = *self.index.get(&self.scratch.hash())?;
        while position != u32::MAX {
            if self.has_scratch_key(position as usize) {
                return Some(position as usize);
            }
            position = self.same_hash_next[position as usize];
        }
        None
    }

    /// The position of the current mode of `sys` in `modes`, built on first use.
    fn get_position<S: PiecewiseLti>(&mut self, sys: &S) -> usize {
        self.scratch.clear();
        sys.mode_key(&mut self.scratch);
        let hash = self.scratch.hash();
        let slot = (hash % Self::RECENT as u64) as usize;
        let (tag, position) = self.recent[slot];
        if tag == hash.wrapping_add(1) && self.has_scratch_key(position) {
            return position;
        }
        let position = match self.find_scratch() {
            Some(position) => position,
            None => {
                if self.full() {
                    self.clear();
                    self.clears += 1;
                }
                self.builds += 1;
                let rate = *self.max_rate.get_or_insert_with(|| sys.max_frequency());
                let mode = self.build(sys, rate);
                let bytes = mode.heap_bytes();
                self.bytes += bytes;
                self.largest_mode = self.largest_mode.max(bytes);
                self.since_recount += 1;
                self.modes.push(mode);
                if sys.guard_count() == 0 {
                    // No guards, no series search: the full path (bins, composite products)
                    // at once.
                    self.promote(self.modes.len() - 1);
                }
                self.key_words.extend_from_slice(self.scratch.words());
                self.key_words.push(self.scratch.capacity);
                self.key_ends.push(self.key_words.len() as u32);
                let position = self.modes.len() - 1;
                self.note_peak();
                // The new mode heads its hash's chain.
                let previous = self.index.insert(hash, position as u32);
                self.same_hash_next.push(previous.unwrap_or(u32::MAX));
                position
            }
        };
        self.recent[slot] = (hash.wrapping_add(1), position);
        position
    }

    /// Puts mode `position` on the full path, with room for its bins to grow
    /// ([`ModeTransitions::promote`]) while the cache holds less than a quarter of its
    /// budget with it (so that the grants never clear a cache that would not have been
    /// cleared without them by much; scenes with few modes take a few MB); the bytes it takes
    /// are counted at once.
    fn promote(&mut self, position: usize) {
        let room = self.budget() / 4;
        let mode = &mut self.modes[position];
        let before = mode.heap_bytes();
        mode.promote(self.bytes + mode.grown_bin_bytes() <= room);
        // The full path's guard data (derivative rows, curvature weights, references) grows
        // with use: counted at its estimate until the next recount.
        let after = mode.heap_bytes().max(mode.full_bytes_estimate());
        self.bytes += after.saturating_sub(before);
        self.largest_mode = self.largest_mode.max(after);
        self.note_peak();
    }

    fn clear(&mut self) {
        self.modes.clear();
        self.key_words.clear();
        self.key_ends.clear();
        self.index.clear();
        self.same_hash_next.clear();
        self.recent = Default::default();
        self.composites.clear();
        self.bytes = 0;
        self.since_recount = 0;
        self.promoted_bytes = 0;
        self.max_rate = None;
        self.frame = None;
        self.envelope = None;
    }

    /// The position of the current mode of `sys` (built on first use), or `None` if building
    /// it would clear the cache (positions recorded before would then be stale).
    fn position<S: PiecewiseLti>(&mut self, sys: &S) -> Option<usize> {
        if self.full() {
            self.scratch.clear();
            sys.mode_key(&mut self.scratch);
            self.find_scratch()?;
        }
        Some(self.get_position(sys))
    }

    /// The position of the current mode of `sys` if it is cached (nothing is built).
    fn cached_position<S: PiecewiseLti>(&mut self, sys: &S) -> Option<usize> {
        self.scratch.clear();
        sys.mode_key(&mut self.scratch);
        self.find_scratch()
    }

    /// The operators of the current mode: `A` from `lti_matrix`, or only its band in the
    /// band frame where the mode will go by its series ([`ModeCache::series_from_birth`]),
    /// and the guard rows (`rate`: the system's [`PiecewiseLti::max_frequency`]).
    fn build<S: PiecewiseLti>(&mut self, sys: &S, rate: f64) -> ModeTransitions {
        let nz = sys.lti_dim();
        let band = sys.lti_band().filter(|_| self.series_from_birth(sys));
        let in_frame = match (&self.frame, &band) {
            (Some(frame), Some(_)) => {
                let mut rows = vec![0.0; frame.band().len() * nz];
                sys.lti_band_rows(&mut rows);
                frame.balance(rows)
            }
            _ => None,
        };
        let mut mode = match in_frame {
            Some(balanced) => {
                self.frame_builds += 1;
                ModeTransitions::in_frame(balanced, rate)
            }
            None => {
                let mut a = DMatrix::zeros(nz, nz);
                sys.lti_matrix(&mut a);
                if let Some(band) = band {
                    self.widen_frame(&a, band);
                }
                ModeTransitions::new(a, rate)
            }
        };
        Self::add_guard_rows(sys, &mut mode);
        mode
    }

    /// Takes mode `a` (built whole: the first of the frame, or one the frame's `D` did not
    /// suit) into the envelope `max |A|` of the frame's modes, and the frame's `D` from the
    /// envelope balanced. The `D` of one contact combination can be far from another's: a
    /// chain split by a lost contact balances its two parts independently, and with such a
    /// mode's `D` the free 32-mesh rigid chain's connected modes had column sums of `|B|` up
    /// to 1.7e12 against 3.4e4. Every mode within the envelope has `‖B‖₁` at most the
    /// envelope's.
    fn widen_frame(&mut self, a: &DMatrix<f64>, band: std::ops::Range<usize>) {
        let envelope = self
            .envelope
            .get_or_insert_with(|| DMatrix::zeros(a.nrows(), a.ncols()));
        if envelope.shape() != a.shape() {
            return;
        }
        for (e, &x) in envelope.iter_mut().zip(a.iter()) {
            *e = e.max(x.abs());
        }
        let balanced = balanced::BalancedMatrix::new(envelope);
        self.frame = BandFrame::of(a, &balanced, band).map(Arc::new);
    }

    /// Whether a mode built now will go by its series: it has guards and the promoted modes
    /// have taken their budget (the full path then takes it only where the series cannot go,
    /// which builds its `A` then).
    fn series_from_birth<S: PiecewiseLti>(&self, sys: &S) -> bool {
        sys.guard_count() > 0 && self.promoted_bytes >= Self::PROMOTED_BUDGET
    }

    /// The guard rows of the current mode of `sys`.
    fn add_guard_rows<S: PiecewiseLti>(sys: &S, mode: &mut ModeTransitions) {
        let nz = sys.lti_dim();
        let mut w = vec![0.0; nz];
        mode.guard_rows = (0..sys.guard_count())
            .map(|i| {
                sys.guard_row(i, &mut w);
                let mut rows = DerivativeRows::default();
                rows.set_row(&w);
                rows
            })
            .collect();
        if !mode.guard_rows.is_empty() {
            // What the series path takes of a mode, taken now: a mode that is never promoted
            // then holds the bytes counted at its build ([`ModeCache::full`]).
            mode.balanced_guard_rows();
        }
    }
}

/// The heap bytes of an exact propagator's mode cache ([`ExactPropagator::memory`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CacheMemory {
    pub held: usize,
    pub peak: usize,
    pub budget: usize,
}

/// The exact propagator: same stateful interface as the RK stepper.
pub struct ExactPropagator {
    t: f64,
    y: Vec<f64>,
    stats: SolverStats,
    modes: ModeCache,
    z: Vec<f64>,
    z_next: Vec<f64>,
    z_event: Vec<f64>,
    /// A sensitivity column lifted into `z` (forcing entries zero) while it is propagated.
    column: Vec<f64>,
    crossing: Workspace,
    series: SeriesWorkspace,
    /// Events without time progress, to stop a Zeno cascade.
    stalled_events: u64,
    /// Whether recurring segments are decided by earlier ones ([`recurrence`]; on by default).
    recurrences: bool,
    /// `z` holds the propagated state at `t` (the last segment's end) and this many segments
    /// have started from a carried `z` since the last fresh lift; `None`: lift afresh.
    carried: Option<u32>,
    /// `∂y(t)/∂y(t_track)` when tracking is on: the product of the `y` blocks of the applied
    /// transition matrices (the forcing rows of `z` do not depend on `y`).
    sensitivity: Option<DMatrix<f64>>,
    /// Whether recurring sequences of guard-free segments are applied as one composite
    /// transition ([`composite`]; on by default).
    composites: bool,
    /// The sequence being walked.
    sequence: Vec<Step>,
    /// The model's stops before a guarded walk ([`PiecewiseLti::save_stops`]), the buffers
    /// of its certification, and where the segment-wise path goes on after a walk that was
    /// taken back (its span, times [`ExactPropagator::guarded_backoff`] after refused
    /// certificates, so a scene that loses contact pays for few certifications).
    stop_state: Vec<u64>,
    /// The model's stops before the last stop of a guarded walk: that stop's assumed
    /// contacts are proved by no segment of the sequence, so an accepted walk takes it again
    /// from the state ([`ExactPropagator::advance_guarded_sequence`]).
    last_stop_state: Vec<u64>,
    certify_work: guarded::CertifyWork,
    segment_wise_until: f64,
    guarded_backoff: u32,
    /// A capture asked to forget the history before the next advance
    /// ([`ExactPropagator::forget_before_next_advance`]).
    forget_pending: Cell<bool>,
    /// The owner's prices of this propagator's work, and the cumulative work at which an
    /// advance stops ([`crate::solve::work`], checked at every segment beside the
    /// propagator's own [`WorkBudget`]); `None`: unbounded.
    prices: WorkPrices,
    work_limit: Option<WorkLimit>,
    /// Work of the metered exponentials ([`balanced::exp_work`]) and guard samples of the
    /// crossing searches of all advances so far (the rest of [`ExactPropagator::work`] is
    /// in the counters).
    exp_units: f64,
    /// Work units of the segment observers ([`SegmentObserver`], priced by the segment).
    observer_units: f64,
    guard_samples: f64,
    /// Whether the current advance checked its limit in full (and may have read work
    /// that came with exponentials).
    checked_in_full: bool,
    /// The windows' terms of the segment an observer looks into ([`segment_series`]).
    observed: SeriesBuffers,
}

/// Events allowed at one instant before the propagation gives up (Zeno guard).
const MAX_STALLED_EVENTS: u64 = 64;

/// Consecutive stops of zero length (a stop at the current time) allowed before the
/// propagation gives up: a model whose stops no longer move forward (a mesh phase that lost
/// its resolution) would otherwise switch pieces forever without time advancing.
const MAX_STALLED_STOPS: u64 = 1024;

/// Guard samples the crossing search may take in one [`ExactPropagator::advance_to`]
/// (2^24 ≈ 1.7e7, a few tenths of a second): a segment is sampled every quarter of the
/// fastest period of its mode, so a mode far faster than the span asked for (e.g. an
/// equivalent mass of 1e-12 kg under ordinary damping: rate 1e15 1/s) would take billions of
/// samples. Checked before each search from its segment length (O(1)); refused with
/// [`SolveError::TooManyGuardSamples`]. A normal run takes a few samples per mesh period, and
/// recurring segments none, so 2^20 mesh periods (the driver's limit of one advance,
/// [`crate::model::MAX_MESH_PERIODS_PER_ADVANCE`]) stay well within it.
pub const MAX_GUARD_SAMPLES_PER_ADVANCE: f64 = 16_777_216.0;

/// The work one [`ExactPropagator::advance_to`] may do beyond the model's own stops, in units
/// of `n_z³` per segment (2^30; `n_z` = [`PiecewiseLti::lti_dim`]): a segment's cost grows
/// with the cube of the lifted dimension (a transition `e^{Aτ}` for a new duration, the
/// mat-vecs and guard rows of its search), so the bound allows 8.6e6 segments of the single
/// pair (`n_z = 5`) and 1.6e5 of the `idler_gearset` drivetrain (`n_z = 19`). Every stop the
/// advance lands on adds [`SEGMENTS_PER_STOP`] to it ([`WorkBudget`]). Beyond it the advance
/// stops with [`SolveError::TooManySteps`] at the last segment end (issue 17: no step may
/// grind).
pub const MAX_WORK_PER_ADVANCE: f64 = 1_073_741_824.0;

/// Segments each stop landed on adds to the budget of one advance: the stop's own segment
/// and up to 15 state events within the piece it ends. The stops are the model's known
/// switches of the interval asked for (stiffness pieces: two per mesh and mesh period), whose
/// number per advance the driver already bounds ([`crate::model::PhaseClock::check_advance`]),
/// so they are legitimate work however large the train: the 64-mesh compliant chain
/// (`n_z = 390`, 128 stops per mesh period) would otherwise be refused after 17 segments.
/// What the budget stops is a runaway of events (contact chatter) that time no longer
/// pays for.
pub const SEGMENTS_PER_STOP: u64 = 16;

/// Refuses a search of `samples` guard samples (or their equivalent in series sub-steps) when
/// the advance has fewer left ([`MAX_GUARD_SAMPLES_PER_ADVANCE`]).
fn check_samples(
    samples: f64,
    samples_left: f64,
    t: f64,
    tau: f64,
    mode: &ModeTransitions,
) -> Result<(), SolveError> {
    if samples > samples_left {
        return Err(SolveError::TooManyGuardSamples {
            t,
            tau,
            samples,
            rate: mode.fastest_rate(),
        });
    }
    Ok(())
}

/// The segment budget of one advance: a base for the events between stops (`MAX_WORK /
/// n_z³`), plus [`SEGMENTS_PER_STOP`] per stop landed on.
#[derive(Debug, Clone, Copy)]
struct WorkBudget {
    base: u64,
    segments: u64,
    stops: u64,
}

impl WorkBudget {
    fn new(nz: usize) -> Self {
        WorkBudget {
            base: (MAX_WORK_PER_ADVANCE / (nz as f64).powi(3)) as u64,
            segments: 0,
            stops: 0,
        }
    }

    fn limit(&self) -> u64 {
        self.base
            .saturating_add(self.stops.saturating_mul(SEGMENTS_PER_STOP))
    }

    /// Counts one segment starting at `t`; the error once the budget is exceeded.
    fn charge(&mut self, t: f64) -> Result<(), SolveError> {
        self.segments += 1;
        if self.segments > self.limit() {
            return Err(SolveError::TooManySteps {
                t,
                max_steps: self.limit(),
            });
        }
        Ok(())
    }
}

/// The owner's work limit as the exact propagator checks it before every segment
/// ([`ExactPropagator::set_work_limit`]). Summing every term of [`ExactPropagator::work`]
/// per segment (the exponential meter is thread-local) costs a tenth of a single-pair
/// segment, so a segment compares only two counters with thresholds: between full checks
/// the work grows only by segments and guard evaluations (everything else — searches with
/// their guard samples, series segments, duration bins and modes built with their
/// exponentials — forces the next full check ([`force_check`]) or
/// changes `builds`), and the thresholds allow each of them half of the work left at the
/// last full check. The limit is thus met at the same segment as with the full sum: a
/// segment starting at or past `until` has spent half the work left in one of the two.
#[derive(Debug, Clone, Copy)]
struct WorkLimit {
    until: f64,
    /// The full check is due at a segment starting with this many segments or guard
    /// evaluations ([`SolverStats`]) or with another count of modes built.
    check_steps: u64,
    check_evals: u64,
    builds: u64,
}

/// Adds the work of the observer of the segment just handed over ([`SegmentObserver`]) to
/// the run's (`observer_units`); under a limit, the next segment checks it in full (the
/// observer's work is not counted in segments), so a run with statistics stops at its budget
/// too, within one segment's observation.
#[inline]
fn charge_observation<const METERED: bool>(
    observed: &mut SeriesBuffers,
    observer_units: &mut f64,
    limit: &mut Option<WorkLimit>,
) {
    let units = observed.take_work();
    if units > 0.0 {
        *observer_units += units;
        if METERED {
            force_check(limit);
        }
    }
}

/// Work other than segments and guard evaluations was done (a search, a series segment, a
/// duration bin built): the limit is checked in full before the next segment (a free
/// function: the mode being walked borrows the propagator's cache).
#[inline(always)]
fn force_check(limit: &mut Option<WorkLimit>) {
    if let Some(limit) = limit {
        limit.check_steps = 0;
    }
}

impl WorkLimit {
    /// A limit at `until` whose full check is due at the next segment.
    fn new(until: f64) -> Self {
        WorkLimit {
            until,
            check_steps: 0,
            check_evals: 0,
            builds: u64::MAX,
        }
    }
}

/// Where this thread's exponential meter and the guard samples stood at the start of an
/// advance, and the samples it has taken.
#[derive(Debug, Clone, Copy)]
struct AdvanceMeter {
    exp_work0: f64,
    samples_left: f64,
}

impl AdvanceMeter {
    fn samples(&self) -> f64 {
        MAX_GUARD_SAMPLES_PER_ADVANCE - self.samples_left
    }
}

impl ExactPropagator {
    pub fn new<S: PiecewiseLti>(sys: &S) -> Self {
        let n = sys.lti_dim();
        ExactPropagator {
            t: 0.0,
            y: vec![0.0; sys.dim()],
            stats: SolverStats::default(),
            modes: ModeCache::default(),
            z: vec![0.0; n],
            z_next: vec![0.0; n],
            z_event: vec![0.0; n],
            column: vec![0.0; n],
            crossing: Workspace::default(),
            series: SeriesWorkspace::default(),
            stalled_events: 0,
            recurrences: true,
            carried: None,
            sensitivity: None,
            composites: true,
            sequence: Vec::new(),
            stop_state: Vec::new(),
            last_stop_state: Vec::new(),
            certify_work: guarded::CertifyWork::default(),
            segment_wise_until: f64::NEG_INFINITY,
            guarded_backoff: 0,
            forget_pending: Cell::new(false),
            prices: WorkPrices::default(),
            work_limit: None,
            exp_units: 0.0,
            observer_units: 0.0,
            guard_samples: 0.0,
            checked_in_full: false,
            observed: SeriesBuffers::default(),
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
        self.carried = None;
        self.segment_wise_until = f64::NEG_INFINITY;
    }

    /// The system's parameters or inputs changed: drop every cached operator.
    pub fn invalidate(&mut self) {
        self.modes.clear();
        self.carried = None;
        self.segment_wise_until = f64::NEG_INFINITY;
        self.guarded_backoff = 0;
    }

    /// Switches the recurring-segment decisions ([`recurrence`]) on or off (then every
    /// segment gets the full crossing search; for comparisons).
    pub fn use_recurrences(&mut self, on: bool) {
        self.recurrences = on;
        if !on {
            self.forget_recurrences();
        }
    }

    /// Drops everything the propagator learned from the run so far: the recurring-segment
    /// references ([`recurrence`]), the duration history of each mode (a duration met once is
    /// applied without a matrix, [`transition::ModeTransitions::apply`]), the products of
    /// recurring sequences and the carried forcing states: the cache is then as a fresh
    /// propagator's. A reference decides an event time, and the two transition paths a state,
    /// to the same tolerance but not to the same last bit, so a state that is captured (and
    /// later restored into a fresh propagator) must continue without the history learned
    /// before it. (The per-mode operators are rebuilt on the next segments; a capture is
    /// rare.)
    pub fn forget_recurrences(&mut self) {
        self.modes.clear();
        self.carried = None;
        self.segment_wise_until = f64::NEG_INFINITY;
        self.guarded_backoff = 0;
    }

    /// [`ExactPropagator::forget_recurrences`] at the start of the next advance: for a
    /// capture that only reads the run (a snapshot), so that the run continues from the
    /// captured state exactly as a restored one does.
    pub fn forget_before_next_advance(&self) {
        self.forget_pending.set(true);
    }

    /// Switches the composite transitions of recurring guard-free sequences ([`composite`])
    /// on (the default) or off (every segment is applied on its own; for comparisons).
    pub fn use_composites(&mut self, on: bool) {
        self.composites = on;
        self.modes.composites.clear();
    }

    /// Modes built and full mode caches cleared so far (a drivetrain with contact loss on
    /// many meshes can meet more contact combinations than the cache holds).
    pub fn mode_counts(&self) -> (u64, u64) {
        (self.modes.builds, self.modes.clears)
    }

    /// Bounds the mode cache (modes and composite products) to `bytes` of heap
    /// (`solver.exact_memory_mb`; default [`ModeCache::MEMORY_BUDGET`]). The cache is
    /// cleared first, so the bound holds from here on.
    pub fn set_memory_budget(&mut self, bytes: usize) {
        self.modes.clear();
        self.modes.budget = Some(bytes);
    }

    /// Heap bytes one promoted mode of `nz` states holds in the mode cache at least: `A`,
    /// its balanced copy, the sample step and two duration bins ([`ModeTransitions`]).
    pub fn mode_bytes_estimate(nz: usize) -> usize {
        5 * nz * nz * 8
    }

    /// The mode cache's memory: the heap bytes it holds now (recounted exactly), the most it
    /// has held (as counted at each build, promotion, product and recount), and its budget.
    pub fn memory(&mut self) -> CacheMemory {
        self.modes.recount();
        CacheMemory {
            held: self.modes.held(),
            peak: self.modes.peak,
            budget: self.modes.budget(),
        }
    }

    /// Composite products (and certificates of guarded sequences, [`guarded`]) built so far
    /// and sequences applied as one product (since the last invalidation or capture).
    pub fn composite_counts(&self) -> (u64, u64) {
        (self.modes.composites.builds, self.modes.composites.hits)
    }

    pub fn t(&self) -> f64 {
        self.t
    }

    /// Prices this propagator's work ([`ExactPropagator::work`]).
    pub fn set_work_prices(&mut self, prices: WorkPrices) {
        self.prices = prices;
    }

    /// Stops every following advance at the first segment end where the cumulative
    /// [`ExactPropagator::work`] has reached `until` ([`SolveError::OverBudget`], an empty
    /// message: the owner words it); `None` lifts the limit.
    pub fn set_work_limit(&mut self, until: Option<f64>) {
        self.work_limit = until.map(WorkLimit::new);
    }

    /// Starts a scope of the owner's budget ([`ExactPropagator::set_work_limit`] at the
    /// cumulative work now plus `limit`; `None`: unbounded) and returns that work, computed
    /// once: an FMU starts one at every call.
    pub fn start_work_scope(&mut self, limit: Option<f64>) -> f64 {
        let work = self.work();
        self.work_limit = limit.map(|limit| {
            let until = work + limit;
            match self.work_limit {
                // The thresholds of the last full check stay conservative for a later end
                // (the work grows), so the next call pays no full check.
                Some(last) if last.until <= until => WorkLimit { until, ..last },
                _ => WorkLimit::new(until),
            }
        });
        work
    }

    /// The work of all advances but that of their segments and guard evaluations.
    fn other_work(&self) -> f64 {
        self.guard_samples * self.prices.guard_eval
            + self.modes.builds as i64 as f64 * self.prices.mode
            + self.exp_units
            + self.observer_units
    }

    /// The work of the segments and guard evaluations so far.
    fn segment_work(&self) -> f64 {
        // Through i64: one instruction (the counts stay far below 2^63).
        self.stats.steps as i64 as f64 * self.prices.step
            + self.stats.guard_evals as i64 as f64 * self.prices.guard_eval
    }

    /// Before a segment starting at `t`: the error once the owner's limit is reached.
    #[inline]
    fn check_work_limit(&mut self, t: f64, meter: &AdvanceMeter) -> Result<(), SolveError> {
        match self.work_limit {
            Some(limit)
                if self.stats.steps >= limit.check_steps
                    || self.stats.guard_evals >= limit.check_evals
                    || self.modes.builds != limit.builds =>
            {
                self.check_work_limit_in_full(t, limit.until, meter)
            }
            _ => Ok(()),
        }
    }

    #[cold]
    fn check_work_limit_in_full(
        &mut self,
        t: f64,
        until: f64,
        meter: &AdvanceMeter,
    ) -> Result<(), SolveError> {
        let work = self.work()
            + meter.samples() * self.prices.guard_eval
            + (balanced::exp_work() - meter.exp_work0);
        self.checked_in_full = true;
        if work >= until {
            return Err(SolveError::OverBudget {
                t,
                message: String::new(),
            });
        }
        // Half the work left to each counter (`as u64` saturates: a zero price allows all).
        let half = 0.5 * (until - work);
        let (steps, evals, builds) = (self.stats.steps, self.stats.guard_evals, self.modes.builds);
        let (step_price, eval_price) = (self.prices.step, self.prices.guard_eval);
        if let Some(limit) = &mut self.work_limit {
            limit.check_steps = steps.saturating_add((half / step_price) as u64);
            limit.check_evals = evals.saturating_add((half / eval_price) as u64);
            limit.builds = builds;
        }
        Ok(())
    }

    /// The work of the segment observers so far ([`SegmentObserver`], e.g. `simulate`'s
    /// statistics), part of [`ExactPropagator::work`].
    pub fn observer_work(&self) -> f64 {
        self.observer_units
    }

    /// The work of all advances so far at the prices set: segments, guard evaluations, modes
    /// built, and (in the advances made under a limit, the only ones whose work is asked
    /// for) guard samples and metered exponentials ([`crate::solve::work`]).
    pub fn work(&self) -> f64 {
        self.segment_work() + self.other_work()
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
        self.advance_observed(sys, t_end, &mut Unobserved)
    }

    /// [`ExactPropagator::advance_to`], handing every segment to `observer` with the system
    /// still in the segment's mode ([`segment_series`]: the state anywhere inside it from the
    /// segment's start and its mode's matrix, without re-integration). Recurring guard-free
    /// sequences are then propagated segment by segment, not as one composite product.
    pub fn advance_observed<S: PiecewiseLti, O: SegmentObserver<S>>(
        &mut self,
        sys: &mut S,
        t_end: f64,
        observer: &mut O,
    ) -> Result<(), SolveError> {
        // The loop comes in two forms: under a limit it meters its work (the exponentials,
        // guard samples and bins built, and the limit checked before every segment);
        // unbounded, it meters nothing, so a run without a budget (a benchmark, a driver used
        // directly) pays nothing per segment for the meter.
        if self.work_limit.is_some() {
            let mut meter = AdvanceMeter {
                exp_work0: balanced::exp_work(),
                samples_left: MAX_GUARD_SAMPLES_PER_ADVANCE,
            };
            self.checked_in_full = false;
            let result = self.advance_metered::<S, O, true>(sys, t_end, &mut meter, observer);
            // Exponentials come only with work that forces a full check (bins, modes,
            // searches): an advance with none, checked or still due, read none.
            let due = matches!(self.work_limit,
                Some(limit) if limit.check_steps == 0 || limit.builds != self.modes.builds);
            if self.checked_in_full || due {
                self.exp_units += balanced::exp_work() - meter.exp_work0;
            }
            self.guard_samples += meter.samples();
            result
        } else {
            let mut meter = AdvanceMeter {
                exp_work0: 0.0,
                samples_left: MAX_GUARD_SAMPLES_PER_ADVANCE,
            };
            self.advance_metered::<S, O, false>(sys, t_end, &mut meter, observer)
        }
    }

    /// [`ExactPropagator::advance_to`], given where the meter stood at its start (the guard
    /// samples left on return were not taken); `METERED`: under the owner's work limit
    /// ([`ExactPropagator::set_work_limit`]), checked before every segment.
    #[inline(always)]
    fn advance_metered<S: PiecewiseLti, O: SegmentObserver<S>, const METERED: bool>(
        &mut self,
        sys: &mut S,
        t_end: f64,
        meter: &mut AdvanceMeter,
        observer: &mut O,
    ) -> Result<(), SolveError> {
        if t_end < self.t {
            return Err(SolveError::BackwardTime { t: self.t, t_end });
        }
        if self.forget_pending.replace(false) {
            self.forget_recurrences();
        }
        let n = sys.dim();
        let nz = sys.lti_dim();
        if self.z.len() != nz {
            self.z.resize(nz, 0.0);
            self.z_next.resize(nz, 0.0);
            self.z_event.resize(nz, 0.0);
            self.column.resize(nz, 0.0);
        }
        let mut budget = WorkBudget::new(nz);
        let mut stalled_stops = 0u64;
        while self.t < t_end {
            if self.composites
                && !O::ACTIVE
                && self.sensitivity.is_none()
                && sys.guard_count() == 0
                && sys.stops_independent_of_state()
                && sys.forcing_carries_over()
            {
                let walked = self.advance_sequence::<S, METERED>(sys, t_end, &mut budget, meter)?;
                if walked {
                    continue;
                }
            }
            if self.composites
                && !O::ACTIVE
                && self.sensitivity.is_none()
                && self.t >= self.segment_wise_until
                && sys.guard_count() > 0
                && sys.stops_assume_contact()
                && sys.forcing_carries_over()
            {
                let decided =
                    self.advance_guarded_sequence::<S, METERED>(sys, t_end, &mut budget, meter)?;
                if decided {
                    continue;
                }
            }
            let stop = sys.next_stop();
            let target = stop.min(t_end);
            let tau = target - self.t;
            if !(tau > 0.0) {
                // The stop coincides with the current time (a segment of zero length in
                // floating point): just switch.
                if stop <= self.t {
                    stalled_stops += 1;
                    if stalled_stops > MAX_STALLED_STOPS {
                        return Err(SolveError::StopNotAhead { t: self.t, stop });
                    }
                    sys.on_stop(self.t, &mut self.y);
                    self.stats.stops += 1;
                    continue;
                }
                return Err(SolveError::StepSizeTooSmall { t: self.t, h: tau });
            }
            stalled_stops = 0;
            if METERED {
                self.check_work_limit(self.t, meter)?;
            }
            budget.charge(self.t)?;
            let carries = self.sensitivity.is_none() && sys.forcing_carries_over();
            match self
                .carried
                .filter(|&count| carries && count < RELIFT_EVERY)
            {
                // The forcing states of the last segment's end, with the (possibly switched
                // or snapped) y.
                Some(count) => {
                    self.z[..n].copy_from_slice(&self.y);
                    self.carried = Some(count + 1);
                }
                _ => {
                    sys.lift(self.t, &self.y, &mut self.z);
                    self.carried = Some(0);
                }
            }
            let position = self.modes.get_position(sys);
            self.stats.frame_modes += std::mem::take(&mut self.modes.frame_builds);
            let guards = sys.guard_count();
            if guards > 0 {
                // A mode is promoted to the full path at its first meeting while the promoted
                // modes' data stays near the core ([`ModeCache::PROMOTED_BUDGET`]); beyond that
                // its segments go by their series (`docs/scaling.md`). Sensitivities need the
                // full path's transition matrices.
                let mode = &self.modes.modes[position];
                let series_ok = self.sensitivity.is_none() && series_segment::applies(mode);
                if !mode.promoted()
                    && (!series_ok
                        || (self.modes.promoted_bytes < ModeCache::PROMOTED_BUDGET
                            && self.modes.fits(mode.full_bytes_estimate())))
                {
                    self.modes.promoted_bytes += mode.full_bytes_estimate();
                    self.modes.promote(position);
                }
            }
            let mode = &mut self.modes.modes[position];
            // The bins this segment builds ([`SolverStats::transitions`]), counted where it
            // last uses its mode: under a limit, where they trigger its full check.
            let bins_before = if METERED { mode.bin_builds() } else { 0 };
            self.stats.steps += 1;

            if guards > 0 {
                let by_series = !mode.promoted();
                let mut event_state_ready = false;
                // A recurring segment is decided by an earlier one of its mode; otherwise
                // guards the model proves positive for the whole mode need no root function
                // and the others get the full search, which may keep the segment as a
                // reference.
                let decided = if self.recurrences && mode.promoted() {
                    let tol = root_tolerance(self.t, tau);
                    mode.decide_recurring(&self.z, tau, tol, &mut self.stats)
                } else {
                    None
                };
                let found = match decided {
                    Some(decision) => {
                        self.stats.recurring_segments += 1;
                        match decision {
                            Decision::Free => {
                                mode.apply(tau, &self.z, &mut self.z_next);
                                None
                            }
                            Decision::Crossing { tau, index } => Some(Crossing { tau, index }),
                        }
                    }
                    None => {
                        let mut excluded = 0u64;
                        for i in 0..guards.min(64) {
                            if sys.guard_excluded(i, &self.z) {
                                excluded |= 1 << i;
                            }
                        }
                        if guards <= 64 && excluded.count_ones() as usize == guards {
                            self.stats.guard_exclusions += 1;
                            mode.apply(tau, &self.z, &mut self.z_next);
                            None
                        } else if by_series {
                            let samples = series_segment::work_in_samples(mode, tau);
                            check_samples(samples, meter.samples_left, self.t, tau, mode)?;
                            meter.samples_left -= samples;
                            self.stats.series_segments += 1;
                            if METERED {
                                force_check(&mut self.work_limit);
                            }
                            let found = series_segment::first_crossing_by_series(
                                mode,
                                &mut self.series,
                                &mut self.stats,
                                self.t,
                                &self.z,
                                &mut self.z_next,
                                tau,
                                excluded,
                            );
                            if found.is_some() {
                                // `z_next` holds the event state.
                                std::mem::swap(&mut self.z_event, &mut self.z_next);
                                event_state_ready = true;
                            }
                            found
                        } else {
                            let samples = (tau / mode.sample_step).ceil();
                            check_samples(samples, meter.samples_left, self.t, tau, mode)?;
                            if METERED {
                                force_check(&mut self.work_limit);
                            }
                            let found = first_crossing(
                                mode,
                                &mut self.crossing,
                                &mut self.stats,
                                self.t,
                                &self.z,
                                &mut self.z_next,
                                tau,
                                excluded,
                            );
                            // The samples taken: up to the crossing, or all of them.
                            meter.samples_left -= found.as_ref().map_or(samples, |c| {
                                (c.tau / mode.sample_step).ceil().min(samples)
                            });
                            if self.recurrences {
                                let outcome = found.as_ref().map(|c| (c.tau, c.index));
                                mode.learn_recurring(&self.z, tau, outcome);
                            }
                            found
                        }
                    }
                };
                if let Some(found) = found {
                    // The event state from the segment's start: in a periodic steady state
                    // τ* recurs, so this is one mat-vec of a cached bin.
                    if !event_state_ready {
                        mode.apply(found.tau, &self.z, &mut self.z_event);
                    }
                    if O::ACTIVE && found.tau > 0.0 {
                        let mut segment = Segment::new(
                            self.t,
                            self.t + found.tau,
                            (&self.z, &self.z_event),
                            mode.balanced(),
                            &mut self.observed,
                            self.prices,
                        );
                        observer.segment(sys, &mut segment);
                        charge_observation::<METERED>(
                            &mut self.observed,
                            &mut self.observer_units,
                            &mut self.work_limit,
                        );
                    }
                    let z_event = &mut self.z_event;
                    if METERED && mode.bin_builds() != bins_before {
                        self.stats.transitions += mode.bin_builds() - bins_before;
                        force_check(&mut self.work_limit);
                    }
                    let t_event = self.t + found.tau;
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
                    if self.sensitivity.is_some() {
                        self.z_next.copy_from_slice(z_event);
                        self.propagate_sensitivity(sys, found.tau);
                        self.t = t_event;
                        self.y.copy_from_slice(&self.z_next[..n]);
                        self.apply_saltation(sys, found.index)?;
                    } else {
                        self.t = t_event;
                        self.y.copy_from_slice(&z_event[..n]);
                        sys.on_event_lifted(self.t, z_event, &mut self.y, found.index);
                        std::mem::swap(&mut self.z, &mut self.z_event);
                    }
                    if !carries {
                        self.carried = None;
                    }
                    self.stats.events += 1;
                    continue;
                }
            } else {
                mode.apply(tau, &self.z, &mut self.z_next);
            }
            if METERED && mode.bin_builds() != bins_before {
                self.stats.transitions += mode.bin_builds() - bins_before;
                force_check(&mut self.work_limit);
            }
            if O::ACTIVE {
                let mut segment = Segment::new(
                    self.t,
                    target,
                    (&self.z, &self.z_next),
                    self.modes.modes[position].balanced(),
                    &mut self.observed,
                    self.prices,
                );
                observer.segment(sys, &mut segment);
                charge_observation::<METERED>(
                    &mut self.observed,
                    &mut self.observer_units,
                    &mut self.work_limit,
                );
            }
            // Checked before it replaces `y`: on error the propagator holds the last finite
            // state at `t`, as the RK stepper does.
            if !self.z_next[..n].iter().all(|v| v.is_finite()) {
                return Err(SolveError::NonFinite { t: self.t });
            }
            self.y.copy_from_slice(&self.z_next[..n]);
            if self.sensitivity.is_some() {
                self.propagate_sensitivity(sys, tau);
            }
            self.t = target;
            if carries {
                std::mem::swap(&mut self.z, &mut self.z_next);
            } else {
                self.carried = None;
            }
            if target == stop {
                sys.on_stop(self.t, &mut self.y);
                self.stats.stops += 1;
                budget.stops += 1;
            }
        }
        Ok(())
    }

    /// Walks the stops of guard-free segments from `t` towards `t_end` (the model's stops do
    /// not depend on the state: [`PiecewiseLti::stops_independent_of_state`]), then
    /// propagates the state through the walked sequence: one mat-vec with its product if it
    /// recurs, else segment by segment ([`composite`]). The walk ends at `t_end`, at a mode
    /// with guards, after [`composite::MAX_LENGTH`] segments, or where the mode returns to
    /// the sequence's first one at a stop (one mesh period of a train at constant speed), so
    /// long advances are cut into recurring sequences too. Returns whether a segment was
    /// walked.
    fn advance_sequence<S: PiecewiseLti, const METERED: bool>(
        &mut self,
        sys: &mut S,
        t_end: f64,
        budget: &mut WorkBudget,
        meter: &AdvanceMeter,
    ) -> Result<bool, SolveError> {
        let n = sys.dim();
        let start = self.t;
        let mut t = start;
        let mut steps = std::mem::take(&mut self.sequence);
        steps.clear();
        let mut stalled_stops = 0u64;
        let mut failure = None;
        while t < t_end && steps.len() < composite::MAX_LENGTH && sys.guard_count() == 0 {
            let stop = sys.next_stop();
            let target = stop.min(t_end);
            let tau = target - t;
            if !(tau > 0.0) {
                if stop <= t {
                    stalled_stops += 1;
                    if stalled_stops > MAX_STALLED_STOPS {
                        failure = Some(SolveError::StopNotAhead { t, stop });
                        break;
                    }
                    // `y` is neither read nor changed by the stop (the trait's promise).
                    sys.on_stop(t, &mut self.y);
                    self.stats.stops += 1;
                    continue;
                }
                failure = Some(SolveError::StepSizeTooSmall { t, h: tau });
                break;
            }
            stalled_stops = 0;
            let Some(mode) = self.modes.position(sys) else {
                break;
            };
            if !steps.is_empty() && mode == steps[0].mode {
                // Back at the first mode after a stop: a new sequence starts here.
                break;
            }
            if METERED {
                if let Err(e) = self.check_work_limit(t, meter) {
                    failure = Some(e);
                    break;
                }
            }
            if let Err(e) = budget.charge(t) {
                failure = Some(e);
                break;
            }
            self.stats.steps += 1;
            steps.push(Step {
                mode,
                tau,
                offset: target - start,
            });
            t = target;
            if target == stop {
                sys.on_stop(t, &mut self.y);
                self.stats.stops += 1;
                budget.stops += 1;
            }
        }
        let walked = !steps.is_empty();
        if walked {
            // A fresh lift at the sequence start (the forcing states are continuous).
            sys.lift(start, &self.y, &mut self.z);
            let tol = composite::offset_tolerance(t);
            match self.modes.composites.lookup(&steps, tol) {
                Lookup::Product(product) => {
                    mat_vec::mat_vec(product.as_slice(), &self.z, &mut self.z_next);
                    std::mem::swap(&mut self.z, &mut self.z_next);
                }
                Lookup::Segments { build } => {
                    for step in &steps {
                        let mode = &mut self.modes.modes[step.mode];
                        let bins = mode.bin_builds();
                        mode.apply(step.tau, &self.z, &mut self.z_next);
                        if METERED && mode.bin_builds() != bins {
                            self.stats.transitions += mode.bin_builds() - bins;
                            force_check(&mut self.work_limit);
                        }
                        std::mem::swap(&mut self.z, &mut self.z_next);
                    }
                    // A product is built only where it fits the cache's budget beside
                    // the modes (else the sequence goes segment by segment).
                    let build = build.filter(|_| self.modes.product_fits(self.z.len()));
                    if let Some(slot) = build {
                        let recorded = self.modes.composites.steps(slot).to_vec();
                        let nz = self.z.len();
                        let mut product = DMatrix::identity(nz, nz);
                        for step in &recorded {
                            let mode = &mut self.modes.modes[step.mode];
                            let bins = mode.bin_builds();
                            let phi = mode.transition_matrix(step.tau);
                            if METERED && mode.bin_builds() != bins {
                                self.stats.transitions += mode.bin_builds() - bins;
                                force_check(&mut self.work_limit);
                            }
                            product = phi * product;
                        }
                        self.modes.composites.set_product(slot, product);
                        self.modes.note_peak();
                    }
                }
            }
            if !self.z[..n].iter().all(|v| v.is_finite()) {
                self.sequence = steps;
                return Err(SolveError::NonFinite { t: self.t });
            }
            self.y.copy_from_slice(&self.z[..n]);
            self.t = t;
            self.carried = None;
        }
        self.sequence = steps;
        match failure {
            Some(e) => Err(e),
            None => Ok(walked),
        }
    }

    /// Walks the stops from `t` towards `t_end` ahead of the state, each entering contact
    /// taken as closed ([`PiecewiseLti::on_stop_assuming_contact`]), and propagates the state
    /// through the walked sequence with one mat-vec of its product where its certificate
    /// proves that no guard crosses ([`guarded`]). The walk ends as the guard-free one
    /// ([`ExactPropagator::advance_sequence`]), at a zero-length stop or at a mode not
    /// cached (the segment-wise path builds the modes). An accepted walk that ends with a
    /// stop takes that stop again from the state: its assumed contacts would be proved by the
    /// next mode's guards, which no certificate of the sequence covers. Otherwise (the
    /// sequence seen once, its product over the memory budget, a guard that may cross) the
    /// model's stops, the counters and the budget are taken back and `false` is returned:
    /// the segment-wise path then goes over the walked span, and further on after refused
    /// certificates (doubling, up to 256 spans). Nothing the segment-wise path reads is
    /// changed by a walk taken back.
    fn advance_guarded_sequence<S: PiecewiseLti, const METERED: bool>(
        &mut self,
        sys: &mut S,
        t_end: f64,
        budget: &mut WorkBudget,
        meter: &AdvanceMeter,
    ) -> Result<bool, SolveError> {
        /// Walked spans the segment-wise path goes over after refused certificates, at most.
        const MAX_BACKOFF: u32 = 256;
        let n = sys.dim();
        let nz = self.z.len();
        let start = self.t;
        let mut saved = std::mem::take(&mut self.stop_state);
        sys.save_stops(&mut saved);
        let (stats_before, budget_before) = (self.stats, *budget);
        let mut steps = std::mem::take(&mut self.sequence);
        steps.clear();
        let mut before_last_stop = std::mem::take(&mut self.last_stop_state);
        // Whether the walk ends with a stop: the contacts it assumed there would be proved
        // only by the guards of the mode after it, which is not in the sequence.
        let mut ends_with_stop = false;
        let mut t = start;
        while t < t_end && steps.len() < composite::MAX_LENGTH {
            let stop = sys.next_stop();
            let target = stop.min(t_end);
            let tau = target - t;
            if !(tau > 0.0) {
                break;
            }
            // Only modes met before: a walk taken back builds none (with contact loss the
            // assumed contacts give modes the run never meets).
            let Some(mode) = self.modes.cached_position(sys) else {
                break;
            };
            if !steps.is_empty() && mode == steps[0].mode {
                break;
            }
            if METERED && self.check_work_limit(t, meter).is_err() {
                break;
            }
            if budget.charge(t).is_err() {
                break;
            }
            self.stats.steps += 1;
            steps.push(Step {
                mode,
                tau,
                offset: target - start,
            });
            t = target;
            ends_with_stop = target == stop;
            if ends_with_stop {
                sys.save_stops(&mut before_last_stop);
                sys.on_stop_assuming_contact(t);
                self.stats.stops += 1;
                budget.stops += 1;
            }
        }
        // `None`: taken back without a certificate refused (seen once, nothing walked).
        let mut outcome = None;
        if !steps.is_empty() {
            // The start state, lifted afresh (the forcing states are continuous), in
            // `z_next`: `z` and `carried` stay as the segment-wise path left them.
            sys.lift(start, &self.y, &mut self.z_next);
            let tol = composite::offset_tolerance(t);
            let slot = match self.modes.composites.lookup_guarded(&steps, tol) {
                Ok(slot) => Some(slot),
                Err(Some(slot)) => {
                    let rows: usize = (steps.iter())
                        .map(|step| self.modes.modes[step.mode].guard_rows.len())
                        .sum();
                    let bytes = (nz * nz + rows * nz) * 8;
                    if self.modes.held() + bytes <= self.modes.budget() {
                        self.build_guarded(slot, nz);
                        if METERED {
                            force_check(&mut self.work_limit);
                        }
                        Some(slot)
                    } else {
                        outcome = Some(false);
                        None
                    }
                }
                Err(None) => None,
            };
            if let Some(slot) = slot {
                let (product, data) = self.modes.composites.guarded(slot);
                let start_state = &self.z_next;
                let holds = data
                    .certificate
                    .as_ref()
                    .is_some_and(|c| c.holds(start_state));
                let proved = holds || {
                    let certificate = guarded::certify(
                        &self.modes.modes,
                        steps.iter().map(|step| (step.mode, step.tau)),
                        &data.spreads,
                        start_state,
                        &mut self.certify_work,
                    );
                    let proved = certificate.is_some();
                    if proved {
                        data.certificate = certificate;
                    }
                    proved
                };
                if proved {
                    mat_vec::mat_vec(product.as_slice(), &self.z_next, &mut self.z);
                    self.modes.composites.hits += 1;
                    if !holds {
                        // A certificate is built work, like a product: counted with them.
                        self.modes.composites.builds += 1;
                    }
                    self.modes.note_peak();
                }
                outcome = Some(proved);
            }
        }
        let accepted = outcome == Some(true);
        if accepted {
            if !self.z[..n].iter().all(|v| v.is_finite()) {
                self.sequence = steps;
                self.stop_state = saved;
                self.last_stop_state = before_last_stop;
                return Err(SolveError::NonFinite { t: self.t });
            }
            self.y.copy_from_slice(&self.z[..n]);
            self.t = t;
            self.carried = None;
            self.guarded_backoff = 0;
            if ends_with_stop {
                // The closing stop classifies its entering pairs from the state, as the
                // segment-wise path does (a pair assumed in contact may enter apart: on a
                // mesh that lost contact on every pair, without tip relief, it always does).
                sys.restore_stops(&before_last_stop);
                sys.on_stop(t, &mut self.y);
            }
        } else {
            sys.restore_stops(&saved);
            self.stats = stats_before;
            *budget = budget_before;
            if outcome == Some(false) {
                self.guarded_backoff = (2 * self.guarded_backoff).clamp(1, MAX_BACKOFF);
            }
            // Nothing walked: on after the next segment (the stop at `t` is the
            // segment-wise path's).
            self.segment_wise_until = if steps.is_empty() {
                sys.next_stop().min(t_end)
            } else {
                t + f64::from(self.guarded_backoff) * (t - start)
            };
        }
        self.sequence = steps;
        self.stop_state = saved;
        self.last_stop_state = before_last_stop;
        Ok(accepted)
    }

    /// Builds the product and the spreads ([`guarded`]) of the guarded sequence in entry
    /// `slot` from its recorded steps: the exponentials of the balanced matrices, no bins
    /// (a guarded mode met by its series holds none).
    fn build_guarded(&mut self, slot: usize, nz: usize) {
        let recorded = self.modes.composites.steps(slot).to_vec();
        let mut product = DMatrix::identity(nz, nz);
        let mut spreads = Vec::new();
        for step in &recorded {
            let mode = &self.modes.modes[step.mode];
            if !guarded::spread_rows(
                mode,
                step.tau,
                &product,
                &mut spreads,
                &mut self.certify_work,
            ) {
                // No bound: the certificate will be refused (a row missing).
                spreads.clear();
                spreads.shrink_to_fit();
                break;
            }
            product = mode.balanced().exp(step.tau) * product;
        }
        self.modes.composites.set_guarded(slot, product, spreads);
        self.modes.note_peak();
    }

    /// `S ← Φ_yy S` over the segment starting now: each column of `S`, lifted with zero
    /// forcing entries, goes through the same transition as the state (the forcing rows of
    /// `Φ` do not depend on `y`, so the `y` block is all that matters).
    fn propagate_sensitivity<S: PiecewiseLti>(&mut self, sys: &S, tau: f64) {
        let Some(s) = &mut self.sensitivity else {
            return;
        };
        let n = s.nrows();
        let mode = self.modes.get(sys);
        let bins_before = mode.bin_builds();
        let mut out = std::mem::take(&mut self.z);
        for j in 0..n {
            self.column.fill(0.0);
            self.column[..n].copy_from_slice(s.column(j).as_slice());
            mode.apply(tau, &self.column, &mut out);
            s.column_mut(j).copy_from_slice(&out[..n]);
        }
        self.stats.transitions += mode.bin_builds() - bins_before;
        force_check(&mut self.work_limit);
        self.z = out;
    }

    /// Switches the mode at an event at `self.t` (state `self.y`, lifted event state in
    /// `z_next`) and carries the tracked sensitivity across it with the saltation matrix
    /// `S = I + (f⁺ − f⁻) ∇_y gᵀ / ġ⁻` (Aizerman & Gantmacher 1958; Leine & Nijmeijer 2004,
    /// eq. 3.74) with `ġ⁻ = w·A⁻z` the guard's total rate before the switch (the harmonic
    /// forcing states carry its explicit time dependence). The snap onto the surface only
    /// removes rounding, so the jump map is the identity.
    fn apply_saltation<S: PiecewiseLti>(
        &mut self,
        sys: &mut S,
        index: usize,
    ) -> Result<(), SolveError> {
        let n = self.y.len();
        let nz = self.z_next.len();
        // Before the switch: the guard row, the flow and the guard's rate of the old mode.
        let mut w = vec![0.0; nz];
        sys.guard_row(index, &mut w);
        let mut flow_before = vec![0.0; nz];
        mat_vec::mat_vec(
            self.modes.get(sys).a().as_slice(),
            &self.z_next,
            &mut flow_before,
        );
        let rate: f64 = w.iter().zip(&flow_before).map(|(a, b)| a * b).sum();
        let scale: f64 = w.iter().zip(&flow_before).map(|(a, b)| (a * b).abs()).sum();
        sys.on_event(self.t, &mut self.y, index);
        if !(rate.abs() > 1e-9 * scale) {
            return Err(SolveError::SingularSaltation { t: self.t });
        }
        let mut z_after = vec![0.0; nz];
        sys.lift(self.t, &self.y, &mut z_after);
        let mut flow_after = vec![0.0; nz];
        mat_vec::mat_vec(
            self.modes.get(sys).a().as_slice(),
            &z_after,
            &mut flow_after,
        );
        let mut saltation = DMatrix::<f64>::identity(n, n);
        for i in 0..n {
            let jump = (flow_after[i] - flow_before[i]) / rate;
            for j in 0..n {
                saltation[(i, j)] += jump * w[j];
            }
        }
        if let Some(s) = &mut self.sensitivity {
            *s = &saltation * &*s;
        }
        Ok(())
    }
}
