//! A guard along the analytic solution of one sample interval as its Taylor series.

use nalgebra::{DMatrix, DVector};

use crate::solve::first_crossing::polynomial_range;

/// A guard row `w` and its time derivatives along the flow, `r_k = (Aᵀ)^k w`
/// (`d^k g/dt^k = r_k · z`), built lazily and kept with the mode (the same `w` recurs in
/// every segment of the mode).
#[derive(Default, Clone)]
pub struct DerivativeRows {
    n: usize,
    /// `r_0, r_1, …`, each of length `n`.
    rows: Vec<f64>,
    /// `(h, M)`: componentwise bounds `M_j ≥ |(e^{Aᵀs} r_2)_j|` for `s ∈ [0, h]`.
    curvature_weights: Option<(f64, Vec<f64>)>,
}

impl DerivativeRows {
    /// Makes `w` the guard row (the derivative rows are dropped only when it changed).
    pub fn set_row(&mut self, w: &[f64]) {
        if self.n != w.len() || self.rows.len() < w.len() || self.rows[..w.len()] != *w {
            self.n = w.len();
            self.rows.clear();
            self.rows.extend_from_slice(w);
            self.curvature_weights = None;
        }
    }

    /// A bound of `|g''(s)| = |r_2 · e^{As} z|` for all `s ∈ [0, h]`: `Σ_j M_j |z_j|` with
    /// `M_j = Σ_k |(r_{k+2})_j| h^k / k! ≥ max_s |(e^{Aᵀs} r_2)_j|` (the series of
    /// `e^{Aᵀs} r_2` term by term; `|λ h| ≤ π/2`, so it settles within a few tens of terms).
    /// The weights are computed once per mode and guard; each bound then costs one dot.
    pub fn curvature_bound(&mut self, a: &DMatrix<f64>, h: f64, z: &[f64]) -> Option<f64> {
        if self
            .curvature_weights
            .as_ref()
            .is_none_or(|(step, _)| *step != h)
        {
            self.curvature_weights = self.build_curvature_weights(a, h).map(|m| (h, m));
        }
        let (_, weights) = self.curvature_weights.as_ref()?;
        Some(weights.iter().zip(z).map(|(m, x)| m * x.abs()).sum())
    }

    fn build_curvature_weights(&mut self, a: &DMatrix<f64>, h: f64) -> Option<Vec<f64>> {
        let n = self.n;
        let mut weights = vec![0.0; n];
        let mut factor = 1.0;
        let mut previous_small = false;
        for k in 0..GuardSeries::MAX_TERMS {
            self.extend_to(a, k + 2);
            let row = &self.rows[(k + 2) * n..(k + 3) * n];
            let mut largest_term = 0.0f64;
            for (m, r) in weights.iter_mut().zip(row) {
                let term = r.abs() * factor;
                *m += term;
                largest_term = largest_term.max(term);
            }
            let largest = weights.iter().fold(0.0f64, |x, &m| x.max(m));
            let small = largest_term <= 1e-20 * largest;
            if k >= 8 && small && previous_small {
                // The tail is far below the sum; one ulp-level margin on top.
                for m in &mut weights {
                    *m *= 1.0 + 1e-12;
                }
                return Some(weights);
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
    pub fn coefficient(&mut self, a: &DMatrix<f64>, k: usize, z: &[f64]) -> f64 {
        self.extend_to(a, k);
        self.row(k).iter().zip(z).map(|(r, x)| r * x).sum()
    }

    /// Builds the rows up to `r_k`.
    fn extend_to(&mut self, a: &DMatrix<f64>, k: usize) {
        let n = self.n;
        while self.rows.len() < (k + 1) * n {
            let last = self.rows.len() - n;
            // (Aᵀ r)_j = Σ_i A_ij r_i: column j of A (column-major) dotted with r.
            for j in 0..n {
                let column = &a.as_slice()[j * n..(j + 1) * n];
                let v: f64 = (0..n).map(|i| column[i] * self.rows[last + i]).sum();
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
    coefficients: [f64; GuardSeries::MAX_TERMS + 1],
    len: usize,
    width: f64,
    fallback: Option<(&'a [f64], &'a DMatrix<f64>, &'a [f64])>,
}

impl<'a> GuardSeries<'a> {
    const MAX_TERMS: usize = 60;

    /// `g(s) = Σ d_k σ^k` by Horner, `σ = s / width`.
    fn horner_value(&self, s: f64) -> f64 {
        let sigma = s / self.width;
        let mut acc = 0.0;
        for &d in self.coefficients[..self.len].iter().rev() {
            acc = d + acc * sigma;
        }
        acc
    }

    /// `g'(s) = Σ_{k≥1} k d_k σ^{k−1} / width`.
    fn horner_slope(&self, s: f64) -> f64 {
        let sigma = s / self.width;
        let mut acc = 0.0;
        for k in (1..self.len).rev() {
            acc = k as f64 * self.coefficients[k] + acc * sigma;
        }
        acc / self.width
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
        let mut series = GuardSeries {
            coefficients: [0.0; Self::MAX_TERMS + 1],
            len: 0,
            width,
            fallback: None,
        };
        let mut magnitude = 0.0f64;
        let mut previous_term = f64::INFINITY;
        let mut factor = 1.0;
        let mut settled = false;
        for k in 0..Self::MAX_TERMS {
            let c = rows.coefficient(a, k, z);
            series.coefficients[k] = c * factor;
            series.len = k + 1;
            let term = c.abs() * factor;
            magnitude = magnitude.max(term);
            let small = |t: f64| t <= 1e-20 * magnitude;
            if k >= 8 && small(term) && small(previous_term) {
                series.coefficients[k + 1] =
                    rows.coefficient(a, k + 1, z) * factor * width / (k + 1) as f64;
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

    /// Number of coefficients (each one a guard-row dot product).
    pub fn terms(&self) -> usize {
        self.len
    }

    /// `g` at `σ = s / width`.
    pub fn value_sigma(&self, sigma: f64) -> f64 {
        match self.fallback {
            Some(_) => self.value(sigma * self.width),
            None => {
                let mut acc = 0.0;
                for &d in self.coefficients[..self.len].iter().rev() {
                    acc = d + acc * sigma;
                }
                acc
            }
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
                let zs = (a * s).exp() * DVector::from_column_slice(z);
                row.iter().zip(zs.iter()).map(|(w, x)| w * x).sum()
            }
            None => self.horner_value(s),
        }
    }

    pub fn slope(&self, s: f64) -> f64 {
        match self.fallback {
            Some((row, a, z)) => {
                let zs = a * ((a * s).exp() * DVector::from_column_slice(z));
                row.iter().zip(zs.iter()).map(|(w, x)| w * x).sum()
            }
            None => self.horner_slope(s),
        }
    }
}
