//! A guard along the analytic solution of one sample interval as its Taylor series, and a
//! bound of its curvature over the interval from per-mode weights.
//!
//! The weights `M_j ≥ max_s |(e^{Aᵀs} r_2)_j|` are sampled at 17 nodes with the chord error
//! on top (close to the true maxima), and the mode's equilibrium directions are removed from
//! `z` first, so the static load and deflection, whose parts of `g''` cancel, do not both
//! enter `Σ_j M_j |z_j|` ([`NullDirection`]). The series is evaluated by four interleaved
//! Horner chains (value and slope in one pass).

use std::cell::OnceCell;

use nalgebra::{DMatrix, DVector};

use super::balanced::metered_exp;
use crate::solve::first_crossing::polynomial_range;

/// Sub-intervals of `[0, h]` at whose nodes the curvature weights are sampled.
const CURVATURE_NODES: usize = 16;

/// A guard row `w` and its time derivatives along the flow, `r_k = (Aᵀ)^k w`
/// (`d^k g/dt^k = r_k · z`), built lazily and kept with the mode (the same `w` recurs in
/// every segment of the mode).
#[derive(Default, Clone)]
pub struct DerivativeRows {
    n: usize,
    /// `r_0, r_1, …`, each of length `n`.
    rows: Vec<f64>,
    /// The curvature weights for one sample step.
    curvature_weights: Option<CurvatureWeights>,
    /// `z` with its equilibrium parts removed ([`DerivativeRows::tightened_curvature_bound`]).
    shifted: Vec<f64>,
}

/// `M_j ≥ |(e^{Aᵀs} r_2)_j|` for `s ∈ [0, h]`, and the directions along which `z` can be
/// shifted without changing the curvature.
#[derive(Clone)]
struct CurvatureWeights {
    h: f64,
    weights: Vec<f64>,
    shifts: Vec<NullDirection>,
}

impl CurvatureWeights {
    /// `Σ_j M_j |z_j|`.
    fn plain(&self, z: &[f64]) -> f64 {
        self.weights.iter().zip(z).map(|(m, x)| m * x.abs()).sum()
    }
}

/// A direction `q` with `A q ≈ 0` (an equilibrium of the mode, e.g. the static deflection
/// under the constant load): `g'' = r_2·e^{As}(z − α q) + α r_2·e^{As} q` and the last term
/// vanishes up to the rounding of `q`, which `weight` bounds. Removing `α q` keeps the large
/// static parts of `z` (deflection and load) from entering `Σ M_j |z_j|` twice.
#[derive(Clone)]
struct NullDirection {
    /// Component of `z` that `α q` cancels (`q[pivot] = 1`, zero at the other pivots).
    pivot: usize,
    q: Vec<f64>,
    /// `≥ |r_2·e^{As} q|` on `[0, h]`.
    weight: f64,
}

/// The mode's equilibrium directions: the right singular vectors of `A`'s (numerically) zero
/// singular values, computed on first use and shared by the mode's guards (one SVD per mode,
/// not per guard: a drivetrain with contact loss meets many modes once each).
#[derive(Default)]
pub struct NullSpace(OnceCell<Vec<Vec<f64>>>);

impl NullSpace {
    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.0
            .get()
            .map_or(0, |v| v.iter().map(|q| q.capacity() * 8).sum())
    }

    /// The directions of `a` (the mode's matrix; the same on every call).
    pub fn vectors(&self, a: &DMatrix<f64>) -> &[Vec<f64>] {
        self.0.get_or_init(|| {
            // (`try_svd` with an iteration limit: a mode with non-finite entries, e.g. an
            // overflowing input, must not hang the propagator, which then reports the state.)
            let svd = a
                .iter()
                .all(|v| v.is_finite())
                .then(|| a.clone().try_svd(false, true, f64::EPSILON, 1000))
                .flatten();
            let Some((v_t, singular_values)) = svd.and_then(|s| Some((s.v_t?, s.singular_values)))
            else {
                return Vec::new();
            };
            let largest = singular_values.iter().fold(0.0f64, |x, &v| x.max(v));
            singular_values
                .iter()
                .enumerate()
                .filter(|&(_, &sigma)| sigma <= 1e-12 * largest)
                .map(|(i, _)| v_t.row(i).iter().copied().collect())
                .collect()
        })
    }
}

