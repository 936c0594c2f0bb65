//! The matrix exponential of a small matrix on the stack: Padé scaling-and-squaring
//! (Higham 2005, "The scaling and squaring method for the matrix exponential revisited",
//! SIAM J. Matrix Anal. Appl. 26(4), Algorithm 2.3, with the θ_m of its Table 2.3).
//!
//! A short run of the exact propagator meets many fresh segment durations (every output stop
//! and every contact event starts one), each one exponential of the augmented mode matrix
//! (`3 + 2H` states for the single pair). nalgebra's `exp` does the same algorithm on heap
//! matrices with a `powf`-based backward-error estimate per degree; at 5 × 5 that is
//! ~1.2 µs, dominated by allocation and bookkeeping. Here the matrices are fixed-size arrays
//! and the degree follows Higham's `‖A‖₁` thresholds directly (no norm estimates: at these
//! sizes `‖A^k‖₁` would cost as much as the product it saves). The caller balances the matrix
//! first (`balanced.rs`).

/// A column-major `N × N` matrix: `m[j][i]` is row `i` of column `j`.
pub type Square<const N: usize> = [[f64; N]; N];

/// θ_m of Higham (2005) Table 2.3: Padé degree `m` is accurate to unit roundoff for
/// `‖A‖₁ ≤ θ_m`. Degrees 3 and 5 (θ = 1.5e-2, 0.25) are left out: cheaper for short
/// durations, but their error, although below unit roundoff in norm, is not: along a periodic
/// orbit it adds up (the undamped rattle of `tests/stress/energy.rs` drifts 1.1e-8 E0 over
/// 1e5 mesh periods with degree 5, 3.5e-9 E0 without, 7.6e-9 E0 with nalgebra's `exp`).
const THETA: [(usize, f64); 2] = [(7, 9.504178996162932e-1), (9, 2.097847961257068e0)];
const THETA_13: f64 = 5.371920351148152e0;

/// Coefficients `b_0 … b_m` of the degree-`m` diagonal Padé approximant of `e^x`
/// (Higham 2005, eq. 2.2 ff.).
const PADE_7: [f64; 8] = [
    17297280.0, 8648640.0, 1995840.0, 277200.0, 25200.0, 1512.0, 56.0, 1.0,
];
const PADE_9: [f64; 10] = [
    17643225600.0,
    8821612800.0,
    2075673600.0,
    302702400.0,
    30270240.0,
    2162160.0,
    110880.0,
    3960.0,
    90.0,
    1.0,
];
const PADE_13: [f64; 14] = [
    64764752532480000.0,
    32382376266240000.0,
    7771770303897600.0,
    1187353796428800.0,
    129060195264000.0,
    10559470521600.0,
    670442572800.0,
    33522128640.0,
    1323241920.0,
    40840800.0,
    960960.0,
    16380.0,
    182.0,
    1.0,
];

/// `e^A`, or `None` when `A` is not finite or the Padé denominator is singular (it is not
/// for any finite `A` in exact arithmetic; the caller then falls back to nalgebra).
pub fn expm<const N: usize>(a: &Square<N>) -> Option<Square<N>> {
    let norm = one_norm(a);
    if !norm.is_finite() {
        return None;
    }
    for (m, theta) in THETA {
        if norm <= theta {
            let (u, v) = match m {
                7 => pade_low(a, &PADE_7),
                _ => pade_low(a, &PADE_9),
            };
            return solve_pade(&u, &v);
        }
    }
    // ‖A/2^s‖₁ ≤ θ_13, then square s times.
    let s = (norm / THETA_13).log2().ceil().max(0.0) as i32;
    let scale = 0.5f64.powi(s);
    let mut scaled = *a;
    for column in &mut scaled {
        for x in column {
            *x *= scale;
        }
    }
    let (u, v) = pade_13(&scaled);
    let mut e = solve_pade(&u, &v)?;
    for _ in 0..s {
        e = mul(&e, &e);
    }
    Some(e)
}

