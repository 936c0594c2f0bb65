//! A guard along the analytic solution of one sample interval as its Taylor series.

use nalgebra::{DMatrix, DVector};

use super::transition::mat_vec;

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

    /// The series of guard row `row` from `z` over `[0, width]`; `scratch` holds `2n`.
    pub fn new(
        row: &'a [f64],
        a: &'a DMatrix<f64>,
        z: &'a [f64],
        width: f64,
        scratch: &mut [f64],
    ) -> GuardSeries<'a> {
        let n = z.len();
        let (v, next) = scratch.split_at_mut(n);
        v.copy_from_slice(z);
        let mut series = GuardSeries {
            coefficients: [0.0; Self::MAX_TERMS + 1],
            len: 0,
            width,
            fallback: None,
        };
        let dot = |v: &[f64]| row.iter().zip(v).map(|(w, x)| w * x).sum::<f64>();
        let mut magnitude = 0.0f64;
        let mut previous_term = f64::INFINITY;
        let mut factor = 1.0;
        for k in 0..Self::MAX_TERMS {
            let c = dot(v);
            series.coefficients[k] = c * factor;
            series.len = k + 1;
            // |c_k| width^k / k! bounds the k-th term over the interval; two small terms in a
            // row, because odd or even terms alone can vanish (e.g. starting at rest).
            let term = c.abs() * factor;
            magnitude = magnitude.max(term);
            let small = |t: f64| t <= 1e-20 * magnitude;
            mat_vec(a.as_slice(), v, next);
            if k >= 8 && small(term) && small(previous_term) {
                // One more coefficient for the slope series.
                series.coefficients[k + 1] = dot(next) * factor * width / (k + 1) as f64;
                series.len = k + 2;
                return series;
            }
            previous_term = term;
            v.copy_from_slice(next);
            factor *= width / (k + 1) as f64;
        }
        series.fallback = Some((row, a, z));
        series
    }

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
