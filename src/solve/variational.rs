//! Variational equations with saltation matrices: a hybrid system `y' = f(t, y)` extended by
//! its state-transition matrix `Φ' = (∂f/∂y) Φ`, `Φ(t0) = I`, so any integrator of
//! [`HybridSystem`]s also delivers `∂y(t)/∂y(t0)` (monodromy matrices for shooting and Floquet
//! analysis of scenes the exact propagator cannot handle).
//!
//! At a state event the flow jumps from `f⁻` to `f⁺`; the transition matrix is multiplied by
//! the saltation matrix `S = I + (f⁺ − f⁻) ∇gᵀ / (∇g·f⁻ + ∂g/∂t)` (Aizerman & Gantmacher
//! 1958; Leine & Nijmeijer 2004, eq. 3.74; Müller 1995). The snap onto the surface is the
//! identity in exact arithmetic. Known-time stops of a continuous model need no correction.

use super::HybridSystem;

/// `[y, vec(Φ)]` (Φ column-major) of an inner system of dimension `n`.
pub struct Variational<'a, S: HybridSystem> {
    pub inner: &'a mut S,
    n: usize,
    /// Set when an event could not be corrected (grazing or missing derivatives).
    pub failure: Option<String>,
}

impl<'a, S: HybridSystem> Variational<'a, S> {
    /// Wraps `inner`; fails if it provides no Jacobian.
    pub fn new(inner: &'a mut S, t: f64, y: &[f64]) -> Result<Self, String> {
        let n = inner.dim();
        let mut jac = vec![0.0; n * n];
        if !inner.jacobian(t, y, &mut jac) {
            return Err("the system provides no Jacobian for variational equations".into());
        }
        Ok(Variational {
            inner,
            n,
            failure: None,
        })
    }

    /// The extended initial state `[y0, I]`.
    pub fn initial_state(&self, y0: &[f64]) -> Vec<f64> {
        let n = self.n;
        let mut z = vec![0.0; n + n * n];
        z[..n].copy_from_slice(y0);
        for i in 0..n {
            z[n + i * n + i] = 1.0;
        }
        z
    }

    /// `Φ` of an extended state, row-major.
    pub fn transition(&self, z: &[f64]) -> Vec<f64> {
        let n = self.n;
        let mut phi = vec![0.0; n * n];
        for col in 0..n {
            for row in 0..n {
                phi[row * n + col] = z[n + col * n + row];
            }
        }
        phi
    }
}

impl<S: HybridSystem> HybridSystem for Variational<'_, S> {
    fn dim(&self) -> usize {
        self.n + self.n * self.n
    }

    fn rhs(&self, t: f64, z: &[f64], dz: &mut [f64]) {
        let n = self.n;
        self.inner.rhs(t, &z[..n], &mut dz[..n]);
        let mut jac = vec![0.0; n * n];
        self.inner.jacobian(t, &z[..n], &mut jac);
        for col in 0..n {
            for row in 0..n {
                dz[n + col * n + row] = (0..n).map(|k| jac[row * n + k] * z[n + col * n + k]).sum();
            }
        }
    }

    fn guard_count(&self) -> usize {
        self.inner.guard_count()
    }

    fn guards(&self, t: f64, z: &[f64], g: &mut [f64]) {
        self.inner.guards(t, &z[..self.n], g);
    }

    fn next_stop(&self) -> f64 {
        self.inner.next_stop()
    }

    fn on_stop(&mut self, t: f64, z: &mut [f64]) {
        let n = self.n;
        self.inner.on_stop(t, &mut z[..n]);
    }

    fn on_event(&mut self, t: f64, z: &mut [f64], index: usize) {
        let n = self.n;
        let mut before = vec![0.0; n];
        self.inner.rhs(t, &z[..n], &mut before);
        let mut grad = vec![0.0; n];
        let dgdt = self.inner.guard_gradient(t, &z[..n], index, &mut grad);
        self.inner.on_event(t, &mut z[..n], index);
        let Some(dgdt) = dgdt else {
            self.failure = Some(format!(
                "event at t = {t:e}: the system gives no guard gradient"
            ));
            return;
        };
        let mut after = vec![0.0; n];
        self.inner.rhs(t, &z[..n], &mut after);
        let rate: f64 = grad.iter().zip(&before).map(|(g, f)| g * f).sum::<f64>() + dgdt;
        let scale: f64 = grad
            .iter()
            .zip(&before)
            .map(|(g, f)| (g * f).abs())
            .sum::<f64>()
            + dgdt.abs();
        if !(rate.abs() > 1e-9 * scale) {
            self.failure = Some(format!(
                "grazing contact at t = {t:e}: the saltation matrix is unbounded"
            ));
            return;
        }
        // Φ ← S Φ with S = I + (f⁺ − f⁻) ∇gᵀ / ġ.
        for col in 0..n {
            let g_phi: f64 = (0..n).map(|k| grad[k] * z[n + col * n + k]).sum();
            for row in 0..n {
                z[n + col * n + row] += (after[row] - before[row]) * g_phi / rate;
            }
        }
    }

    /// The inner guard's gradient, padded with zeros over the sensitivity block.
    fn guard_gradient(&self, t: f64, z: &[f64], index: usize, grad: &mut [f64]) -> Option<f64> {
        let n = self.n;
        grad[n..].fill(0.0);
        self.inner.guard_gradient(t, &z[..n], index, &mut grad[..n])
    }

    fn affine_guard(&self, index: usize, t0: f64, t1: f64, w: &mut [f64]) -> Option<f64> {
        let n = self.n;
        w[n..].fill(0.0);
        self.inner.affine_guard(index, t0, t1, &mut w[..n])
    }

    fn jacobian(&self, _t: f64, _z: &[f64], _jac: &mut [f64]) -> bool {
        false
    }
}
