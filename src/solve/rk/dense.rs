//! Continuous extensions (dense output) of the last accepted step.
//!
//! RODAS4's is `y0 + θ r1 + θ(1−θ)(r2 + θ r3)` with `r1 = y1 − y0` and `r2, r3` stage
//! combinations (HW II §IV.7, `rodas.f` `CONTRO`), 3rd order.
//!
//! The explicit methods use Hairer's Hermite-like representation (HNW I §II.6, `dopri5.f`/`dop853.f`):
//! `u(θ) = r0 + θ(r1 + (1-θ)(r2 + θ(r3 + (1-θ) P(θ))))` with `r0 = y0`, `r1 = y1 - y0`,
//! `r2 = h f0 - r1`, `r3 = r1 - h f1 - r2`, so `u` matches `y` and `f` at both ends whatever
//! `P` is; `P` carries the higher-order correction. Storing the rows once per step makes every
//! evaluation a short Horner scheme (no right-hand-side calls), which is what event location on
//! the interpolant needs.

use super::rosenbrock;
use super::tableau::{DOP853_D, DOP853_D_STAGES, DP5_D};
use super::Method;

/// Number of coefficient rows per component.
pub(crate) fn rows(method: Method) -> usize {
    match method {
        Method::Dp5 => 5,
        Method::Dop853 => 8,
        Method::Rodas4 => 4,
    }
}

/// Fills `r` (`rows(method) * n` values, row-major) from the step `y0 → y1` of size `h` with
/// stages `k` (`total * n`, row-major; the FSAL stage `f(t0 + h, y1)` and, for DOP853, the three
/// dense-output stages must already be there).
///
/// For RODAS4, `k` holds `f(t0, y0)` and the stages `u_1 … u_6` (rows 1–6).
pub(crate) fn build(method: Method, h: f64, y0: &[f64], y1: &[f64], k: &[f64], r: &mut [f64]) {
    let n = y0.len();
    let fsal = match method {
        Method::Dp5 => 6,
        Method::Dop853 => 12,
        Method::Rodas4 => return build_rosenbrock(y0, y1, k, r),
    };
    let (r0, rest) = r.split_at_mut(n);
    let (r1, rest) = rest.split_at_mut(n);
    let (r2, rest) = rest.split_at_mut(n);
    let (r3, rest) = rest.split_at_mut(n);
    for m in 0..n {
        let dy = y1[m] - y0[m];
        let bspl = h * k[m] - dy;
        r0[m] = y0[m];
        r1[m] = dy;
        r2[m] = bspl;
        r3[m] = dy - h * k[fsal * n + m] - bspl;
    }
    match method {
        Method::Dp5 => {
            let r4 = &mut rest[..n];
            for (m, r4m) in r4.iter_mut().enumerate() {
                let mut s = 0.0;
                for (j, &d) in DP5_D.iter().enumerate() {
                    if d != 0.0 {
                        s += d * k[j * n + m];
                    }
                }
                *r4m = h * s;
            }
        }
        Method::Dop853 => {
            for (row, d) in DOP853_D.iter().enumerate() {
                let rr = &mut rest[row * n..(row + 1) * n];
                for (m, rm) in rr.iter_mut().enumerate() {
                    let mut s = 0.0;
                    for (&j, &dj) in DOP853_D_STAGES.iter().zip(d.iter()) {
                        s += dj * k[j * n + m];
                    }
                    *rm = h * s;
                }
            }
        }
        // Built by `build_rosenbrock` above.
        Method::Rodas4 => {}
    }
}

fn build_rosenbrock(y0: &[f64], y1: &[f64], k: &[f64], r: &mut [f64]) {
    let n = y0.len();
    let (r0, rest) = r.split_at_mut(n);
    let (r1, rest) = rest.split_at_mut(n);
    r0.copy_from_slice(y0);
    for m in 0..n {
        r1[m] = y1[m] - y0[m];
    }
    for (row, d) in rosenbrock::DENSE.iter().enumerate() {
        let rr = &mut rest[row * n..(row + 1) * n];
        for (m, rm) in rr.iter_mut().enumerate() {
            *rm = d
                .iter()
                .enumerate()
                .map(|(j, dj)| dj * k[(j + 1) * n + m])
                .sum();
        }
    }
}

