//! Restarted GMRES (Saad & Schultz 1986; Saad, *Iterative Methods for Sparse Linear Systems*,
//! 2nd ed., 2003, Alg. 6.9 with the Givens rotations of §6.5.3) for the Newton systems of the
//! torus quadrature, whose matrix is never formed: each product is a pass over the torus grid
//! ([`super::krylov`]).

use nalgebra::DVector;

/// The result of [`gmres`].
pub(super) struct Solved {
    pub(super) x: DVector<f64>,
    /// Whether `‖b − A x‖ ≤ tolerance · ‖b‖`.
    pub(super) converged: bool,
}

/// Solves `A x = b` from `x = 0` by GMRES restarted every `restart` products, until the
/// residual norm is at most `tolerance · ‖b‖` or `max_products` products are taken; `apply`
/// is `v ↦ A v`.
pub(super) fn gmres(
    apply: &mut dyn FnMut(&DVector<f64>) -> DVector<f64>,
    b: &DVector<f64>,
    tolerance: f64,
    restart: usize,
    max_products: usize,
) -> Solved {
    let n = b.len();
    let target = tolerance * b.norm();
    let mut x = DVector::zeros(n);
    let mut products = 0;
    if target == 0.0 {
        return Solved {
            x,
            converged: b.norm() == 0.0,
        };
    }
    let m = restart.max(1);
    loop {
        let r = if products == 0 {
            b.clone()
        } else {
            products += 1;
            b - apply(&x)
        };
        let beta = r.norm();
        if beta <= target || products >= max_products {
            return Solved {
                x,
                converged: beta <= target,
            };
        }
        // Arnoldi (modified Gram–Schmidt) with the least-squares problem kept triangular by
        // Givens rotations: `g[k]` is the residual norm after k steps.
        let mut basis: Vec<DVector<f64>> = vec![r / beta];
        let mut h = vec![vec![0.0; m]; m + 1];
        let (mut cs, mut sn) = (vec![0.0; m], vec![0.0; m]);
        let mut g = vec![0.0; m + 1];
        g[0] = beta;
        let mut steps = 0;
        for k in 0..m {
            let mut w = apply(&basis[k]);
            products += 1;
            for (i, v) in basis.iter().enumerate() {
                h[i][k] = w.dot(v);
                w.axpy(-h[i][k], v, 1.0);
            }
            let next = w.norm();
            h[k + 1][k] = next;
            for i in 0..k {
                let t = cs[i] * h[i][k] + sn[i] * h[i + 1][k];
                h[i + 1][k] = -sn[i] * h[i][k] + cs[i] * h[i + 1][k];
                h[i][k] = t;
            }
            let d = h[k][k].hypot(h[k + 1][k]);
            if d == 0.0 {
                break;
            }
            cs[k] = h[k][k] / d;
            sn[k] = h[k + 1][k] / d;
            h[k][k] = d;
            h[k + 1][k] = 0.0;
            g[k + 1] = -sn[k] * g[k];
            g[k] *= cs[k];
            steps = k + 1;
            if g[k + 1].abs() <= target || products >= max_products || next == 0.0 {
                break;
            }
            basis.push(w / next);
        }
        // x += V y with H y = g (upper triangular).
        let mut y = vec![0.0; steps];
        for i in (0..steps).rev() {
            let tail: f64 = (i + 1..steps).map(|c| h[i][c] * y[c]).sum();
            y[i] = (g[i] - tail) / h[i][i];
        }
        for (v, yi) in basis.iter().zip(&y) {
            x.axpy(*yi, v, 1.0);
        }
        if steps == 0 || g[steps].abs() <= target || products >= max_products {
            return Solved {
                x,
                converged: steps > 0 && g[steps].abs() <= target,
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    /// Against nalgebra's LU on a random nonsymmetric 120-square system `I + 0.3 B / √n`
    /// (eigenvalues in a disc about 1), with and without restarts.
    #[test]
    fn solves_like_the_lu() {
        let n = 120;
        let mut seed = 7u64;
        let mut next = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let scale = 0.6 / (n as f64).sqrt();
        let a = DMatrix::from_fn(n, n, |i, j| f64::from(u8::from(i == j)) + scale * next());
        let b = DVector::from_fn(n, |_, _| next());
        let reference = a.clone().lu().solve(&b).unwrap();
        for restart in [n, 10] {
            let solved = gmres(&mut |v| &a * v, &b, 1e-12, restart, 10 * n);
            assert!(solved.converged, "restart {restart}");
            let error = (&solved.x - &reference).amax() / reference.amax();
            assert!(error < 1e-10, "restart {restart}: {error}");
        }
        // A product budget too small: not converged, said so.
        let short = gmres(&mut |v| &a * v, &b, 1e-12, n, 3);
        assert!(!short.converged);
        assert!((&a * &short.x - &b).norm() > 1e-12 * b.norm());
    }
}
