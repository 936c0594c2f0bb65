//! The result of a Floquet analysis: the monodromy over one response period and its
//! multipliers (Nayfeh & Mook, *Nonlinear Oscillations*, §5.2), shared by the general
//! monodromy (`floquet`) and the single pair's closed form (`linear_period`).

use nalgebra::{Complex, DMatrix};

/// Monodromy matrix and Floquet multipliers over one mesh period.
#[derive(Debug, Clone)]
pub struct Floquet {
    /// Response period `T` (the mesh period of a single mesh), s.
    pub period: f64,
    /// `M = ∂y(T)/∂y(0)` for the model's state (`[x, x']` of a single pair).
    pub monodromy: DMatrix<f64>,
    /// Eigenvalues of `M`.
    pub multipliers: Vec<Complex<f64>>,
    /// How `M` was computed.
    pub method: String,
}

/// A multiplier as the reports print it: real and imaginary part and modulus.
pub fn multiplier_line(m: &Complex<f64>) -> String {
    format!(
        "  multiplier {:+.12} {:+.12}i  |μ| = {:.12}",
        m.re,
        m.im,
        m.norm()
    )
}

impl Floquet {
    /// Largest `|μ|`; the linear response is asymptotically stable when it is below 1.
    pub fn spectral_radius(&self) -> f64 {
        self.multipliers
            .iter()
            .map(|m| m.norm())
            .fold(0.0, f64::max)
    }
}