impl DerivativeRows {
    /// Heap bytes held (the mode cache's memory budget).
    pub fn heap_bytes(&self) -> usize {
        self.rows.capacity() * 8
            + self.curvature_weights.as_ref().map_or(0, |c| {
                c.weights.capacity() * 8
                    + c.shifts.iter().map(|d| d.q.capacity() * 8).sum::<usize>()
            })
    }

    /// Makes `w` the guard row (the derivative rows are dropped only when it changed).
    pub fn set_row(&mut self, w: &[f64]) {
        if self.n != w.len() || self.rows.len() < w.len() || self.rows[..w.len()] != *w {
            self.n = w.len();
            self.rows.clear();
            self.rows.extend_from_slice(w);
            self.curvature_weights = None;
        }
    }

    /// `Σ_j M_j |z_j|` with `M_j ≥ max_s |(e^{Aᵀs} r_2)_j|`
    /// ([`DerivativeRows::build_curvature_weights`], computed once per mode and guard): a
    /// bound of `|g''(s)| = |r_2 · e^{As} z|` for all `s ∈ [0, h]` from the weights alone, one
    /// dot. [`DerivativeRows::tightened_curvature_bound`] may lower it.
    pub fn plain_curvature_bound(
        &mut self,
        a: &DMatrix<f64>,
        null_space: &NullSpace,
        h: f64,
        z: &[f64],
    ) -> Option<f64> {
        if self.curvature_weights.as_ref().is_none_or(|c| c.h != h) {
            self.curvature_weights = self.build_curvature_weights(a, null_space, h);
        }
        Some(self.curvature_weights.as_ref()?.plain(z))
    }

    /// The smaller of `plain` (the [`DerivativeRows::plain_curvature_bound`] of `z`, whose
    /// weights are built) and the same sum for `z` with its equilibrium parts removed
    /// ([`NullDirection`]): the directions are as much data again per direction, and cold in
    /// a mode met rarely, so the crossing search reads them only when `plain` does not prove
    /// an interval free.
    pub fn tightened_curvature_bound(&mut self, z: &[f64], plain: f64) -> f64 {
        let Some(c) = self.curvature_weights.as_ref() else {
            return plain;
        };
        if c.shifts.is_empty() {
            return plain;
        }
        // One pass over z per direction (vectorises; a fold over the directions per
        // component was a serial chain, the search's hottest loop on trains with contact
        // loss, whose separated gears add equilibrium directions). Same operations in the
        // same order per component, so the same bound.
        let y = &mut self.shifted;
        y.clear();
        y.extend_from_slice(z);
        for d in &c.shifts {
            let along = z[d.pivot];
            for (yj, qj) in y.iter_mut().zip(&d.q) {
                *yj -= along * qj;
            }
        }
        let mut shifted: f64 = c
            .weights
            .iter()
            .zip(y.iter())
            .map(|(m, v)| m * v.abs())
            .sum();
        for d in &c.shifts {
            shifted += z[d.pivot].abs() * d.weight;
        }
        plain.min(shifted)
    }

