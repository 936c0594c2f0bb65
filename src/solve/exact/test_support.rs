//! Shared fixtures of the exact propagator's unit tests.

use nalgebra::DMatrix;

/// A damped mesh with harmonic and constant forcing in the augmented form
/// `z = [x, v, cos, sin, 1]` (static deflection 7.4e-6 m, fastest rate 1.87e4 rad/s).
pub fn forced_oscillator() -> DMatrix<f64> {
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

/// The largest difference of `x` from `y` relative to the largest entry of `y`.
pub fn max_rel_diff(x: &[f64], y: &[f64]) -> f64 {
    let scale = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    x.iter()
        .zip(y)
        .map(|(a, b)| (a - b).abs() / scale)
        .fold(0.0, f64::max)
}
