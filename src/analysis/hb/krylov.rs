//! Newton–Krylov on the torus quadrature (issue 38): the Newton systems of a two-frequency
//! train solved by GMRES ([`super::gmres`]) with matrix-free products, no Jacobian matrix and
//! no factorisation (Knoll & Keyes 2004, J. Comput. Phys. 193:357–397, §2; Krack & Gross 2019
//! §2.4 for the AFT Jacobian it replaces).
//!
//! The condensed Jacobian is `J = I + R ∂g/∂s` (module doc of [`super`]): `R` the receptances,
//! block-diagonal per order, and `∂g/∂s` the Galerkin matrix of the law's slopes minus the mean
//! law already inverted in `R`. Its product with `v` is the Galerkin projection of
//! `∂F/∂S δS + ∂F/∂Ṡ δṠ` over the torus grid ([`super::problem`]'s `Torus::product`, the
//! slopes kept from the evaluation), then `R` per order: a pass over the grid costs about one
//! residual without the law, where the dense Jacobian of the countershaft at H = 20 (1 682
//! unknowns) took its Toeplitz sums and an LU of ~3·10⁹ flops. The mean part being inverted
//! in `R`, `J` is the identity plus the stiffness variation's share, and GMRES needs no further
//! preconditioner while no contact is lost (≤ 27 products a solve on the countershaft). With
//! a third of the mesh period out of contact it needs 40–140, and the solves take the
//! factorised Jacobian of an earlier iterate as preconditioner ([`FrozenJacobian`]; the mean
//! slopes of the contact pattern, block-diagonal per order, were measured not to reduce the
//! products: docs/harmonic-balance.md, "The whole range").

use std::f64::consts::TAU;

use nalgebra::{DMatrix, DVector};

use super::blocked_lu::FrozenJacobian;
use super::gmres::gmres;
use super::problem::{cmul, factor, Evaluation, Problem, Want};
use crate::model::Drivetrain;

/// Relative residual of the linear solve at which GMRES stops. It bounds the update's error
/// relative to the update: with a law linear in the deflection (no contact change) the second
/// update of a corrector is then below the HB tolerance, so a point takes two residuals.
const KRYLOV_TOLERANCE: f64 = 1e-10;

/// Krylov vectors kept before GMRES restarts (each one vector of the unknowns).
const KRYLOV_RESTART: usize = 80;

/// Products of one linear solve before it is given up.
const KRYLOV_PRODUCTS: usize = 400;

/// Newton iterations of the corrector before the step is halved.
const KRYLOV_ITERATIONS: usize = 12;

/// Products of one solve above which its [`FrozenJacobian`] is refreshed at the next iterate.
/// Where no contact is lost a corrector solve takes at most 27 products on the countershaft at
/// H = 20 (200–394 rad/s), so no Jacobian is built there; on the branch with 22–33 % contact
/// loss on mesh 1 beyond the 394 rad/s fold it took 40–140.
const KRYLOV_REFRESH_PRODUCTS: usize = 30;

/// The outcome of [`krylov_corrector`].
pub(super) enum Corrected {
    /// The last iterate's evaluation (with node samples) and the iterations taken.
    Converged(Box<Evaluation>, usize),
    /// No convergence (a linear solve or the Newton iteration): halve the step.
    Failed,
    /// The torus quadrature declined (a contact switch it cannot bracket): the caller
    /// continues on the line quadrature.
    Declined,
}

impl<M: Drivetrain> Problem<M> {
    /// `J v` for the mesh-deflection coefficients `v`, at the torus linearisation and the
    /// frequency of the last evaluation that kept it ([`Want::linear`]).
    pub(super) fn jacobian_product(&self, v: &DVector<f64>) -> DVector<f64> {
        let torus = self.torus.as_ref().expect("on the torus");
        let rec = self.receptance.as_ref().expect("evaluated");
        let (len, f) = (self.len, self.f);
        let gal = torus.product(self, v);
        let mut y = v.clone();
        let mut g = vec![0.0; len];
        for (n, mesh) in self.meshes.iter().enumerate() {
            for k in 0..mesh.outputs {
                let out = mesh.first + k;
                for (r, g) in g.iter_mut().enumerate() {
                    *g = factor(r) * gal[out][r];
                }
                if k == 0 {
                    // The mean law moved into the linear part: − k̄ v − c̄ f dv/dθ.
                    let vn = &v.as_slice()[n * len..(n + 1) * len];
                    for (g, x) in g.iter_mut().zip(vn) {
                        *g -= mesh.k_mean * x;
                    }
                    for (q, &j) in self.orders.iter().enumerate().skip(1) {
                        let w = TAU * j as f64 * mesh.c_mean * f;
                        g[2 * q - 1] -= w * vn[2 * q];
                        g[2 * q] += w * vn[2 * q - 1];
                    }
                }
                // Every coordinate's rows: R[c, out] per order.
                for c in 0..self.coordinates() {
                    let block = &mut y.as_mut_slice()[c * len..(c + 1) * len];
                    block[0] += rec.r[0][(c, out)].re * g[0];
                    for q in 1..self.orders.len() {
                        let (a, b) = cmul(rec.r[q][(c, out)], g[2 * q - 1], g[2 * q]);
                        block[2 * q - 1] += a;
                        block[2 * q] += b;
                    }
                }
            }
        }
        y
    }

