//! The grid on which the per-mesh results scan a converged orbit's series before refining
//! ([`super::statistics`]): its size for the retained orders, and the series on it by one
//! inverse FFT (rustfft) each, `O(N log N)` for the `N = 8 j_max` points instead of `O(N |J|)`
//! term by term (on the countershaft at H = 20, 11 520 points × 421 orders per series).

use std::f64::consts::TAU;
use std::sync::Arc;

use rustfft::num_complex::Complex64;
use rustfft::{Fft, FftPlanner};

/// Grid points per period of the highest retained order on which the series are scanned
/// before the best point is refined.
pub(super) const SCAN_PER_ORDER: usize = 8;

/// The scan grid `θ_i = i/points` of the retained orders and its inverse FFT.
#[derive(Clone)]
pub(super) struct ScanGrid {
    inverse: Arc<dyn Fft<f64>>,
}

impl std::fmt::Debug for ScanGrid {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "ScanGrid({} points)", self.points())
    }
}

impl ScanGrid {
    /// The grid for the retained `orders`: [`SCAN_PER_ORDER`] points per period of the highest
    /// order, at least 64.
    pub(super) fn new(orders: &[usize]) -> ScanGrid {
        let max_order = *orders.last().expect("order 0 at least");
        let points = (SCAN_PER_ORDER * max_order.max(1)).max(64);
        ScanGrid {
            inverse: FftPlanner::new().plan_fft_inverse(points),
        }
    }

    pub(super) fn points(&self) -> usize {
        self.inverse.len()
    }

    /// The series `c_0 + Σ a_j cos 2πjθ + b_j sin 2πjθ` (`coefficients = [c_0, a_1, b_1, …]`
    /// over `orders`) on the grid, or (`derivative`) its θ-derivative: the real part of the
    /// inverse DFT of the one-sided spectrum `a_j − i b_j` (times `2πij`).
    pub(super) fn series(
        &self,
        orders: &[usize],
        coefficients: &[f64],
        derivative: bool,
    ) -> Vec<f64> {
        let points = self.points();
        let mut spectrum = vec![Complex64::new(0.0, 0.0); points];
        if !derivative {
            spectrum[0] = Complex64::new(coefficients[0], 0.0);
        }
        for (q, &j) in orders.iter().enumerate().skip(1) {
            let hat = Complex64::new(coefficients[2 * q - 1], -coefficients[2 * q]);
            spectrum[j % points] += if derivative {
                hat * Complex64::new(0.0, TAU * j as f64)
            } else {
                hat
            };
        }
        self.inverse.process(&mut spectrum);
        spectrum.iter().map(|z| z.re).collect()
    }
}

/// Uniform instants per HB period at which a signal is sampled for [`uniform_coefficients`]:
/// the power of two above twice the highest retained order (`orders` ascending).
pub(super) fn uniform_points(orders: &[usize]) -> usize {
    (2 * orders.last().expect("order 0 at least") + 1).next_power_of_two()
}

/// The coefficients `[c_0, a_1, b_1, …]` over `orders` of a signal from its `samples` at the
/// uniform instants `θ_i = i/N` of the period (one forward FFT; exact for a trigonometric
/// polynomial of order below `N/2`, higher orders alias).
pub(super) fn uniform_coefficients(orders: &[usize], samples: &[f64]) -> Vec<f64> {
    let points = samples.len();
    let mut spectrum: Vec<Complex64> = samples.iter().map(|&y| Complex64::new(y, 0.0)).collect();
    FftPlanner::new()
        .plan_fft_forward(points)
        .process(&mut spectrum);
    let scale = 1.0 / points as f64;
    let mut c = vec![0.0; 2 * orders.len() - 1];
    c[0] = spectrum[0].re * scale;
    for (q, &j) in orders.iter().enumerate().skip(1) {
        // y = Σ a cos + b sin ⇔ Y_j = N (a − ib)/2.
        let z = spectrum[j % points];
        c[2 * q - 1] = 2.0 * z.re * scale;
        c[2 * q] = -2.0 * z.im * scale;
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against the series summed term by term at every grid point.
    #[test]
    fn series_by_fft_equal_the_sums() {
        let orders = [0, 3, 19, 53, 72];
        let coefficients = [0.4, 1.0, -0.5, 0.25, 2.0, -1.5, 0.75, 0.1, -0.3];
        let grid = ScanGrid::new(&orders);
        assert_eq!(grid.points(), 8 * 72);
        let (x, dx) = (
            grid.series(&orders, &coefficients, false),
            grid.series(&orders, &coefficients, true),
        );
        for i in 0..grid.points() {
            let theta = i as f64 / grid.points() as f64;
            let (mut v, mut d) = (coefficients[0], 0.0);
            for (q, &j) in orders.iter().enumerate().skip(1) {
                let w = TAU * j as f64;
                let (s, c) = (w * theta).sin_cos();
                let (a, b) = (coefficients[2 * q - 1], coefficients[2 * q]);
                v += a * c + b * s;
                d += w * (b * c - a * s);
            }
            assert!((x[i] - v).abs() < 1e-12, "{i}: {} {v}", x[i]);
            assert!((dx[i] - d).abs() < 1e-9, "{i}: {} {d}", dx[i]);
        }
        // And back from uniform samples of the series.
        let points = uniform_points(&orders);
        assert_eq!(points, 256);
        let samples: Vec<f64> = (0..points)
            .map(|i| {
                let theta = i as f64 / points as f64;
                let mut v = coefficients[0];
                for (q, &j) in orders.iter().enumerate().skip(1) {
                    let (s, c) = (TAU * j as f64 * theta).sin_cos();
                    v += coefficients[2 * q - 1] * c + coefficients[2 * q] * s;
                }
                v
            })
            .collect();
        let back = uniform_coefficients(&orders, &samples);
        for (a, b) in back.iter().zip(&coefficients) {
            assert!((a - b).abs() < 1e-13, "{a} {b}");
        }
    }
}