/// `‖A‖₁`, the largest column sum of magnitudes.
fn one_norm<const N: usize>(a: &Square<N>) -> f64 {
    a.iter()
        .map(|column| column.iter().map(|x| x.abs()).sum::<f64>())
        .fold(0.0, f64::max)
}

/// `A B`.
pub fn mul<const N: usize>(a: &Square<N>, b: &Square<N>) -> Square<N> {
    let mut c = [[0.0; N]; N];
    for (cj, bj) in c.iter_mut().zip(b) {
        for (ak, &bkj) in a.iter().zip(bj) {
            for (cij, &aik) in cj.iter_mut().zip(ak) {
                *cij += aik * bkj;
            }
        }
    }
    c
}

/// `Σ_k c_k M_k + c_I I`.
fn combination<const N: usize, const K: usize>(
    terms: [(f64, &Square<N>); K],
    identity: f64,
) -> Square<N> {
    let mut out = [[0.0; N]; N];
    for (c, m) in terms {
        for (oj, mj) in out.iter_mut().zip(m) {
            for (o, &x) in oj.iter_mut().zip(mj) {
                *o += c * x;
            }
        }
    }
    for (i, column) in out.iter_mut().enumerate() {
        column[i] += identity;
    }
    out
}

/// `U = A Σ_{j odd} b_j A^{j−1}`, `V = Σ_{j even} b_j A^j` for `m` = 7, 9.
fn pade_low<const N: usize, const L: usize>(a: &Square<N>, b: &[f64; L]) -> (Square<N>, Square<N>) {
    let m = L - 1;
    let a2 = mul(a, a);
    let a4 = mul(&a2, &a2);
    let a6 = mul(&a4, &a2);
    let a8 = if m >= 9 { mul(&a6, &a2) } else { [[0.0; N]; N] };
    let coefficient = |j: usize| if j <= m { b[j] } else { 0.0 };
    let odd = combination(
        [
            (coefficient(3), &a2),
            (coefficient(5), &a4),
            (coefficient(7), &a6),
            (coefficient(9), &a8),
        ],
        b[1],
    );
    let v = combination(
        [
            (coefficient(2), &a2),
            (coefficient(4), &a4),
            (coefficient(6), &a6),
            (coefficient(8), &a8),
        ],
        b[0],
    );
    (mul(a, &odd), v)
}

/// Degree 13 with Higham's six products: `U = A[A6(b13 A6 + b11 A4 + b9 A2) + b7 A6 + b5 A4 +
/// b3 A2 + b1 I]`, `V = A6(b12 A6 + b10 A4 + b8 A2) + b6 A6 + b4 A4 + b2 A2 + b0 I`.
fn pade_13<const N: usize>(a: &Square<N>) -> (Square<N>, Square<N>) {
    let b = &PADE_13;
    let a2 = mul(a, a);
    let a4 = mul(&a2, &a2);
    let a6 = mul(&a4, &a2);
    let inner_u = combination([(b[13], &a6), (b[11], &a4), (b[9], &a2)], 0.0);
    let outer_u = combination(
        [
            (1.0, &mul(&a6, &inner_u)),
            (b[7], &a6),
            (b[5], &a4),
            (b[3], &a2),
        ],
        b[1],
    );
    let inner_v = combination([(b[12], &a6), (b[10], &a4), (b[8], &a2)], 0.0);
    let v = combination(
        [
            (1.0, &mul(&a6, &inner_v)),
            (b[6], &a6),
            (b[4], &a4),
            (b[2], &a2),
        ],
        b[0],
    );
    (mul(a, &outer_u), v)
}

