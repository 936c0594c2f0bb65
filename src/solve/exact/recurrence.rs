//! Recurring segments: the first guard crossing of a segment decided from an earlier segment
//! of the same mode that started from a nearby state.
//!
//! A periodic steady state repeats its segments: every mesh period the same modes start from
//! almost the same lifted state `z` (the harmonic forcing states are periodic too). After a
//! full crossing search ([`super::crossing`]) the segment is kept as a *reference*: its start
//! `z_r` and a certificate of its guards over `[0, S]` (`S` the segment's end, or just past
//! its crossing). A later segment of the mode starting from `z` differs from the reference by
//! `e(s) = w·e^{As}(z − z_r)`, and `|e(s)| ≤ Σ_j M_j |z_j − z_{r,j}| = E₀` on `[0, S]` with
//! `M_j ≥ max_s |(e^{Aᵀs} w)_j|` (and `E₁` likewise for the guard's rate, from `Aᵀw`).
//! The reference guard is cut into pieces of `h/16` (`h` the mode's sample step), and each
//! piece before the crossing is proved either *positive* (`g_r ≥ m` there, so `g ≥ m − E₀`)
//! or *rising* (`g_r' ≥ d`, so `g' ≥ d − E₁`; the guard starts on the surface after an event).
//! The crossing lies in a run of *falling* pieces (`g_r' ≤ −d`) that ends below zero: for the
//! new state the guard still falls there and still ends below zero, so it has exactly one
//! crossing in the run, and it is the first. It is located on the cubic Taylor polynomial of
//! the guard about the reference crossing, four dots with rows kept with the reference, and
//! bracketed to the root-finding tolerance with a rigorous remainder bound.
//!
//! So a recurring segment costs a few weighted sums and dots instead of the sampled search:
//! where the bounds do not hold (a transient, another segment of the same mode, a grazing
//! orbit) the full search runs, as it would without references. The decisions are rigorous
//! either way; only the last bits of an event time can depend on which path found it, so
//! state capture and restore drop the references ([`super::ExactPropagator::forget_recurrences`])
//! and a run continues from a state as a function of that state alone.

use nalgebra::DMatrix;

use super::balanced::BalancedMatrix;
use super::enclosure::{taylor_lower_bound, Point};
use super::guard_series::{dot, DerivativeRows, GuardSeries, NullSpace};
use crate::solve::SolverStats;

/// Pieces per sample step of the reference guard's certificate.
const PIECES_PER_STEP: usize = 16;
/// References kept per mode (segments of one mode per period: its stiffness pieces, the
/// flights before and after a stop); replaced round-robin.
const CAPACITY: usize = 4;
/// Full searches skipped at most between two reference builds of one mode while the
/// references it builds are not used: a build costs tens of full searches, so a run whose
/// segments do not recur (output points at phases that never repeat, a chaotic rattle) pays
/// a few percent at most.
const MAX_BACKOFF: u32 = 4096;
/// Decisions after which a reference has paid for its build (a build samples the guards and
/// their weights over the whole segment, some tens of full searches of a steady run; with
/// dense output points a search is far cheaper, and a reference met again only for a few
/// periods by a nearly commensurate grid has not paid).
const PAYBACK_HITS: u64 = 64;
/// Full searches of a mode before its first reference is built: a build costs tens of full
/// searches, so only runs with many segments of the mode can pay for it (a 28-period run with
/// dense output, as in the work-precision benchmark, builds none).
const WARM_UP: u64 = 128;
/// Sample steps a reference may span.
const MAX_STEPS: usize = 64;
/// Relative rounding margin of the reference guard's node values and rates (of their scale
/// `Σ M_j |z_j|`): the series' rounding is a few ulps of its largest term.
const NODE_NOISE: f64 = 1e-11;

/// What a reference decides for a segment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Decision {
    /// No guard crosses in `(0, τ]`.
    Free,
    /// Guard `index` crosses first, just before `tau` (`g(tau) < 0`, within the tolerance).
    Crossing { tau: f64, index: usize },
}

/// What a reference is built from besides the guard rows: the mode's matrix, its balanced
/// form (for exponentials) and its guard sample step.
#[derive(Clone, Copy)]
pub struct ModeOperators<'a> {
    pub a: &'a DMatrix<f64>,
    pub balanced: &'a BalancedMatrix,
    pub null_space: &'a NullSpace,
    pub sample_step: f64,
}

