//! Right-looking blocked LU with partial pivoting (Golub & Van Loan, *Matrix Computations*,
//! 4th ed., Alg. 3.4.2 with 3.2.11's blocking) for the large Newton systems of the chord
//! corrector (more than [`super::problem::CHORD_UNKNOWNS`] unknowns): the trailing updates are
//! matrix products (nalgebra's `gemm`, matrixmultiply's packed kernels), where the unblocked
//! LU spends its ~(2/3)n³ flops in rank-one updates. On the countershaft at H = 20
//! (1683 square) this is what one Jacobian refresh costs (docs/harmonic-balance.md "Solver").

use nalgebra::{DMatrix, DVector, Dyn, LU};

/// Columns per panel.
const PANEL: usize = 64;

/// `P A = L U` in place: `L` unit lower (below the diagonal), `U` upper; `rows[i]` the row
/// of `A` that row `i` of `P A` is.
pub(super) struct BlockedLu {
    lu: DMatrix<f64>,
    rows: Vec<usize>,
}

impl BlockedLu {
    /// Factorises the square matrix `a`; None when a pivot is zero (singular).
    pub(super) fn new(mut a: DMatrix<f64>) -> Option<BlockedLu> {
        let n = a.nrows();
        assert_eq!(n, a.ncols(), "square");
        let mut rows: Vec<usize> = (0..n).collect();
        for k0 in (0..n).step_by(PANEL) {
            let kb = PANEL.min(n - k0);
            // The panel, unblocked (row swaps over the whole rows).
            for j in k0..k0 + kb {
                let column = a.column(j);
                let (p, pivot) = (j..n)
                    .map(|i| (i, column[i].abs()))
                    .fold((j, -1.0), |best, x| if x.1 > best.1 { x } else { best });
                if !(pivot > 0.0) {
                    return None;
                }
                if p != j {
                    a.swap_rows(j, p);
                    rows.swap(j, p);
                }
                let d = a[(j, j)];
                for i in j + 1..n {
                    a[(i, j)] /= d;
                }
                for c in j + 1..k0 + kb {
                    let u = a[(j, c)];
                    if u != 0.0 {
                        for i in j + 1..n {
                            a[(i, c)] -= a[(i, j)] * u;
                        }
                    }
                }
            }
            let rest = n - k0 - kb;
            if rest == 0 {
                continue;
            }
            // U12 = L11⁻¹ A12.
            for c in k0 + kb..n {
                for j in k0..k0 + kb {
                    let u = a[(j, c)];
                    if u != 0.0 {
                        for i in j + 1..k0 + kb {
                            a[(i, c)] -= a[(i, j)] * u;
                        }
                    }
                }
            }
            // A22 −= L21 U12.
            let l21 = a.view((k0 + kb, k0), (rest, kb)).clone_owned();
            let u12 = a.view((k0, k0 + kb), (kb, rest)).clone_owned();
            a.view_mut((k0 + kb, k0 + kb), (rest, rest))
                .gemm(-1.0, &l21, &u12, 1.0);
        }
        Some(BlockedLu { lu: a, rows })
    }

    /// `A⁻¹ b`.
    pub(super) fn solve(&self, b: &DVector<f64>) -> Option<DVector<f64>> {
        let n = self.lu.nrows();
        let mut x = DVector::from_fn(n, |i, _| b[self.rows[i]]);
        for j in 0..n {
            let v = x[j];
            if v != 0.0 {
                for i in j + 1..n {
                    x[i] -= self.lu[(i, j)] * v;
                }
            }
        }
        for j in (0..n).rev() {
            x[j] /= self.lu[(j, j)];
            let v = x[j];
            if v != 0.0 {
                for i in 0..j {
                    x[i] -= self.lu[(i, j)] * v;
                }
            }
        }
        x.iter().all(|v| v.is_finite()).then_some(x)
    }
}

/// A factorised Newton matrix: nalgebra's LU below [`super::problem::CHORD_UNKNOWNS`]
/// unknowns (the small systems' iterates unchanged), the blocked LU above.
pub(super) enum Factorised {
    Unblocked(LU<f64, Dyn, Dyn>),
    /// None when a pivot was zero.
    Blocked(Option<BlockedLu>),
}

impl Factorised {
    pub(super) fn new(a: DMatrix<f64>, blocked: bool) -> Factorised {
        if blocked {
            Factorised::Blocked(BlockedLu::new(a))
        } else {
            Factorised::Unblocked(a.lu())
        }
    }

    /// `A⁻¹ b`; None when `A` is singular.
    pub(super) fn solve(&self, b: &DVector<f64>) -> Option<DVector<f64>> {
        match self {
            Factorised::Unblocked(lu) => lu.solve(b),
            Factorised::Blocked(lu) => lu.as_ref()?.solve(b),
        }
    }
}

/// The preconditioner of the Newton–Krylov solves on the torus (`krylov.rs`) where GMRES on
/// the Jacobian alone needs many products (contact loss): the factorised Newton matrix of an
/// earlier iterate (the dense Jacobian of the torus sums, bordered in the continuation's
/// corrector, factorised by the blocked LU), kept over iterates and branch points while it
/// keeps the solves short and refreshed (`refresh`) when a solve takes many products; the
/// identity until then. A preconditioner from the current contact pattern, applied on the
/// right so that GMRES's residual stays the system's (Knoll & Keyes 2004, J. Comput. Phys.
/// 193:357–397, §3.1, the frozen Jacobian as preconditioner).
#[derive(Default)]
pub(super) struct FrozenJacobian {
    lu: Option<Factorised>,
    /// Set by a solve that took many products: the next iterate factorises its Jacobian.
    pub(super) refresh: bool,
}

impl FrozenJacobian {
    /// Keeps the factorisation of `a` (the Newton matrix at the current iterate).
    pub(super) fn factorise(&mut self, a: DMatrix<f64>) {
        self.lu = Some(Factorised::new(a, true));
        self.refresh = false;
    }

    /// `M⁻¹ v`: the identity without a factorisation (or where it is singular).
    pub(super) fn apply(&self, v: &DVector<f64>) -> DVector<f64> {
        (self.lu.as_ref())
            .and_then(|lu| lu.solve(v))
            .unwrap_or_else(|| v.clone())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against nalgebra's unblocked LU on a random 300-square system (several panels and a
    /// partial last one).
    #[test]
    fn solves_like_the_unblocked_lu() {
        let n = 300;
        let mut seed = 1u64;
        let mut next = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let a = DMatrix::from_fn(n, n, |_, _| next());
        let b = DVector::from_fn(n, |_, _| next());
        let x = BlockedLu::new(a.clone()).unwrap().solve(&b).unwrap();
        let reference = a.clone().lu().solve(&b).unwrap();
        let error = (&x - &reference).amax() / reference.amax();
        assert!(error < 1e-10, "{error}");
        assert!((&a * &x - &b).amax() < 1e-10);
        assert!(BlockedLu::new(DMatrix::zeros(3, 3)).is_none());
    }
}