/// Evaluates the interpolant at `θ = (t - t0)/h` into `out`.
pub(crate) fn eval(method: Method, theta: f64, r: &[f64], out: &mut [f64]) {
    let n = out.len();
    let s = theta;
    let s1 = 1.0 - theta;
    match method {
        Method::Dp5 => {
            for (m, o) in out.iter_mut().enumerate() {
                *o = r[m]
                    + s * (r[n + m] + s1 * (r[2 * n + m] + s * (r[3 * n + m] + s1 * r[4 * n + m])));
            }
        }
        Method::Dop853 => {
            for (m, o) in out.iter_mut().enumerate() {
                let conpar =
                    r[4 * n + m] + s * (r[5 * n + m] + s1 * (r[6 * n + m] + s * r[7 * n + m]));
                *o = r[m] + s * (r[n + m] + s1 * (r[2 * n + m] + s * (r[3 * n + m] + s1 * conpar)));
            }
        }
        Method::Rodas4 => {
            for (m, o) in out.iter_mut().enumerate() {
                *o = r[m] + s * (r[n + m] + s1 * (r[2 * n + m] + s * r[3 * n + m]));
            }
        }
    }
}

/// Exponents `(a, b)` of the basis `θ^a (1 − θ)^b` that multiplies each coefficient row in
/// [`eval`] (expanding its nested form).
fn basis(method: Method) -> &'static [(i32, i32)] {
    match method {
        Method::Dp5 => &[(0, 0), (1, 0), (1, 1), (2, 1), (2, 2)],
        Method::Dop853 => &[
            (0, 0),
            (1, 0),
            (1, 1),
            (2, 1),
            (2, 2),
            (3, 2),
            (3, 3),
            (4, 3),
        ],
        Method::Rodas4 => &[(0, 0), (1, 0), (1, 1), (2, 1)],
    }
}

/// Largest degree of the interpolant in `θ` (DOP853: 7).
pub(crate) const MAX_DEGREE: usize = 7;

/// Monomial coefficients `q_0 … q_7` of `w·u(θ)`, the linear functional `w` of the interpolant
/// (`r` as filled by [`build`], `n` components). The interpolant is a polynomial in `θ` (degree
/// 4 for DP5, 7 for DOP853), so an affine guard along it is this polynomial plus its explicit
/// time part.
pub(crate) fn functional_polynomial(
    method: Method,
    r: &[f64],
    w: &[f64],
    q: &mut [f64; MAX_DEGREE + 1],
) {
    let n = w.len();
    q.fill(0.0);
    for (row, &(a, b)) in basis(method).iter().enumerate() {
        let weight: f64 = w
            .iter()
            .zip(&r[row * n..(row + 1) * n])
            .map(|(wm, rm)| wm * rm)
            .sum();
        if weight == 0.0 {
            continue;
        }
        // θ^a (1 − θ)^b = Σ_i C(b, i) (−1)^i θ^{a+i}.
        let mut binomial = 1.0;
        for i in 0..=b {
            let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
            q[(a + i) as usize] += weight * sign * binomial;
            binomial *= (b - i) as f64 / (i + 1) as f64;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn functional_polynomial_matches_the_interpolant() {
        // Arbitrary rows for n = 2; w·u(θ) by `eval` against the monomial form.
        let n = 2;
        let w = [0.7, -1.3];
        for method in Method::ALL {
            let r: Vec<f64> = (0..rows(method) * n)
                .map(|i| ((i * 37 % 11) as f64 - 5.0) * 0.1)
                .collect();
            let mut q = [0.0; MAX_DEGREE + 1];
            functional_polynomial(method, &r, &w, &mut q);
            let mut u = [0.0; 2];
            for k in 0..=10 {
                let theta = k as f64 / 10.0;
                eval(method, theta, &r, &mut u);
                let direct = w[0] * u[0] + w[1] * u[1];
                let monomial = q.iter().rev().fold(0.0, |acc, c| acc * theta + c);
                assert!(
                    (direct - monomial).abs() < 1e-14,
                    "{method}: θ = {theta}: {direct} vs {monomial}"
                );
            }
        }
    }
}