    /// The curvature weights `M_j ≥ max_{s∈[0,h]} |(e^{Aᵀs} r_2)_j|` ([`Self::sup_weights`];
    /// the term-by-term weights, up to `e^{|λh|} ≈ 4.8` above the maxima, left a steady
    /// separating scene with several polynomial searches per period that a tight bound proves
    /// free) and the mode's equilibrium directions.
    fn build_curvature_weights(
        &mut self,
        a: &DMatrix<f64>,
        null_space: &NullSpace,
        h: f64,
    ) -> Option<CurvatureWeights> {
        let (weights, loose) = self.sup_weights_and_magnitudes(a, h, 2)?;
        let n = self.n;
        let terms = self.rows.len() / n - 2;
        let mut shifts: Vec<NullDirection> = Vec::new();
        // Equilibrium directions, reduced so that each cancels one component of z (the one it
        // weighs most) and none of the others' (Gauss–Jordan on the pivots).
        for v in null_space.vectors(a) {
            let mut q = v.clone();
            for d in &shifts {
                let factor = q[d.pivot];
                for (x, y) in q.iter_mut().zip(&d.q) {
                    *x -= factor * y;
                }
            }
            let (pivot, score) = (0..n)
                .map(|j| (j, weights[j] * q[j].abs()))
                .fold((0, 0.0), |best, c| if c.1 > best.1 { c } else { best });
            if !(score > 0.0) {
                continue;
            }
            let scale = q[pivot];
            q.iter_mut().for_each(|x| *x /= scale);
            for d in &mut shifts {
                let factor = d.q[pivot];
                for (x, y) in d.q.iter_mut().zip(&q) {
                    *x -= factor * y;
                }
            }
            shifts.push(NullDirection {
                pivot,
                q,
                weight: 0.0,
            });
        }
        // |r_2·e^{As} q| ≤ Σ_k |r_{k+2}·q| h^k/k!, each dot with its rounding bound.
        for d in &mut shifts {
            let mut factor = 1.0;
            for k in 0..terms {
                let row = &self.rows[(k + 2) * n..(k + 3) * n];
                let dot: f64 = row.iter().zip(&d.q).map(|(r, x)| r * x).sum();
                let size: f64 = row.iter().zip(&d.q).map(|(r, x)| (r * x).abs()).sum();
                d.weight += (dot.abs() + 4.0 * n as f64 * f64::EPSILON * size) * factor;
                factor *= h / (k + 1) as f64;
            }
            // The truncated tail is below 1e-20 of the term-by-term sums (as for the weights),
            // which bound |r_{k+2}·q| through Σ_j |(r_{k+2})_j| |q_j|: a margin far above it.
            let scale: f64 = loose.iter().zip(&d.q).map(|(l, x)| l * x.abs()).sum();
            d.weight = d.weight * (1.0 + 1e-12) + 1e-16 * scale;
        }
        Some(CurvatureWeights { h, weights, shifts })
    }

    /// `M_j ≥ max_{s∈[0,h]} |f_j(s)|`, `f_j(s) = (e^{Aᵀs} r_first)_j = Σ_k (r_{k+first})_j s^k/k!`
    /// (the guard's `first`-th time derivative along the flow is `f(s)·z`): the largest `|f_j|`
    /// at 17 equidistant nodes plus the chord error `max|f_j''| Δ²/8` between them
    /// (`max|f_j''|` bounded term by term from `r_{first+2}`), or the term-by-term bound
    /// `Σ_k |(r_{k+first})_j| h^k/k!` where that is smaller. The sampled weights are close to
    /// the true maxima; the term-by-term ones exceed them by up to `e^{|λh|} ≈ 4.8` for an
    /// oscillation (`|λh| ≤ π/2`).
    pub fn sup_weights(&mut self, a: &DMatrix<f64>, h: f64, first: usize) -> Option<Vec<f64>> {
        self.sup_weights_and_magnitudes(a, h, first)
            .map(|(weights, _)| weights)
    }

