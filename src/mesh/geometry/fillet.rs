//! Fillet-foundation (gear body) compliance: Sainsot, Velex & Duverger 2004, "Contribution of
//! gear body to tooth deflections — a new bidimensional analytical formula", J. Mech. Des.
//! 126(4) 748–752.
//!
//! Liao et al. 2025 eq. (4) uses a coupled fillet model whose series Φ_s, Θ_s are only given in
//! their ref. [35]; the notes (§1.4 [EXT]) recommend this single-tooth formula as the
//! fallback, with the cross compliances `1/K_f12 = 1/K_f21 = 0`.

use super::gear::Gear;

/// Polynomial coefficients `(A, B, C, D, E, F)` of `X* = A/θ_f² + B h_f² + C h_f/θ_f + D/θ_f +
/// E h_f + F` for `X = L, M, P, Q` (Sainsot et al. 2004, Table 1; notes §1.4).
const COEFFICIENTS: [[f64; 6]; 4] = [
    [-5.574e-5, -1.9986e-3, -2.3015e-4, 4.7702e-3, 0.0271, 6.8045],
    [60.111e-5, 28.100e-3, -83.431e-4, -9.9256e-3, 0.1624, 0.9086],
    [-50.952e-5, 185.50e-3, 0.0538e-4, 53.300e-3, 0.2895, 0.9236],
    [
        -6.2042e-5, 9.0889e-3, -4.0964e-4, 7.8297e-3, -0.1472, 0.6904,
    ],
];

/// The fitted coefficients `[L*, M*, P*, Q*]` of `gear` (`h_f = r_f/r_int`).
pub fn coefficients(gear: &Gear) -> [f64; 4] {
    let tf = gear.theta_f;
    let hf = gear.r_root / gear.r_bore;
    COEFFICIENTS
        .map(|[a, b, c, d, e, f]| a / (tf * tf) + b * hf * hf + c * hf / tf + d / tf + e * hf + f)
}

/// Fillet-foundation compliance `1/K_f` of `gear` for a load at load angle `alpha_f`, m/N:
/// `cos²α_F/(E L) [L*(u_f/S_f)² + M*(u_f/S_f) + P*(1 + Q* tan²α_F)]`, with `S_f = 2 r_f θ_f`
/// and `u_f` the distance from the root circle to where the load line crosses the tooth
/// centre line. The notes' `u_f = r_b[(α_F+θ_b) sin α_F + cos α_F] − h_F tan α_F − r_f`
/// simplifies exactly to `r_b / cos α_F − r_f`, used here.
pub fn compliance(gear: &Gear, coefficients: &[f64; 4], alpha_f: f64) -> f64 {
    let [l, m, p, q] = *coefficients;
    let ca = alpha_f.cos();
    let sf = 2.0 * gear.r_root * gear.theta_f;
    let u = (gear.r_base / ca - gear.r_root) / sf;
    ca * ca / (gear.e * gear.face_width)
        * (l * u * u + m * u + p * (1.0 + q * alpha_f.tan().powi(2)))
}

/// Ranges of `L*, M*, P*, Q*` over Sainsot's fitted data set (as checked by the ROSS
/// implementation); outside them the formula extrapolates.
pub const FITTED_RANGES: [(f64, f64); 4] =
    [(6.82, 6.94), (1.08, 3.29), (2.56, 13.47), (0.141, 0.62)];

/// True when all four coefficients lie in [`FITTED_RANGES`].
pub fn within_fitted_range(coefficients: &[f64; 4]) -> bool {
    coefficients
        .iter()
        .zip(FITTED_RANGES)
        .all(|(&c, (lo, hi))| (lo..=hi).contains(&c))
}

#[cfg(test)]
mod tests {
    #[test]
    fn u_f_simplification_matches_the_notes_formula() {
        // notes §1.4: u_f = r_b[(α_F+θ_b) sin α_F + cos α_F] − h_F tan α_F − r_f,
        // h_F = r_b[(α_F+θ_b) cos α_F − sin α_F]; used here as r_b/cos α_F − r_f.
        let (rb, tb, rf) = (0.0282, 0.093, 0.0262);
        for a in [-0.05f64, 0.0, 0.1, 0.3, 0.5] {
            let hf = rb * ((a + tb) * a.cos() - a.sin());
            let notes = rb * ((a + tb) * a.sin() + a.cos()) - hf * a.tan() - rf;
            let used = rb / a.cos() - rf;
            assert!((notes - used).abs() < 1e-15, "α_F = {a}");
        }
    }
}
