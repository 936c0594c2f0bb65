//! Error norms, the PI step-size controller and the initial step heuristic.
//!
//! All three follow Hairer's codes (HNW I §II.4 "automatic step size control", §II.10 for
//! DOP853's combined estimator), so step counts can be compared with `dopri5.f`/`dop853.f`,
//! scipy and `ode_solvers` when validating.

use super::tableau::{DOP853, DOP853_BHH, DOP853_E5, DP5_E};
use super::Method;

/// Controller constants of one method.
#[derive(Debug, Clone)]
pub(crate) struct Controller {
    /// Exponent on the current error, `1/(q+1) - 0.75 β` (Gustafsson's PI form in Hairer's
    /// parametrisation; `q` = order of the error estimator used for the step size).
    pub expo: f64,
    /// Exponent on the previous accepted error (the "I" memory); 0 gives the classic controller.
    pub beta: f64,
    /// Safety factor.
    pub safe: f64,
    /// Largest shrink factor `h_new ≥ h · fac_min`.
    pub fac_min: f64,
    /// Largest growth factor `h_new ≤ h · fac_max`.
    pub fac_max: f64,
}

impl Controller {
    pub fn of(method: Method) -> Self {
        match method {
            // dopri5.f defaults: β = 0.04 damps the step-size oscillation of DP5 near its
            // stability boundary (HNW II §IV.2); 1/5 ≤ h_new/h ≤ 10.
            Method::Dp5 => Controller {
                expo: 0.2 - 0.04 * 0.75,
                beta: 0.04,
                safe: 0.9,
                fac_min: 0.2,
                fac_max: 10.0,
            },
            // dop853.f defaults: β = 0; 0.333 ≤ h_new/h ≤ 6. The 8th-order error behaves like
            // h^8, so the exponent is 1/8 (the combined estimator scales as h^8).
            Method::Dop853 => Controller {
                expo: 1.0 / 8.0,
                beta: 0.0,
                safe: 0.9,
                fac_min: 0.333,
                fac_max: 6.0,
            },
            // rodas.f defaults: the error of the 3rd-order embedded solution behaves like h^4;
            // 0.2 ≤ h_new/h ≤ 6.
            Method::Rodas4 => Controller {
                expo: 0.25,
                beta: 0.0,
                safe: 0.9,
                fac_min: 0.2,
                fac_max: 6.0,
            },
        }
    }
}

/// Hairer's scaled error of the step `y0 → y1` (≤ 1 means accept).
///
/// Scale `sk_i = atol + rtol · max(|y0_i|, |y1_i|)`; DP5 uses the RMS of the embedded 4th-order
/// difference. DOP853 combines its 5th- and 3rd-order estimators as
/// `|h| · E5² / sqrt(n (E5² + 0.01 E3²))` (HNW I §II.10), which behaves like `h^8` for small `h`
/// yet stays reliable for large `h` where the 5th-order estimate alone underestimates.
pub(crate) fn error_norm(
    method: Method,
    h: f64,
    y0: &[f64],
    y1: &[f64],
    k: &[f64],
    atol: f64,
    rtol: f64,
) -> f64 {
    let n = y0.len();
    let scale = |m: usize| atol + rtol * y0[m].abs().max(y1[m].abs());
    match method {
        Method::Dp5 => {
            let mut sum = 0.0;
            for m in 0..n {
                let mut e = 0.0;
                for (j, &ej) in DP5_E.iter().enumerate() {
                    if ej != 0.0 {
                        e += ej * k[j * n + m];
                    }
                }
                let q = h * e / scale(m);
                sum += q * q;
            }
            (sum / n as f64).sqrt()
        }
        Method::Dop853 => {
            let (mut e5sq, mut e3sq) = (0.0, 0.0);
            for m in 0..n {
                let sk = scale(m);
                let mut e5 = 0.0;
                for (j, &ej) in DOP853_E5.iter().enumerate() {
                    if ej != 0.0 {
                        e5 += ej * k[j * n + m];
                    }
                }
                // Σ (b_j - b̂3_j) k_j, from the weights rather than (y1 - y0)/h, which would
                // cancel catastrophically for small h.
                let mut e3 = 0.0;
                for (j, &bj) in DOP853.b.iter().enumerate() {
                    if bj != 0.0 {
                        e3 += bj * k[j * n + m];
                    }
                }
                for &(j, bj) in DOP853_BHH.iter() {
                    e3 -= bj * k[j * n + m];
                }
                e5sq += (e5 / sk) * (e5 / sk);
                e3sq += (e3 / sk) * (e3 / sk);
            }
            let mut deno = e5sq + 0.01 * e3sq;
            if deno <= 0.0 {
                deno = 1.0;
            }
            h.abs() * e5sq * (1.0 / (n as f64 * deno)).sqrt()
        }
        Method::Rodas4 => {
            // Stage u_6 (row 6) is y1 minus the embedded solution (HW II §IV.7, `rodas.f`).
            let u6 = &k[6 * n..7 * n];
            let sum: f64 = (0..n).map(|m| (u6[m] / scale(m)).powi(2)).sum();
            (sum / n as f64).sqrt()
        }
    }
}

/// Order used by the initial-step heuristic (`iord` in Hairer's `hinit`).
pub(crate) fn hinit_order(method: Method) -> i32 {
    match method {
        Method::Dp5 => 5,
        Method::Dop853 => 8,
        Method::Rodas4 => 4,
    }
}