/// A segment after its full crossing search: start `z`, duration `tau`, and the crossing
/// found (`τ*`, guard), if any.
#[derive(Clone, Copy)]
pub struct SearchedSegment<'a> {
    pub z: &'a [f64],
    pub tau: f64,
    pub outcome: Option<(f64, usize)>,
}

/// The references of one mode.
#[derive(Default)]
pub struct Recurrences {
    references: Vec<Reference>,
    /// The reference that decided last (tried first).
    last_hit: usize,
    /// The reference built last, judged at the next build: it paid for itself
    /// ([`PAYBACK_HITS`]) or not.
    last_built: Option<usize>,
    /// Decisions and builds so far: the clock of [`Reference::last_used`].
    uses: u64,
    /// Full searches of the mode so far (up to [`WARM_UP`]).
    searches: u64,
    /// Full searches still to skip before the next build, and the current backoff (doubled
    /// after a build whose reference has not paid for itself, reset after one that has).
    wait: u32,
    backoff: u32,
    /// `|z − z_r|` and `|z|` per component.
    distance: Vec<f64>,
    magnitude: Vec<f64>,
}

struct Reference {
    /// When the reference was built or last decided a segment (the least recently used one
    /// is replaced), and how many it decided.
    last_used: u64,
    hits: u64,
    z: Vec<f64>,
    /// The end of the certified range `[0, S]`.
    horizon: f64,
    /// Per guard index.
    guards: Vec<GuardCertificate>,
}

struct GuardCertificate {
    /// `M_j ≥ max_{s∈[0,S]} |(e^{Aᵀs} w)_j|` and the same for `Aᵀw`.
    value_weights: Vec<f64>,
    rate_weights: Vec<f64>,
    /// Least lower bound of `g_r` over the pieces proved positive (`∞` if none).
    value_margin: f64,
    /// Least lower bound of `g_r'` over the pieces proved rising (`∞` if none).
    rise_margin: f64,
    /// The crossing of the guard that crossed first in the reference.
    crossing: Option<CrossingCertificate>,
}

struct CrossingCertificate {
    /// The run of falling pieces `[start, S]` that holds the crossing.
    start: f64,
    /// Least `−g_r'` over the run.
    fall_margin: f64,
    /// Upper bound of `g_r(S)` (`< 0`).
    end_value: f64,
    /// The reference crossing `s_r`.
    at: f64,
    /// `u_k = (Aᵀ)^k e^{Aᵀ s_r} w` for `k = 0..4`: `g(s_r + δ) = Σ_k (u_k·z) δ^k/k! + R`.
    taylor_rows: Vec<f64>,
    /// `W_j ≥ |(e^{Aᵀ(s_r+δ)} (Aᵀ)^4 w)_j| / 24` for `s_r + δ` in the run:
    /// `|R| ≤ W·|z| δ⁴`.
    remainder_weights: Vec<f64>,
    /// `V_j = Σ_k |(u_k)_j| D^k/k!` (`D` the reach of `δ`): the rounding of the cubic's
    /// coefficient dots is below `4(n + 4)ε V·|z|` wherever it is evaluated.
    rounding_weights: Vec<f64>,
}

impl Recurrences {
    /// Heap bytes held by the references (the mode cache's memory budget).
    pub fn heap_bytes(&self) -> usize {
        let f64s = |v: &Vec<f64>| v.capacity() * 8;
        let references: usize = self
            .references
            .iter()
            .map(|r| {
                f64s(&r.z)
                    + r.guards
                        .iter()
                        .map(|g| {
                            std::mem::size_of::<GuardCertificate>()
                                + f64s(&g.value_weights)
                                + f64s(&g.rate_weights)
                                + g.crossing.as_ref().map_or(0, |c| {
                                    f64s(&c.taylor_rows)
                                        + f64s(&c.remainder_weights)
                                        + f64s(&c.rounding_weights)
                                })
                        })
                        .sum::<usize>()
            })
            .sum();
        references + f64s(&self.distance) + f64s(&self.magnitude)
    }