/// `r = (V − U)⁻¹ (V + U)` by LU with partial pivoting.
fn solve_pade<const N: usize>(u: &Square<N>, v: &Square<N>) -> Option<Square<N>> {
    let mut lhs = [[0.0; N]; N];
    let mut rhs = [[0.0; N]; N];
    for j in 0..N {
        for i in 0..N {
            lhs[j][i] = v[j][i] - u[j][i];
            rhs[j][i] = v[j][i] + u[j][i];
        }
    }
    // Gaussian elimination on the columns of `lhs`, applied to every column of `rhs`.
    for k in 0..N {
        let pivot = (k..N).max_by(|&p, &q| lhs[k][p].abs().total_cmp(&lhs[k][q].abs()))?;
        if lhs[k][pivot] == 0.0 || !lhs[k][pivot].is_finite() {
            return None;
        }
        if pivot != k {
            for column in lhs.iter_mut().chain(rhs.iter_mut()) {
                column.swap(k, pivot);
            }
        }
        let inverse = 1.0 / lhs[k][k];
        for i in k + 1..N {
            let factor = lhs[k][i] * inverse;
            if factor == 0.0 {
                continue;
            }
            for column in lhs[k..].iter_mut().chain(rhs.iter_mut()) {
                column[i] -= factor * column[k];
            }
        }
    }
    for column in rhs.iter_mut() {
        for k in (0..N).rev() {
            let mut x = column[k];
            for j in k + 1..N {
                x -= lhs[j][k] * column[j];
            }
            column[k] = x / lhs[k][k];
        }
    }
    Some(rhs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::SMatrix;

    fn from_nalgebra<const N: usize>(m: &SMatrix<f64, N, N>) -> Square<N> {
        let mut out = [[0.0; N]; N];
        for j in 0..N {
            for i in 0..N {
                out[j][i] = m[(i, j)];
            }
        }
        out
    }

    fn max_rel_diff<const N: usize>(x: &Square<N>, y: &Square<N>) -> f64 {
        let scale = y.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
        x.iter()
            .flatten()
            .zip(y.iter().flatten())
            .map(|(a, b)| (a - b).abs() / scale)
            .fold(0.0, f64::max)
    }

    /// Against nalgebra's `exp` (an independent implementation of the same method, with its
    /// own degree selection) over every Padé degree and several squarings.
    #[test]
    fn matches_nalgebra_exp_for_every_degree() {
        let base = SMatrix::<f64, 5, 5>::from_fn(|i, j| {
            ((i * 7 + j * 3) % 11) as f64 / 11.0 - 0.4 + if i == j { -0.3 } else { 0.0 }
        });
        let base_norm = from_nalgebra(&base)
            .iter()
            .map(|c| c.iter().map(|x| x.abs()).sum::<f64>())
            .fold(0.0, f64::max);
        for target in [1e-3, 0.2, 0.9, 2.0, 5.0, 40.0, 900.0] {
            let a = base * (target / base_norm);
            let ours = expm(&from_nalgebra(&a)).expect("finite");
            let reference = from_nalgebra(&a.exp());
            let err = max_rel_diff(&ours, &reference);
            assert!(err < 1e-13, "‖A‖₁ = {target}: {err:e}");
        }
    }

    /// Closed forms: a rotation generator gives `[[cos, −sin], [sin, cos]]`, a nilpotent
    /// Jordan block `I + N + N²/2`.
    #[test]
    fn closed_forms() {
        for theta in [1e-4, 0.3, 2.0, 30.0] {
            let e = expm(&[[0.0, theta], [-theta, 0.0]]).unwrap();
            let expected = [[theta.cos(), theta.sin()], [-theta.sin(), theta.cos()]];
            assert!(
                max_rel_diff(&e, &expected) < 4e-15 * theta.max(1.0),
                "{theta}"
            );
        }
        let e = expm(&[[0.0, 0.0, 0.0], [3.0, 0.0, 0.0], [0.0, 2.0, 0.0]]).unwrap();
        // N = [[0,3,0],[0,0,2],[0,0,0]] (rows): N² = [[0,0,6],0,0]; e^N = I + N + N²/2.
        let expected = [[1.0, 0.0, 0.0], [3.0, 1.0, 0.0], [3.0, 2.0, 1.0]];
        assert!(max_rel_diff(&e, &expected) < 1e-15);
    }

    #[test]
    fn non_finite_input_is_refused() {
        assert!(expm(&[[f64::NAN, 0.0], [0.0, 1.0]]).is_none());
        assert!(expm(&[[f64::INFINITY, 0.0], [0.0, 1.0]]).is_none());
    }
}