    /// [`Self::sup_weights`] and the term-by-term bounds [`Self::series_magnitudes`] it starts
    /// from.
    fn sup_weights_and_magnitudes(
        &mut self,
        a: &DMatrix<f64>,
        h: f64,
        first: usize,
    ) -> Option<(Vec<f64>, Vec<f64>)> {
        let loose = self.series_magnitudes(a, h, first)?;
        let loose_second = self.series_magnitudes(a, h, first + 2)?;
        let n = self.n;
        let terms = self.rows.len() / n - first;
        let rows = &self.rows[first * n..(first + terms) * n];
        let mut weights = vec![0.0f64; n];
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx") {
            // SAFETY: the CPU has AVX (checked just above).
            unsafe { node_maxima_avx(rows, n, h, &mut weights) };
        } else {
            node_maxima(rows, n, h, &mut weights);
        }
        #[cfg(not(target_arch = "x86_64"))]
        node_maxima(rows, n, h, &mut weights);
        // Between two nodes |f| exceeds the larger node value by at most max|f''| Δ²/8; the
        // node values carry rounding of their terms' size.
        let gap = h / CURVATURE_NODES as f64;
        for ((m, l), l2) in weights.iter_mut().zip(&loose).zip(&loose_second) {
            *m = l.min(*m + l2 * gap * gap / 8.0 + 1e-12 * l);
        }
        Some((weights, loose))
    }

    /// `Σ_k |(r_{k+first})_j| h^k / k!` for each component `j` (an upper bound of
    /// `|(e^{Aᵀs} r_first)_j|` on `[0, h]`, term by term), extending the rows until the terms
    /// fall below `1e-20` of the sum; `None` if they do not settle.
    pub fn series_magnitudes(
        &mut self,
        a: &DMatrix<f64>,
        h: f64,
        first: usize,
    ) -> Option<Vec<f64>> {
        let n = self.n;
        let mut sums = vec![0.0; n];
        let mut factor = 1.0;
        let mut previous_small = false;
        for k in 0..GuardSeries::MAX_TERMS {
            self.extend_to(a, k + first);
            let row = &self.rows[(k + first) * n..(k + first + 1) * n];
            let mut largest_term = 0.0f64;
            for (m, r) in sums.iter_mut().zip(row) {
                let term = r.abs() * factor;
                *m += term;
                largest_term = largest_term.max(term);
            }
            let largest = sums.iter().fold(0.0f64, |x, &m| x.max(m));
            let small = largest_term <= 1e-20 * largest;
            if k >= 8 && small && previous_small {
                // The tail is far below the sum; one ulp-level margin on top.
                for m in &mut sums {
                    *m *= 1.0 + 1e-12;
                }
                return Some(sums);
            }
            previous_small = small;
            factor *= h / (k + 1) as f64;
        }
        None
    }

    pub fn row(&self, k: usize) -> &[f64] {
        &self.rows[k * self.n..(k + 1) * self.n]
    }

    /// `r_k · z`, extending the rows as far as needed.
    #[inline]
    pub fn coefficient(&mut self, a: &DMatrix<f64>, k: usize, z: &[f64]) -> f64 {
        if self.rows.len() < (k + 1) * self.n {
            self.extend_to(a, k);
        }
        dot(self.row(k), z)
    }

    /// Builds the rows up to `r_k`.
    pub fn extend_to(&mut self, a: &DMatrix<f64>, k: usize) {
        let n = self.n;
        while self.rows.len() < (k + 1) * n {
            let last = self.rows.len() - n;
            // (Aᵀ r)_j = Σ_i A_ij r_i: column j of A (column-major) dotted with r.
            for j in 0..n {
                let column = &a.as_slice()[j * n..(j + 1) * n];
                let v = dot_in_lanes(column, &self.rows[last..last + n]);
                self.rows.push(v);
            }
        }
    }
}

/// `g(s) = w·e^{As} z = Σ_k c_k s^k / k!` with `c_k = w·A^k z` (Moler & Van Loan 2003,
/// method 1). Sample intervals are at most a quarter of the fastest period, so `|λ s| ≤ π/2`
/// and the terms fall factorially; root finding then costs a few flops per evaluation
/// instead of a matrix exponential. Where the series does not settle (e.g. heavy damping
/// outside the frequency bound) the coefficients fall back to exact `expm` evaluation.
/// The coefficients live on the stack: building a series does not allocate.
pub struct GuardSeries<'a> {
    /// `d_k = c_k width^k / k!`, so that `g(s) = Σ d_k σ^k` with `σ = s / width` (Horner
    /// without divisions; each `d_k` is bounded by the largest term, so nothing overflows).
    /// Zero beyond `len` (up to a multiple of four for the interleaved Horner chains).
    coefficients: [f64; GuardSeries::STORAGE],
    len: usize,
    width: f64,
    fallback: Option<(&'a [f64], &'a DMatrix<f64>, &'a [f64])>,
}