    /// The decision of a reference for the segment of duration `tau` from `z`, if one holds.
    /// `rows` are the mode's guard rows (`r_0 = w`, `r_1 = Aᵀw`); `tol` is the root-finding
    /// tolerance of the full search. Inlined into its one caller
    /// ([`super::transition::ModeTransitions::decide_recurring`]).
    #[inline(always)]
    pub fn decide(
        &mut self,
        rows: &[DerivativeRows],
        z: &[f64],
        tau: f64,
        tol: f64,
        stats: &mut SolverStats,
    ) -> Option<Decision> {
        let count = self.references.len();
        for attempt in 0..count {
            let k = (self.last_hit + attempt) % count;
            let decision = self.references[k].decide(
                rows,
                z,
                tau,
                tol,
                &mut self.distance,
                &mut self.magnitude,
                stats,
            );
            if decision.is_some() {
                self.uses += 1;
                let reference = &mut self.references[k];
                reference.last_used = self.uses;
                reference.hits += 1;
                self.last_hit = k;
                return decision;
            }
        }
        None
    }

    /// After a full search of `segment`: keeps it as a reference, unless the backoff says to
    /// wait.
    pub fn learn(
        &mut self,
        mode: ModeOperators,
        rows: &mut [DerivativeRows],
        segment: SearchedSegment,
    ) {
        if self.searches < WARM_UP {
            self.searches += 1;
            return;
        }
        if self.wait > 0 {
            self.wait -= 1;
            return;
        }
        let used = self.last_built.is_some_and(|k| {
            self.references
                .get(k)
                .is_some_and(|r| r.hits >= PAYBACK_HITS)
        });
        self.backoff = if used {
            0
        } else {
            (2 * self.backoff).clamp(1, MAX_BACKOFF)
        };
        self.wait = self.backoff;
        self.last_built = None;
        let Some(mut reference) = Reference::build(mode, rows, segment) else {
            return;
        };
        self.uses += 1;
        reference.last_used = self.uses;
        let slot = if self.references.len() < CAPACITY {
            self.references.push(reference);
            self.references.len() - 1
        } else {
            let (slot, _) = self
                .references
                .iter()
                .enumerate()
                .min_by_key(|(_, r)| r.last_used)
                .expect("a full set");
            self.references[slot] = reference;
            slot
        };
        self.last_hit = slot;
        self.last_built = Some(slot);
    }
}

/// `s` as a slice of the constant length `N` (`N = 0`: as it is), so that the loops over it in
/// a function instantiated for the single pair's augmented sizes unroll.
#[inline(always)]
fn sized<const N: usize>(s: &[f64]) -> &[f64] {
    if N == 0 {
        s
    } else {
        &s[..N]
    }
}

#[inline(always)]
fn sized_mut<const N: usize>(s: &mut [f64]) -> &mut [f64] {
    if N == 0 {
        s
    } else {
        &mut s[..N]
    }
}

