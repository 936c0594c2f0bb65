//! Transition matrices of linear systems whose matrix is a polynomial in time over a segment,
//! `y' = G(τ) y` with `G(τ) = G_0 + G_1 τ + G_2 τ² + …`, `τ ∈ [0, h]` (Liu & Parker 2007 notes
//! `models-liu-parker-2007.md` §4.4 eq. (4.55): Peano–Baker series of a polynomial system).
//!
//! The power series `Φ(τ) = Σ_n Φ_n τ^n` of the transition matrix follows from `Φ' = GΦ`,
//! `Φ(0) = I`:  `(n + 1) Φ_{n+1} = Σ_k G_k Φ_{n−k}`. It converges for every `h` (Φ is entire),
//! but its terms grow like `(ρh)^n/n!` before they fall, `ρ` the fastest rate of the system, and
//! the cancellation then costs digits; so the segment is cut into substeps with `ρ h_s ≤ 1/2`
//! (the polynomial re-expanded about each substep's start) and the series on each is summed
//! until its terms fall below the rounding of every entry. That makes each segment exact to
//! rounding for a stiffness that varies linearly (or quadratically) in time, such as the
//! piecewise-linear mesh stiffness of He & Singh 2007 eq. (25), where the paper uses Airy
//! (Bessel ±1/3) functions per segment.

use nalgebra::DMatrix;

/// Largest `ρ h` per substep: the series then needs about 20 terms for full precision.
const MAX_RATE_STEP: f64 = 0.5;
/// Hard cap on series terms per substep (never reached with `ρ h ≤ 1/2`).
const MAX_TERMS: usize = 200;

/// `G(τ)` of the polynomial `coefficients` (`G_0, G_1, …`).
pub fn evaluate(coefficients: &[DMatrix<f64>], tau: f64) -> DMatrix<f64> {
    let mut g = coefficients
        .last()
        .expect("at least one coefficient")
        .clone();
    for c in coefficients.iter().rev().skip(1) {
        g = g * tau + c;
    }
    g
}

/// The coefficients of `G(τ_0 + σ)` as a polynomial in `σ` (Taylor shift).
pub fn shift(coefficients: &[DMatrix<f64>], tau0: f64) -> Vec<DMatrix<f64>> {
    let degree = coefficients.len() - 1;
    (0..=degree)
        .map(|j| {
            // Σ_{k ≥ j} C(k, j) τ0^{k−j} G_k.
            let mut sum = coefficients[j].clone();
            let mut binomial_power = 1.0;
            for (k, g) in coefficients.iter().enumerate().skip(j + 1) {
                binomial_power *= k as f64 / (k - j) as f64 * tau0;
                sum += g * binomial_power;
            }
            sum
        })
        .collect()
}

/// An estimate of the fastest rate of `G`: `sqrt(‖G²‖_∞)`, which is `ω` for an oscillator
/// `[[0, 1], [−ω², 0]]` whatever the scaling of its states, and at least `‖G‖_∞` for a
/// first-order decay.
fn rate(g: &DMatrix<f64>) -> f64 {
    let norm = |m: &DMatrix<f64>| {
        m.row_iter()
            .map(|r| r.iter().map(|v| v.abs()).sum::<f64>())
            .fold(0.0, f64::max)
    };
    let squared = norm(&(g * g)).sqrt();
    let diagonal = (0..g.nrows()).map(|i| g[(i, i)].abs()).fold(0.0, f64::max);
    squared.max(diagonal)
}

/// Number of substeps for a segment of length `h`.
pub fn substeps(coefficients: &[DMatrix<f64>], h: f64) -> usize {
    let rho = [0.0, 0.5 * h, h]
        .iter()
        .map(|&tau| rate(&evaluate(coefficients, tau)))
        .fold(0.0, f64::max);
    ((rho * h / MAX_RATE_STEP).ceil() as usize).max(1)
}