impl<'a> GuardSeries<'a> {
    const MAX_TERMS: usize = 60;
    const STORAGE: usize = (Self::MAX_TERMS + 1).next_multiple_of(4);

    /// `g(s) = Σ d_k σ^k`, `σ = s / width`.
    fn horner_value(&self, s: f64) -> f64 {
        interleaved_horner(
            &self.coefficients[..self.len.next_multiple_of(4)],
            s / self.width,
        )
    }

    /// `g'(s) = Σ_{k≥1} k d_k σ^{k−1} / width`.
    fn horner_slope(&self, s: f64) -> f64 {
        self.horner_value_and_slope(s).1
    }

    /// `(g(s), g'(s))` in one pass.
    fn horner_value_and_slope(&self, s: f64) -> (f64, f64) {
        let coefficients = &self.coefficients[..self.len.next_multiple_of(4)];
        let (value, slope) = interleaved_horner_with_slope(coefficients, s / self.width);
        (value, slope / self.width)
    }

    /// The series of guard `rows.row(0)` from `z` over `[0, width]`, its coefficients
    /// `c_k = (Aᵀ)^k w · z` as dot products with the mode's cached derivative rows (one dot
    /// of length `n` per term instead of a matrix-vector product).
    pub fn from_rows(
        rows: &'a mut DerivativeRows,
        a: &'a DMatrix<f64>,
        z: &'a [f64],
        width: f64,
    ) -> GuardSeries<'a> {
        // One instantiation per augmented size, so the dot products inline and unroll.
        match z.len() {
            3 => Self::build(rows, a, z, width, dot_fixed::<3>),
            5 => Self::build(rows, a, z, width, dot_fixed::<5>),
            7 => Self::build(rows, a, z, width, dot_fixed::<7>),
            9 => Self::build(rows, a, z, width, dot_fixed::<9>),
            _ => Self::build(rows, a, z, width, |r, z| {
                r.iter().zip(z).map(|(x, y)| x * y).sum()
            }),
        }
    }

    #[inline(always)]
    fn build<D: Fn(&[f64], &[f64]) -> f64>(
        rows: &'a mut DerivativeRows,
        a: &'a DMatrix<f64>,
        z: &'a [f64],
        width: f64,
        dot: D,
    ) -> GuardSeries<'a> {
        let mut series = GuardSeries {
            coefficients: [0.0; Self::STORAGE],
            len: 0,
            width,
            fallback: None,
        };
        let n = z.len();
        // The rows a series of the mode needed before (extended below if this one needs more).
        let mut available = rows.rows.len() / n;
        let mut magnitude = 0.0f64;
        let mut previous_term = f64::INFINITY;
        let mut factor = 1.0;
        let mut settled = false;
        for k in 0..Self::MAX_TERMS {
            if k + 2 > available {
                rows.extend_to(a, k + 1);
                available = k + 2;
            }
            let c = dot(&rows.rows[k * n..(k + 1) * n], z);
            series.coefficients[k] = c * factor;
            series.len = k + 1;
            let term = c.abs() * factor;
            magnitude = magnitude.max(term);
            let small = |t: f64| t <= 1e-20 * magnitude;
            if k >= 8 && small(term) && small(previous_term) {
                let next = dot(&rows.rows[(k + 1) * n..(k + 2) * n], z);
                series.coefficients[k + 1] = next * factor * width / (k + 1) as f64;
                series.len = k + 2;
                settled = true;
                break;
            }
            previous_term = term;
            factor *= width / (k + 1) as f64;
        }
        if !settled {
            let rows: &'a DerivativeRows = rows;
            series.fallback = Some((rows.row(0), a, z));
        }
        series
    }

    /// The series `g(s) = Σ d_k σ^k`, `σ = s / width`, of coefficients `d_k` already in `σ`
    /// units (the guard row applied to the Taylor terms of the state:
    /// [`super::series_segment`]); at most [`GuardSeries::MAX_TERMS`] of them.
    pub fn from_coefficients(d: &[f64], width: f64) -> GuardSeries<'static> {
        let mut coefficients = [0.0; Self::STORAGE];
        coefficients[..d.len()].copy_from_slice(d);
        GuardSeries {
            coefficients,
            len: d.len(),
            width,
            fallback: None,
        }
    }

    /// The interval's width (`σ = s / width`).
    pub fn width(&self) -> f64 {
        self.width
    }

    /// Number of coefficients (each one a guard-row dot product).
    pub fn terms(&self) -> usize {
        self.len
    }

    /// `g` at `σ = s / width`.
    pub fn value_sigma(&self, sigma: f64) -> f64 {
        match self.fallback {
            Some(_) => self.value(sigma * self.width),
            None => interleaved_horner(&self.coefficients[..self.len.next_multiple_of(4)], sigma),
        }
    }

    /// `dg/dσ = width · g'(s)` at `σ`.
    pub fn slope_sigma(&self, sigma: f64) -> f64 {
        self.width * self.slope(sigma * self.width)
    }

    /// An enclosure `[L, U]` of `d²g/dσ²` on `[a, b]` (centred Taylor form of the polynomial;
    /// unbounded for the `expm` fallback, which has no polynomial).
    pub fn curvature_range(&self, a: f64, b: f64) -> (f64, f64) {
        if self.fallback.is_some() || self.len < 3 {
            return if self.fallback.is_some() {
                (f64::NEG_INFINITY, f64::INFINITY)
            } else {
                (0.0, 0.0)
            };
        }
        let mut c = [0.0; Self::MAX_TERMS - 1];
        let n = self.len - 2;
        for (j, cj) in c[..n].iter_mut().enumerate() {
            *cj = self.coefficients[j + 2] * ((j + 2) * (j + 1)) as f64;
        }
        polynomial_range(&mut c[..n], a, b)
    }

    pub fn value(&self, s: f64) -> f64 {
        match self.fallback {
            Some((row, a, z)) => {
                let zs = metered_exp(&(a * s)) * DVector::from_column_slice(z);
                row.iter().zip(zs.iter()).map(|(w, x)| w * x).sum()
            }
            None => self.horner_value(s),
        }
    }

    /// `(g(s), g'(s))` in one pass.
    pub fn value_and_slope(&self, s: f64) -> (f64, f64) {
        match self.fallback {
            Some(_) => (self.value(s), self.slope(s)),
            None => self.horner_value_and_slope(s),
        }
    }

    pub fn slope(&self, s: f64) -> f64 {
        match self.fallback {
            Some((row, a, z)) => {
                let zs = a * (metered_exp(&(a * s)) * DVector::from_column_slice(z));
                row.iter().zip(zs.iter()).map(|(w, x)| w * x).sum()
            }
            None => self.horner_slope(s),
        }
    }
}