impl Reference {
    /// Inlined into its one caller ([`Recurrences::decide`]): a call per segment and
    /// reference costs as much as the decision of a recurring one.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn decide(
        &self,
        rows: &[DerivativeRows],
        z: &[f64],
        tau: f64,
        tol: f64,
        distance: &mut Vec<f64>,
        magnitude: &mut Vec<f64>,
        stats: &mut SolverStats,
    ) -> Option<Decision> {
        let n = z.len();
        if self.guards.len() != rows.len() || self.z.len() != n {
            return None;
        }
        distance.resize(n, 0.0);
        magnitude.resize(n, 0.0);
        let (d, m) = (distance.as_mut_slice(), magnitude.as_mut_slice());
        match n {
            5 => self.decide_sized::<5>(rows, z, tau, tol, d, m, stats),
            7 => self.decide_sized::<7>(rows, z, tau, tol, d, m, stats),
            _ => self.decide_sized::<0>(rows, z, tau, tol, d, m, stats),
        }
    }

    /// [`Reference::decide`] for vectors of length `N` (`0`: any).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn decide_sized<const N: usize>(
        &self,
        rows: &[DerivativeRows],
        z: &[f64],
        tau: f64,
        tol: f64,
        distance: &mut [f64],
        magnitude: &mut [f64],
        stats: &mut SolverStats,
    ) -> Option<Decision> {
        let z = sized::<N>(z);
        let (distance, magnitude) = (sized_mut::<N>(distance), sized_mut::<N>(magnitude));
        // |fl(z − z_r) − (z − z_r)| ≤ ε |z − z_r|: one more ulp-level factor on the bounds.
        for ((d, a), b) in distance.iter_mut().zip(z).zip(sized::<N>(&self.z)) {
            *d = (a - b).abs();
        }
        let mut magnitude_ready = false;
        let mut first: Option<(f64, usize)> = None;
        for (i, c) in self.guards.iter().enumerate() {
            let spread = 1.0 + 1e-12;
            let e0 = dot(sized::<N>(&c.value_weights), distance) * spread;
            let e1 = dot(sized::<N>(&c.rate_weights), distance) * spread;
            if !(e0 < c.value_margin && e1 < c.rise_margin) {
                return None;
            }
            let Some(crossing) = &c.crossing else {
                continue;
            };
            if !(e1 < crossing.fall_margin && crossing.end_value + e0 < 0.0) {
                return None;
            }
            if crossing.start == 0.0 {
                // The run starts the segment: the guard must start above the surface.
                stats.guard_evals += 1;
                if !(dot(rows[i].row(0), z) > 0.0) {
                    return None;
                }
            }
            stats.guard_evals += 4;
            if !magnitude_ready {
                for (m, x) in magnitude.iter_mut().zip(z) {
                    *m = x.abs();
                }
                magnitude_ready = true;
            }
            let (before, after) = crossing.locate::<N>(z, magnitude, self.horizon, tol)?;
            if after <= tau {
                first = Some((after, i));
            } else if before < tau {
                // The segment ends within the bracket: let the full search decide.
                return None;
            }
        }
        match first {
            Some((tau, index)) => Some(Decision::Crossing { tau, index }),
            None if tau <= self.horizon => Some(Decision::Free),
            None => None,
        }
    }

    /// The reference for `segment`, or `None` where a piece cannot be certified (a grazing
    /// minimum, a curvature bound too loose).
    fn build(
        mode: ModeOperators,
        rows: &mut [DerivativeRows],
        segment: SearchedSegment,
    ) -> Option<Reference> {
        let ModeOperators {
            a,
            balanced,
            null_space,
            sample_step: h,
        } = mode;
        let SearchedSegment { z, tau, outcome } = segment;
        let n = z.len();
        let m = rows.len();
        let (crossing_index, target) = match outcome {
            Some((at, index)) if at > 0.0 => (Some(index), at),
            Some(_) => return None,
            // Recurring stop-to-stop segments differ in their last bits (`t_stop − t`).
            None => (None, tau * (1.0 + 1e-6)),
        };
        if crossing_index.is_some_and(|i| i >= m) {
            return None;
        }
        let mut scans: Vec<Scan> = (0..m).map(|_| Scan::new(n)).collect();
        let piece_width = h / PIECES_PER_STEP as f64;
        let mut horizon = None;
        let mut z_chunk = z.to_vec();
        let abs_start: Vec<f64> = z.iter().map(|v| v.abs()).collect();
        let mut row_chunk = vec![0.0; n];
        for step in 0..MAX_STEPS {
            let start = step as f64 * h;
            // Chunks of one sample step; a reference without crossing ends at its target, one
            // with a crossing at the first piece end past it where the guard is below zero.
            let width = match crossing_index {
                Some(_) => h,
                None => h.min(target - start),
            };
            let phi = (step > 0).then(|| balanced.exp(start));
            if let Some(phi) = &phi {
                let zc = phi * nalgebra::DVector::from_column_slice(z);
                z_chunk.copy_from_slice(zc.as_slice());
            }
            // Per guard: the chunk's weights and its node values and rates.
            let mut nodes: Vec<ChunkNodes> = Vec::with_capacity(m);
            for (i, scan) in scans.iter_mut().enumerate() {
                let w = rows[i].row(0);
                match &phi {
                    Some(phi) => {
                        // (e^{Aᵀs} w)_j = Σ_i Φ_ij w_i.
                        for (j, r) in row_chunk.iter_mut().enumerate() {
                            *r = phi.column(j).iter().zip(w).map(|(p, x)| p * x).sum();
                        }
                    }
                    None => row_chunk.copy_from_slice(w),
                }
                let mut chunk_rows = DerivativeRows::default();
                chunk_rows.set_row(&row_chunk);
                let value_weights = chunk_rows.sup_weights(a, h, 0)?;
                let rate_weights = chunk_rows.sup_weights(a, h, 1)?;
                // Scales of the guard and its rate over the chunk, for the rounding margins
                // (the weights bound each component's part of g and g' from the start z).
                let value_scale = dot(&value_weights, &abs_start);
                let rate_scale = dot(&rate_weights, &abs_start);
                for (s, v) in scan.value_weights.iter_mut().zip(&value_weights) {
                    *s = s.max(*v);
                }
                for (s, v) in scan.rate_weights.iter_mut().zip(&rate_weights) {
                    *s = s.max(*v);
                }
                let plain = rows[i].plain_curvature_bound(a, null_space, h, &z_chunk)?;
                let curvature = rows[i].tightened_curvature_bound(&z_chunk, plain);
                let series = GuardSeries::from_rows(&mut rows[i], a, &z_chunk, width);
                let values: Vec<(f64, f64)> = (0..=PIECES_PER_STEP)
                    .map(|k| series.value_and_slope(width * k as f64 / PIECES_PER_STEP as f64))
                    .collect();
                nodes.push(ChunkNodes {
                    values,
                    curvature,
                    value_noise: NODE_NOISE * value_scale,
                    rate_noise: NODE_NOISE * rate_scale,
                });
            }
            let width_piece = width / PIECES_PER_STEP as f64;
            debug_assert!(width_piece <= piece_width * (1.0 + 1e-12));
            for k in 0..PIECES_PER_STEP {
                let piece_start = start + k as f64 * width_piece;
                let piece_end = start + (k + 1) as f64 * width_piece;
                for (i, (scan, chunk)) in scans.iter_mut().zip(&nodes).enumerate() {
                    let piece = chunk.piece(k, width_piece);
                    let is_crossing_guard = crossing_index == Some(i);
                    if piece.falls() && piece.end_value < -chunk.value_noise {
                        if !is_crossing_guard || piece_end < target {
                            // Another guard, or a crossing before the one the search found.
                            return None;
                        }
                        scan.close_crossing(piece_start, piece, chunk.value_noise)?;
                        horizon = Some(piece_end);
                    } else {
                        scan.add(piece_start, piece)?;
                    }
                }
                if horizon.is_some() {
                    break;
                }
            }
            if crossing_index.is_none() && start + width >= target {
                horizon = Some(target);
            }
            if horizon.is_some() {
                break;
            }
            if crossing_index.is_some_and(|_| start + h > target + 2.0 * piece_width) {
                return None;
            }
        }
        let horizon = horizon?;
        let mut guards = Vec::with_capacity(m);
        for (i, scan) in scans.into_iter().enumerate() {
            let mut value_margin = scan.value_margin;
            let crossing = match (scan.crossing_run, crossing_index == Some(i)) {
                (Some(run), true) => {
                    let at = target;
                    if !(at >= run.start && at <= horizon) {
                        return None;
                    }
                    Some(CrossingCertificate::new(
                        a, balanced, &rows[i], run, at, horizon,
                    )?)
                }
                (None, false) => {
                    // A falling run that reaches the horizon without crossing must be
                    // positive throughout.
                    if let Some(run) = scan.pending {
                        if !(run.value_margin > 0.0) {
                            return None;
                        }
                        value_margin = value_margin.min(run.value_margin);
                    }
                    None
                }
                _ => return None,
            };
            guards.push(GuardCertificate {
                value_weights: scan.value_weights,
                rate_weights: scan.rate_weights,
                value_margin,
                rise_margin: scan.rise_margin,
                crossing,
            });
        }
        Some(Reference {
            last_used: 0,
            hits: 0,
            z: z.to_vec(),
            horizon,
            guards,
        })
    }
}