/// The series of one substep (`ρ h ≤ 1/2`).
fn series(coefficients: &[DMatrix<f64>], h: f64) -> DMatrix<f64> {
    let n = coefficients[0].nrows();
    let degree = coefficients.len() - 1;
    // Scaled coefficients G_k h^{k+1}, and terms P_m = Φ_m h^m.
    let scaled: Vec<DMatrix<f64>> = coefficients
        .iter()
        .enumerate()
        .map(|(k, g)| g * h.powi(k as i32 + 1))
        .collect();
    let mut terms: Vec<DMatrix<f64>> = vec![DMatrix::identity(n, n)];
    let mut sum = DMatrix::identity(n, n);
    let mut largest = DMatrix::<f64>::identity(n, n);
    let min_terms = 2 * n + degree + 2;
    let mut quiet = 0;
    for m in 0..MAX_TERMS {
        // P_{m+1} = (1/(m+1)) Σ_k (G_k h^{k+1}) P_{m−k}.
        let mut next = DMatrix::zeros(n, n);
        for (k, g) in scaled.iter().enumerate().take(m + 1) {
            next += g * &terms[m - k];
        }
        next /= (m + 1) as f64;
        sum += &next;
        // A term below the rounding of each entry (relative to the largest term of that
        // entry, which sets its rounding floor) changes nothing; `degree + 2` such terms in a
        // row, because some entries have only every other term (cos, sin).
        let mut small = true;
        for (l, t) in largest.iter_mut().zip(next.iter()) {
            *l = l.max(t.abs());
            if t.abs() > 1e-17 * *l {
                small = false;
            }
        }
        terms.push(next);
        quiet = if small { quiet + 1 } else { 0 };
        if m + 1 >= min_terms && quiet >= degree + 2 {
            break;
        }
    }
    sum
}

/// The transition matrix `Φ(h, 0)` of `y' = G(τ) y` with `G` the polynomial `coefficients`
/// (`G_0, G_1, …`, square, of one size), exact to rounding.
pub fn transition(coefficients: &[DMatrix<f64>], h: f64) -> DMatrix<f64> {
    let n = coefficients[0].nrows();
    let parts = substeps(coefficients, h);
    let step = h / parts as f64;
    let mut phi = DMatrix::identity(n, n);
    for j in 0..parts {
        let local = shift(coefficients, j as f64 * step);
        phi = series(&local, step) * phi;
    }
    phi
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_oscillator_is_a_rotation() {
        let w = 2.5e4;
        let g = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -w * w, 0.0]);
        let h = 3.7e-3; // ω h ≈ 92: about 185 substeps.
        let phi = transition(&[g], h);
        let (s, c) = (w * h).sin_cos();
        assert!((phi[(0, 0)] - c).abs() < 1e-12);
        assert!((phi[(0, 1)] - s / w).abs() < 1e-12 / w);
        assert!((phi[(1, 0)] + w * s).abs() < 1e-12 * w);
        assert!((phi[(1, 1)] - c).abs() < 1e-12);
    }

    #[test]
    fn linear_scalar_equation_matches_the_gaussian() {
        // y' = (a + b τ) y ⇒ y(h) = exp(a h + b h²/2).
        let (a, b, h) = (-3.0, 40.0, 0.7);
        let g0 = DMatrix::from_element(1, 1, a);
        let g1 = DMatrix::from_element(1, 1, b);
        let phi = transition(&[g0, g1], h);
        let exact = (a * h + 0.5 * b * h * h).exp();
        assert!(
            ((phi[(0, 0)] - exact) / exact).abs() < 1e-13,
            "{} vs {exact}",
            phi[(0, 0)]
        );
    }

    #[test]
    fn shift_re_expands_the_polynomial() {
        let c: Vec<DMatrix<f64>> = [1.0, -2.0, 0.5]
            .iter()
            .map(|&v| DMatrix::from_element(1, 1, v))
            .collect();
        let shifted = shift(&c, 0.8);
        for sigma in [0.0, 0.3, 1.1] {
            let a = evaluate(&c, 0.8 + sigma)[(0, 0)];
            let b = evaluate(&shifted, sigma)[(0, 0)];
            assert!((a - b).abs() < 1e-14);
        }
    }
}