/// `Σ c_k x^k` (`c.len()` a multiple of four) as four Horner chains in `x⁴`,
/// `P_0(x⁴) + x P_1(x⁴) + x² (P_2(x⁴) + x P_3(x⁴))` (Estrin's splitting, Knuth TAOCP vol. 2
/// §4.6.4): the same operations as one Horner chain, but a quarter of its dependent latency,
/// which dominates a 25-term series; for `|x| ≤ 1` the rounding bound is of the same order.
#[inline]
fn interleaved_horner(c: &[f64], x: f64) -> f64 {
    let x2 = x * x;
    let x4 = x2 * x2;
    let mut acc = [0.0; 4];
    for chunk in c.chunks_exact(4).rev() {
        for (a, &ck) in acc.iter_mut().zip(chunk) {
            *a = ck + *a * x4;
        }
    }
    (acc[0] + x * acc[1]) + x2 * (acc[2] + x * acc[3])
}

/// `(p(x), p'(x))` for `p = Σ c_k x^k` with the chains of [`interleaved_horner`]:
/// `p = Σ_i x^i Q_i(x⁴)`, so `p' = Σ_i (i x^{i−1} Q_i + 4 x^{i+3} Q_i')`, each `Q_i'` from its
/// own chain alongside `Q_i` (Horner's derivative recurrence).
#[inline]
fn interleaved_horner_with_slope(c: &[f64], x: f64) -> (f64, f64) {
    let x2 = x * x;
    let x4 = x2 * x2;
    let mut q = [0.0; 4];
    let mut dq = [0.0; 4];
    for chunk in c.chunks_exact(4).rev() {
        for ((qi, dqi), &ck) in q.iter_mut().zip(dq.iter_mut()).zip(chunk) {
            *dqi = *qi + *dqi * x4;
            *qi = ck + *qi * x4;
        }
    }
    let value = (q[0] + x * q[1]) + x2 * (q[2] + x * q[3]);
    let inner = (dq[0] + x * dq[1]) + x2 * (dq[2] + x * dq[3]);
    let slope = 4.0 * x2 * x * inner + (q[1] + 2.0 * x * q[2] + 3.0 * x2 * q[3]);
    (value, slope)
}