/// One guard's node values and rates over one sample step of the reference.
struct ChunkNodes {
    values: Vec<(f64, f64)>,
    /// `C ≥ |g''|` on the step.
    curvature: f64,
    value_noise: f64,
    rate_noise: f64,
}

/// Bounds of the reference guard on one piece.
#[derive(Clone, Copy)]
struct PieceBounds {
    /// Lower bound of `g_r`.
    lower: f64,
    /// Bounds of `g_r'`.
    rate_low: f64,
    rate_high: f64,
    /// `g_r` at the piece's end.
    end_value: f64,
    /// The fastest rate of the mode over a piece, `(π/2)/h` per sample step.
    rate_scale: f64,
}

impl PieceBounds {
    fn falls(&self) -> bool {
        self.rate_high < 0.0
    }
}

impl ChunkNodes {
    fn piece(&self, k: usize, width: f64) -> PieceBounds {
        let ((g_a, d_a), (g_b, d_b)) = (self.values[k], self.values[k + 1]);
        let c = self.curvature;
        // The larger of the two Taylor minorants from the ends (|g''| ≤ C), and where the
        // guard is monotone on the piece, its lower end value.
        let point = |at: f64, g: f64, d: f64| Point {
            at,
            g,
            slope: d * width,
        };
        let mut lower = taylor_lower_bound(
            point(0.0, g_a, d_a),
            point(1.0, g_b, d_b),
            -c * width * width,
        );
        // g' is C-Lipschitz: min g' ≥ (d_a + d_b − C w)/2, max g' ≤ (d_a + d_b + C w)/2.
        let mean = 0.5 * (d_a + d_b);
        let rate_low = mean - 0.5 * c * width - self.rate_noise;
        let rate_high = mean + 0.5 * c * width + self.rate_noise;
        if rate_high < 0.0 {
            lower = lower.max(g_b);
        } else if rate_low > 0.0 {
            lower = lower.max(g_a);
        }
        PieceBounds {
            lower: lower - self.value_noise,
            rate_low,
            rate_high,
            end_value: g_b,
            rate_scale: std::f64::consts::FRAC_PI_2 / (PIECES_PER_STEP as f64 * width),
        }
    }
}

