//! Mesh-level functions of the mesh phase: stiffness sources and transmission-error series.
//!
//! Everything here is a function of the **mesh phase** `p` (mesh cycles), never of time: the
//! model turns time into phase with its nominal-speed clock (`docs/model.md`, "Mesh phase").

pub mod eccentricity;
pub mod errors;
pub mod geometry;
pub mod helical;
pub mod series;
pub mod stiffness;

pub use series::PhaseSeries;

/// The fraction `p − ⌊p⌋ ∈ [0, 1]` of a mesh phase: the same value as `crate::mesh::cycle_fraction(p)`
/// (both are one rounding of the exact fraction; only the sign of a zero may differ), without
/// the software `fmod`, which costs as much as the `sin_cos` of a harmonic.
#[inline]
pub fn cycle_fraction(p: f64) -> f64 {
    p - p.floor()
}

/// `10^d` for `d ≤ 15`, each exact in `f64`.
const POWERS_OF_TEN: [f64; 16] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
];

/// The cycle fraction of mesh phase `p` as an output reports it (the `phase` columns, issue 31
/// item 4): rounded to the decimals the phase resolves. `p` carries a rounding of about
/// `4ε·max(|p|, 1)` cycles (the clock's `p₀ + f·(t − t₀)`), so a fraction within that of a
/// whole cycle is the cycle's start, 0 (not 0.9999999999999858), and the digits below the
/// resolution are dropped: the value printed is the shortest decimal of that resolution.
pub fn output_phase(p: f64) -> f64 {
    let resolution = 4.0 * f64::EPSILON * p.abs().max(1.0);
    // Decimals the phase resolves (at most 15, at least 1): the largest `d` with
    // `10^d·resolution ≤ 1`, i.e. `⌊−log₁₀ resolution⌋`, by the table of exact powers rather
    // than a logarithm per output row (this runs on every row of every run).
    let mut digits = 15;
    while digits > 1 && POWERS_OF_TEN[digits] * resolution > 1.0 {
        digits -= 1;
    }
    let scale = POWERS_OF_TEN[digits];
    let fraction = (cycle_fraction(p) * scale).round() / scale;
    if fraction >= 1.0 {
        0.0
    } else {
        fraction
    }
}
pub use stiffness::{MeshStiffness, Piece};

#[cfg(test)]
mod output_phase_tests {
    use super::output_phase;

    /// A phase a rounding below a whole cycle reports the cycle's start; the fraction is
    /// printed to the decimals the phase resolves; a phase a cycle further resolves fewer.
    #[test]
    fn output_phase_is_rounded_to_its_resolution() {
        let p = 57.0 - 1.42e-14;
        assert_eq!(output_phase(p), 0.0);
        assert_eq!(format!("{}", output_phase(0.0285 * 7.0)), "0.1995");
        assert_eq!(
            format!("{}", output_phase(2850.0 * 0.004_000_01)),
            "0.4000285"
        );
        let q = 12.3 + 4e-15;
        assert_eq!(format!("{}", output_phase(q)), "0.3");
        assert_eq!(output_phase(-0.25), 0.75);
        assert!((0..10_000).all(|k| {
            let v = output_phase(k as f64 * 0.0285);
            (0.0..1.0).contains(&v)
        }));
    }
}