    /// `J⁻¹ b` by GMRES at the last evaluation's torus linearisation; None when it does not
    /// converge.
    /// `frozen` preconditions the solve on the right and is marked for a refresh when the
    /// solve takes more than [`KRYLOV_REFRESH_PRODUCTS`] products.
    pub(super) fn krylov_solve(
        &self,
        b: &DVector<f64>,
        frozen: &mut FrozenJacobian,
    ) -> Option<DVector<f64>> {
        preconditioned_gmres(frozen, &mut |v| self.jacobian_product(v), b)
    }
}

/// `A⁻¹ b` by GMRES on `product` (`v ↦ A v`), preconditioned on the right by `frozen`, which
/// is marked for a refresh when the solve takes more than [`KRYLOV_REFRESH_PRODUCTS`]
/// products; None when it does not converge or is not finite.
fn preconditioned_gmres(
    frozen: &mut FrozenJacobian,
    product: &mut dyn FnMut(&DVector<f64>) -> DVector<f64>,
    b: &DVector<f64>,
) -> Option<DVector<f64>> {
    let mut products = 0;
    let solved = gmres(
        &mut |v| {
            products += 1;
            product(&frozen.apply(v))
        },
        b,
        KRYLOV_TOLERANCE,
        KRYLOV_RESTART,
        KRYLOV_PRODUCTS,
    );
    if products > KRYLOV_REFRESH_PRODUCTS {
        frozen.refresh = true;
    }
    let x = frozen.apply(&solved.x);
    (solved.converged && x.iter().all(|x| x.is_finite())).then_some(x)
}

/// The unit tangent `[−J⁻¹d; 1]/‖·‖` of the branch `r(s, λ) = 0` (`d = ∂r/∂λ` in the scaled
/// unknowns) at the last evaluation's torus linearisation; None when GMRES does not converge.
pub(super) fn krylov_tangent<M: Drivetrain>(
    problem: &Problem<M>,
    d: &DVector<f64>,
) -> Option<DVector<f64>> {
    let y = problem.krylov_solve(d, &mut FrozenJacobian::default())?;
    let dim = y.len();
    let mut t = DVector::zeros(dim + 1);
    t.rows_mut(0, dim).copy_from(&(-y));
    t[dim] = 1.0;
    Some(t.normalize())
}

/// The continuation's corrector on the torus: Newton on `[r; tᵀ(w − w_pred)] = 0` in the
/// scaled unknowns `w = [s/x_s, f/f_ref]`, each bordered system solved by GMRES with the
/// products `[J v_s + ∂r/∂λ v_λ; tᵀ v]` (the border is a rank-two change of `J`, which adds
/// about two Krylov vectors, and keeps the system regular at folds).
pub(super) fn krylov_corrector<M: Drivetrain>(
    problem: &mut Problem<M>,
    frozen: &mut FrozenJacobian,
    candidate: &mut DVector<f64>,
    (predicted, tangent): (&DVector<f64>, &DVector<f64>),
    (xs, f_ref): (f64, f64),
    tolerance: f64,
) -> Corrected {
    let dim = candidate.len() - 1;
    for it in 1..=KRYLOV_ITERATIONS {
        let s = candidate.rows(0, dim) * xs;
        let f = candidate[dim] * f_ref;
        let refresh = frozen.refresh;
        let want = Want {
            jacobian: refresh,
            frequency: true,
            samples: true,
            linear: true,
        };
        let Ok(mut e) = problem.evaluate(&s, f, want) else {
            return Corrected::Failed;
        };
        if problem.torus.is_none() {
            return Corrected::Declined;
        }
        let Some(d) = e.d_frequency.take() else {
            return Corrected::Failed;
        };
        let d = d * (f_ref / xs);
        if refresh {
            let Some(jacobian) = e.jacobian.take() else {
                return Corrected::Failed;
            };
            let mut a = DMatrix::zeros(dim + 1, dim + 1);
            a.view_mut((0, 0), (dim, dim)).copy_from(&jacobian);
            a.view_mut((0, dim), (dim, 1)).copy_from(&d);
            a.set_row(dim, &tangent.transpose());
            frozen.factorise(a);
        }
        let mut g = DVector::zeros(dim + 1);
        g.rows_mut(0, dim).copy_from(&(&e.residual / xs));
        g[dim] = tangent.dot(&(&*candidate - predicted));
        let linearised: &Problem<M> = problem;
        let mut bordered = |x: &DVector<f64>| {
            let mut y = DVector::zeros(dim + 1);
            let xs = x.rows(0, dim).into_owned();
            y.rows_mut(0, dim)
                .copy_from(&(linearised.jacobian_product(&xs) + &d * x[dim]));
            y[dim] = tangent.dot(x);
            y
        };
        let Some(delta) = preconditioned_gmres(frozen, &mut bordered, &(-g)) else {
            return Corrected::Failed;
        };
        if delta.amax() <= tolerance.max(1e-13) * 10.0 {
            return Corrected::Converged(Box::new(e), it);
        }
        *candidate += &delta;
    }
    Corrected::Failed
}