/// A run of falling pieces not yet known to end in the crossing.
#[derive(Clone, Copy)]
struct FallingRun {
    start: f64,
    /// Least `−g_r'` over the run.
    fall_margin: f64,
    /// Least lower bound of `g_r` over the run (must be `> 0` if the run ends otherwise).
    value_margin: f64,
    /// Upper bound of `g_r` at the run's end (set when it closes on the crossing).
    end_value: f64,
}

/// One guard's certificate while the reference is scanned.
struct Scan {
    value_weights: Vec<f64>,
    rate_weights: Vec<f64>,
    value_margin: f64,
    rise_margin: f64,
    pending: Option<FallingRun>,
    crossing_run: Option<FallingRun>,
}

impl Scan {
    fn new(n: usize) -> Scan {
        Scan {
            value_weights: vec![0.0; n],
            rate_weights: vec![0.0; n],
            value_margin: f64::INFINITY,
            rise_margin: f64::INFINITY,
            pending: None,
            crossing_run: None,
        }
    }

    /// A piece before the crossing: positive, rising, or falling (kept pending: a falling run
    /// may end in the crossing, where only its fall matters).
    fn add(&mut self, start: f64, piece: PieceBounds) -> Option<()> {
        if piece.falls() {
            let run = self.pending.get_or_insert(FallingRun {
                start,
                fall_margin: f64::INFINITY,
                value_margin: f64::INFINITY,
                end_value: f64::NAN,
            });
            run.fall_margin = run.fall_margin.min(-piece.rate_high);
            run.value_margin = run.value_margin.min(piece.lower);
            return Some(());
        }
        if let Some(run) = self.pending.take() {
            if !(run.value_margin > 0.0) {
                return None;
            }
            self.value_margin = self.value_margin.min(run.value_margin);
        }
        // Positive or rising, whichever leaves more room for a perturbation (E₁ ≈ ω E₀).
        let positive = piece.lower > 0.0;
        let rising = piece.rate_low > 0.0;
        match (positive, rising) {
            (true, true) if piece.lower * piece.rate_scale >= piece.rate_low => {
                self.value_margin = self.value_margin.min(piece.lower)
            }
            (_, true) => self.rise_margin = self.rise_margin.min(piece.rate_low),
            (true, false) => self.value_margin = self.value_margin.min(piece.lower),
            (false, false) => return None,
        }
        Some(())
    }

    /// The falling piece where the guard ends below zero closes the run of the crossing.
    fn close_crossing(&mut self, start: f64, piece: PieceBounds, noise: f64) -> Option<()> {
        let mut run = self.pending.take().unwrap_or(FallingRun {
            start,
            fall_margin: f64::INFINITY,
            value_margin: f64::INFINITY,
            end_value: f64::NAN,
        });
        run.fall_margin = run.fall_margin.min(-piece.rate_high);
        run.end_value = piece.end_value + noise;
        (run.end_value < 0.0 && run.fall_margin > 0.0).then_some(())?;
        self.crossing_run = Some(run);
        Some(())
    }
}