/// `a · b`; the single pair's augmented sizes `3 + 2H` get a fixed-size, unrolled loop (a
/// series costs one dot per coefficient).
#[inline(always)]
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    match b.len() {
        3 => dot_fixed::<3>(a, b),
        5 => dot_fixed::<5>(a, b),
        7 => dot_fixed::<7>(a, b),
        9 => dot_fixed::<9>(a, b),
        _ => a.iter().zip(b).map(|(x, y)| x * y).sum(),
    }
}

/// `a·b` in four interleaved partial sums: the compiler cannot reorder a floating-point sum,
/// and one running sum is latency-bound (the derivative rows of a new mode of a large train
/// are ~60 of these per component).
pub fn dot_in_lanes(a: &[f64], b: &[f64]) -> f64 {
    let mut lanes = [0.0f64; 4];
    let (a4, b4) = (a.chunks_exact(4), b.chunks_exact(4));
    let tail: f64 = a4
        .remainder()
        .iter()
        .zip(b4.remainder())
        .map(|(x, y)| x * y)
        .sum();
    for (x, y) in a4.zip(b4) {
        for k in 0..4 {
            lanes[k] += x[k] * y[k];
        }
    }
    (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]) + tail
}

#[inline(always)]
fn dot_fixed<const N: usize>(a: &[f64], b: &[f64]) -> f64 {
    let (a, b): (&[f64; N], &[f64; N]) = (
        a[..N].try_into().expect("row of the vector's size"),
        b[..N].try_into().expect("vector of size N"),
    );
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// The nodes `s_i = h i / CURVATURE_NODES` of [`DerivativeRows::sup_weights`].
const NODES: usize = CURVATURE_NODES + 1;

/// `weights_j = max_i |Σ_k (rows_k)_j s_i^k / k!|` over the nodes `s_i` (`rows` holds `n`
/// components per term): Horner in `s` per node and component, the nodes side by side (one
/// division per term and node, element-wise over the nodes: they vectorise).
#[inline(always)]
fn node_maxima(rows: &[f64], n: usize, h: f64, weights: &mut [f64]) {
    let mut s = [0.0f64; NODES];
    for (i, s) in s.iter_mut().enumerate() {
        *s = h * i as f64 / CURVATURE_NODES as f64;
    }
    let mut value = vec![[0.0f64; NODES]; n];
    let mut step = [0.0f64; NODES];
    for (k, row) in rows.chunks_exact(n).enumerate().rev() {
        for (st, &s) in step.iter_mut().zip(&s) {
            *st = s / (k + 1) as f64;
        }
        for (values, &r) in value.iter_mut().zip(row) {
            for (v, &st) in values.iter_mut().zip(&step) {
                *v = r + *v * st;
            }
        }
    }
    for (m, values) in weights.iter_mut().zip(&value) {
        for v in values {
            *m = m.max(v.abs());
        }
    }
}

/// [`node_maxima`] compiled for AVX: the same operations in the same order per node and
/// component (no fused multiply-add), so the weights are bit for bit those of the baseline
/// build.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn node_maxima_avx(rows: &[f64], n: usize, h: f64, weights: &mut [f64]) {
    node_maxima(rows, n, h, weights);
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DVector;

    /// A damped gear mesh in contact with STE and the static load in the augmented form
    /// `z = [x, v, cos, sin, 1]` (the numbers of `fmu/spur_pair`).
    fn loaded_mesh() -> DMatrix<f64> {
        let (k_m, c_m, w, f_m) = (3.5e8, 2.0e3, 1.8e4, 2.6e3);
        #[rustfmt::skip]
        let a = DMatrix::from_row_slice(5, 5, &[
            0.0, 1.0, 0.0, 0.0, 0.0,
            -k_m, -c_m, 350.0, -20.0, f_m,
            0.0, 0.0, 0.0, -w, 0.0,
            0.0, 0.0, w, 0.0, 0.0,
            0.0, 0.0, 0.0, 0.0, 0.0,
        ]);
        a
    }

    #[test]
    fn interleaved_horner_matches_plain_horner() {
        let c: Vec<f64> = (0..28)
            .map(|k| ((k * 7 % 11) as f64 - 5.0) / (k + 1) as f64)
            .collect();
        for x in [0.0, 0.13, 0.5, 0.77, 1.0] {
            let (mut p, mut dp) = (0.0, 0.0);
            for &ck in c.iter().rev() {
                dp = p + dp * x;
                p = ck + p * x;
            }
            let (value, slope) = interleaved_horner_with_slope(&c, x);
            assert!(
                (value - p).abs() <= 1e-14 * (1.0 + p.abs()),
                "{x}: {value} {p}"
            );
            assert!(
                (slope - dp).abs() <= 1e-13 * (1.0 + dp.abs()),
                "{x}: {slope} {dp}"
            );
            assert_eq!(interleaved_horner(&c, x), value);
        }
    }

    /// The curvature bound against `g''` from nalgebra's `expm` (an independent evaluation) on
    /// a fine grid, for states near the static deflection (where the load's and the
    /// deflection's parts of `g''` cancel) and far from it: a bound, and within a small factor
    /// of the true maximum (the term-by-term weights were ~5× above it).
    #[test]
    fn curvature_bound_encloses_and_is_tight() {
        let a = loaded_mesh();
        let h = std::f64::consts::FRAC_PI_2 / (3.5e8f64).sqrt();
        let mut rows = DerivativeRows::default();
        rows.set_row(&[1.0, 0.0, -1e-6, 0.0, 0.0]);
        let x_static = 2.6e3 / 3.5e8;
        for z in [
            [x_static + 2e-6, 0.05, 0.6, 0.8, 1.0],
            [x_static, 0.0, 1.0, 0.0, 1.0],
            [3e-8, 0.17, 0.03, 1.0, 1.0],
            [-4e-5, -1.2, 0.0, -1.0, 1.0],
        ] {
            let plain = rows
                .plain_curvature_bound(&a, &NullSpace::default(), h, &z)
                .expect("settles");
            let bound = rows.tightened_curvature_bound(&z, plain);
            let a2 = &a * &a;
            let w = DVector::from_column_slice(&[1.0, 0.0, -1e-6, 0.0, 0.0]);
            let mut largest = 0.0f64;
            for i in 0..=400 {
                let s = h * i as f64 / 400.0;
                let zs = (&a * s).exp() * DVector::from_column_slice(&z);
                largest = largest.max(w.dot(&(&a2 * zs)).abs());
            }
            assert!(bound >= largest, "{z:?}: {bound:e} < {largest:e}");
            assert!(bound <= 2.5 * largest, "{z:?}: {bound:e} vs {largest:e}");
        }
    }
}