impl CrossingCertificate {
    fn new(
        a: &DMatrix<f64>,
        balanced: &BalancedMatrix,
        rows: &DerivativeRows,
        run: FallingRun,
        at: f64,
        horizon: f64,
    ) -> Option<CrossingCertificate> {
        let w = rows.row(0);
        let n = w.len();
        let phi = balanced.exp(at);
        let u0: Vec<f64> = (0..n)
            .map(|j| phi.column(j).iter().zip(w).map(|(p, x)| p * x).sum())
            .collect();
        let mut taylor = DerivativeRows::default();
        taylor.set_row(&u0);
        taylor.extend_to(a, 3);
        let taylor_rows: Vec<f64> = (0..4).flat_map(|k| taylor.row(k).to_vec()).collect();
        let reach = (at - run.start).max(horizon - at);
        let remainder_weights = taylor
            .series_magnitudes(a, reach, 4)?
            .into_iter()
            .map(|m| m / 24.0)
            .collect();
        let mut rounding_weights = vec![0.0; n];
        let mut factor = 1.0;
        for k in 0..4 {
            for (v, u) in rounding_weights.iter_mut().zip(taylor.row(k)) {
                *v += u.abs() * factor;
            }
            factor *= reach / (k + 1) as f64;
        }
        Some(CrossingCertificate {
            start: run.start,
            fall_margin: run.fall_margin,
            end_value: run.end_value,
            at,
            taylor_rows,
            remainder_weights,
            rounding_weights,
        })
    }

    /// A bracket `(before, after)` of the crossing from `z` (`g(before) > 0 > g(after)`,
    /// `after − before ≤ tol`), from Newton on the cubic Taylor polynomial about the reference
    /// crossing with its remainder bounded; `None` if it cannot be proved.
    #[inline(always)]
    fn locate<const N: usize>(
        &self,
        z: &[f64],
        magnitude: &[f64],
        horizon: f64,
        tol: f64,
    ) -> Option<(f64, f64)> {
        let n = z.len();
        let row = |k: usize| sized::<N>(&self.taylor_rows[k * n..(k + 1) * n]);
        let c = [
            dot(row(0), z),
            dot(row(1), z),
            0.5 * dot(row(2), z),
            dot(row(3), z) / 6.0,
        ];
        let noise = 4.0
            * (n + 4) as f64
            * f64::EPSILON
            * dot(sized::<N>(&self.rounding_weights), magnitude);
        let fourth = dot(sized::<N>(&self.remainder_weights), magnitude);
        let p = |d: f64| ((c[3] * d + c[2]) * d + c[1]) * d + c[0];
        let error = |d: f64| noise + fourth * (d * d) * (d * d) + 4.0 * f64::EPSILON * p(d).abs();
        // Newton with the slope at the reference crossing (one division): the crossing moves
        // little between recurrences, where the slope changes by `2 c₂ δ / c₁ ≪ 1`, so this
        // converges about as fast as Newton; the bracket below is checked either way.
        let inverse_slope = 1.0 / c[1];
        if !inverse_slope.is_finite() {
            return None;
        }
        let mut d = 0.0f64;
        let mut converged = false;
        for _ in 0..12 {
            let step = p(d) * inverse_slope;
            d -= step;
            if step.abs() <= 0.125 * tol {
                converged = true;
                break;
            }
        }
        if !converged {
            return None;
        }
        let before = self.at + (d - 0.5 * tol);
        let after = self.at + (d + 0.5 * tol);
        let (d_before, d_after) = (before - self.at, after - self.at);
        let proved = before >= self.start
            && after <= horizon
            && p(d_before) > error(d_before)
            && p(d_after) < -error(d_after);
        proved.then_some((before, after))
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::DMatrix;

    use super::super::crossing::{first_crossing, root_tolerance, Workspace};
    use super::super::guard_series::DerivativeRows;
    use super::super::transition::ModeTransitions;
    use super::Decision;
    use crate::solve::SolverStats;

    /// A damped oscillator near 3 kHz with harmonic (2.85 kHz) and constant forcing, lifted:
    /// `z = [x, x', cos Ωt, sin Ωt, 1]`; guard `x − e cos Ωt` (a deflection with STE).
    fn mode() -> ModeTransitions {
        let (w0, zeta, big_omega) = (1.885e4f64, 0.05, 1.79e4);
        let k = w0 * w0;
        #[rustfmt::skip]
        let a = DMatrix::from_row_slice(5, 5, &[
            0.0, 1.0, 0.0, 0.0, 0.0,
            -k, -2.0 * zeta * w0, 0.3 * k * 1e-6, 0.0, k * 7.4e-6,
            0.0, 0.0, 0.0, -big_omega, 0.0,
            0.0, 0.0, big_omega, 0.0, 0.0,
            0.0, 0.0, 0.0, 0.0, 0.0,
        ]);
        let mut mode = ModeTransitions::new(a, w0.max(big_omega));
        let mut rows = DerivativeRows::default();
        rows.set_row(&[1.0, 0.0, -1e-6, 0.0, 0.0]);
        mode.guard_rows = vec![rows];
        mode
    }

    /// The segment's start time (it sets the root tolerance `4ε(t + τ)`).
    const T: f64 = 0.5;

    /// The full sampled search as a decision (the oracle).
    fn full_search(mode: &mut ModeTransitions, z: &[f64], tau: f64) -> Decision {
        let mut ws = Workspace::default();
        let mut stats = SolverStats::default();
        let mut z_end = [0.0; 5];
        match first_crossing(mode, &mut ws, &mut stats, T, z, &mut z_end, tau, 0) {
            Some(c) => Decision::Crossing {
                tau: c.tau,
                index: c.index,
            },
            None => Decision::Free,
        }
    }

    /// Perturbed starts around two references (a segment that crosses, one that does not):
    /// every decision a reference makes equals the full search's (same guard, times within
    /// the root tolerance); small perturbations are all decided, large ones only where the
    /// bounds prove it (and the crossing cases move the event across the segment's end).
    #[test]
    fn decisions_match_the_full_search_under_perturbations() {
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut uniform = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        // Falling through the surface within the segment, and staying above it.
        let cases = [
            ([7.0e-6, -0.25, 0.6, 0.8, 1.0], 1.5e-4, true),
            ([9.0e-6, 0.02, 0.6, 0.8, 1.0], 1.2e-4, false),
        ];
        for (z_ref, tau_ref, crosses) in cases {
            let mut mode = mode();
            let reference = full_search(&mut mode, &z_ref, tau_ref);
            assert_eq!(matches!(reference, Decision::Crossing { .. }), crosses);
            let outcome = match reference {
                Decision::Crossing { tau, index } => Some((tau, index)),
                Decision::Free => None,
            };
            // The mode's warm-up, then the build.
            for _ in 0..=super::WARM_UP {
                mode.learn_recurring(&z_ref, tau_ref, outcome);
            }
            let (mut decided, mut refused) = (0, 0);
            for exponent in -12..=-1 {
                let scale = 10f64.powi(exponent);
                let mut decided_here = 0;
                for _ in 0..200 {
                    let mut z = z_ref;
                    for v in z.iter_mut().take(4) {
                        *v *= 1.0 + scale * (2.0 * uniform() - 1.0);
                    }
                    let tau = tau_ref * (1.0 + scale * (2.0 * uniform() - 1.0));
                    let tol = root_tolerance(T, tau);
                    let mut stats = SolverStats::default();
                    let Some(decision) = mode.decide_recurring(&z, tau, tol, &mut stats) else {
                        refused += 1;
                        continue;
                    };
                    decided += 1;
                    decided_here += 1;
                    match (decision, full_search(&mut mode, &z, tau)) {
                        (Decision::Free, Decision::Free) => {}
                        (
                            Decision::Crossing { tau: a, index: i },
                            Decision::Crossing { tau: b, index: j },
                        ) => {
                            assert_eq!(i, j);
                            assert!((a - b).abs() <= 2.0 * tol, "τ* {a:e} vs {b:e} at {scale:e}");
                        }
                        (a, b) => panic!("reference says {a:?}, the full search {b:?} ({scale:e})"),
                    }
                }
                if exponent <= -8 {
                    assert_eq!(decided_here, 200, "small perturbations ({scale:e}) decided");
                }
            }
            println!("crosses = {crosses}: {decided} decided, {refused} refused");
            assert!(refused > 0, "large perturbations must be refused");
        }
    }
}
