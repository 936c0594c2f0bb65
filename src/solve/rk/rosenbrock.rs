//! RODAS4, the L-stable, stiffly accurate Rosenbrock method of order 4(3) with a 3rd-order
//! continuous extension (Hairer & Wanner, *Solving ODEs II*, 2nd ed. 1996, §IV.7, Table 7.5;
//! coefficients as in Hairer's `rodas.f`, `ROCOE` with `METH = 1`).
//!
//! Linearly implicit: one LU of `E = I/(hγ) − J` per step (re-factored after a rejection with
//! the same `J`), six solves, six right-hand sides, no Newton iteration, so a step costs the
//! same whatever the stiffness. In the transformed variables of HW II (7.25), with `J = ∂f/∂y`
//! and `f_t = ∂f/∂t` at the step start,
//!
//! `E u_i = f(t + c_i h, y + Σ_{j<i} a_ij u_j) + Σ_{j<i} (c_ij/h) u_j + h d_i f_t`,
//!
//! `y1 = y + Σ a_5j u_j + u5 + u6`; `u6` is the difference to the embedded 3rd-order solution
//! (the error estimate); both solutions are stage arguments (stiffly accurate), which is why
//! `R(∞) = 0`. The dense output `y0 (1−θ) + θ (y1 + (1−θ)(r2 + θ r3))` is of order 3.
//!
//! The Jacobian is the system's ([`HybridSystem::jacobian`]: exact and constant within a
//! segment of the piecewise-LTI gear models) or, when it has none (tooth friction, carried
//! rotation), forward differences as in `rodas.f`; `f_t` is a forward difference kept inside
//! the step, so no evaluation falls beyond the stop the step ends on.
#![allow(clippy::excessive_precision)]

use crate::solve::{HybridSystem, SolverStats};

/// `γ`, the diagonal of the method.
pub(crate) const GAMMA: f64 = 0.25;

/// Stage nodes `c_i` (`C2, C3, C4` of `rodas.f`; stages 5 and 6 sit at the step end).
pub(crate) const C: [f64; 6] = [0.0, 0.386, 0.21, 0.63, 1.0, 1.0];

/// Time-derivative weights `d_i = Σ_j γ_ij` of stages 1–4 (stages 5, 6: zero).
pub(crate) const D: [f64; 6] = [0.25, -0.1043, 0.1035, -0.03620000000000023, 0.0, 0.0];

/// Stage arguments `y + Σ_j a_ij u_j`: row `i` holds `a_i1 … a_i,i−1`. Row 6 is row 5 plus
/// `u5` (the embedded solution is the argument of the last stage).
pub(crate) const A: [&[f64]; 6] = [
    &[],
    &[1.544000000000000],
    &[0.9466785280815826, 0.2557011698983284],
    &[3.314825187068521, 2.896124015972201, 0.9986419139977817],
    &[
        1.221224509226641,
        6.019134481288629,
        12.53708332932087,
        -0.6878860361058950,
    ],
    &[
        1.221224509226641,
        6.019134481288629,
        12.53708332932087,
        -0.6878860361058950,
        1.0,
    ],
];

/// `c_ij` of the stage equations (`C21 … C65`).
pub(crate) const CIJ: [&[f64]; 6] = [
    &[],
    &[-5.668800000000000],
    &[-2.430093356833875, -0.2063599157091915],
    &[-0.1073529058151375, -9.594562251023355, -20.47028614809616],
    &[
        7.496443313967647,
        -10.24680431464352,
        -33.99990352819905,
        11.70890893206160,
    ],
    &[
        8.083246795921522,
        -7.981132988064893,
        -31.52159432874371,
        16.31930543123136,
        -6.058818238834054,
    ],
];

/// `m_j`: `y1 = y + Σ m_j u_j`.
pub(crate) const M: [f64; 6] = [
    1.221224509226641,
    6.019134481288629,
    12.53708332932087,
    -0.6878860361058950,
    1.0,
    1.0,
];

/// Dense-output rows `r2 = Σ_j d2j u_j`, `r3 = Σ_j d3j u_j` over stages 1–5 (`D21 … D35`).
pub(crate) const DENSE: [[f64; 5]; 2] = [
    [
        10.12623508344586,
        -7.487995877610167,
        -34.80091861555747,
        -7.992771707568823,
        1.025137723295662,
    ],
    [
        -0.6762803392801253,
        6.087714651680015,
        16.43084320892478,
        24.76722511418386,
        -6.594389125716872,
    ],
];

/// Stages of one step.
pub(crate) const STAGES: usize = 6;

/// How `E = I/(hγ) − J` is factored.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Structure {
    /// One LU of the whole `n × n` matrix.
    Full,
    /// `J = [[0, I], [A, B]]` with blocks of size `m = n/2` (a second-order system `x'' =
    /// A x + B x'` in first-order form: every gear model's Jacobian): one LU of the Schur
    /// complement `S = α² I − α B − A`, `α = 1/(hγ)`, of size `m`, i.e. 8× fewer flops than
    /// the LU of `E`. This is the special structure `M1 = M2 = n/2` of Hairer's `rodas.f`
    /// and `decsol.f` (`DECOMR`/`SLVROD`), HW II §IV.7 "Implementation of Rosenbrock methods".
    SecondOrder { m: usize },
}

/// The linear algebra of the linearly implicit step: `J`, `f_t`, and the LU factors of `E`
/// (or of its Schur complement, [`Structure::SecondOrder`]).
#[derive(Debug, Clone)]
pub(crate) struct LinearlyImplicit {
    n: usize,
    /// `∂f/∂y` at the step start, row-major.
    jac: Vec<f64>,
    structure: Structure,
    /// `∂f/∂t` at the step start.
    f_t: Vec<f64>,
    /// LU factors (unit lower triangle below the diagonal), row-major: of `E` (`n × n`) or
    /// of the Schur complement (`m × m`, the first `m²` entries).
    lu: Vec<f64>,
    pivots: Vec<usize>,
    /// Scratch for finite differences: a right-hand side and a perturbed state.
    probe: Vec<f64>,
    y_probe: Vec<f64>,
    /// Step size the factors were built for (`NaN`: none valid).
    factored_for: f64,
}

impl LinearlyImplicit {
    pub fn new(n: usize) -> Self {
        LinearlyImplicit {
            n,
            jac: vec![0.0; n * n],
            structure: Structure::Full,
            f_t: vec![0.0; n],
            lu: vec![0.0; n * n],
            pivots: vec![0; n],
            probe: vec![0.0; n],
            y_probe: vec![0.0; n],
            factored_for: f64::NAN,
        }
    }

    /// `J` and `f_t` at `(t, y)` with `f0 = f(t, y)`; the `f_t` difference stays within
    /// `room` (the time to the step limit), so the mode frozen for the step is the one used.
    pub fn linearise<S: HybridSystem>(
        &mut self,
        sys: &S,
        t: f64,
        y: &[f64],
        f0: &[f64],
        room: f64,
        stats: &mut SolverStats,
    ) {
        let n = self.n;
        if sys.jacobian(t, y, &mut self.jac) {
            self.structure = second_order_blocks(&self.jac, n);
        } else {
            // Forward differences by columns (`rodas.f`): δ_j = √(ε max(1e-5, |y_j|)). Their
            // upper blocks are not exactly `[0, I]`, so the full LU is used.
            self.structure = Structure::Full;
            self.y_probe.copy_from_slice(y);
            for (j, &yj) in y.iter().enumerate() {
                let delta = (f64::EPSILON * yj.abs().max(1e-5)).sqrt();
                self.y_probe[j] = yj + delta;
                sys.rhs(t, &self.y_probe, &mut self.probe);
                stats.rhs_evals += 1;
                self.y_probe[j] = yj;
                for (i, (&p, &f)) in self.probe.iter().zip(f0).enumerate() {
                    self.jac[i * n + j] = (p - f) / delta;
                }
            }
        }
        let delta = (f64::EPSILON * t.abs().max(1e-5)).sqrt().min(0.5 * room);
        if delta > 0.0 && t + delta > t {
            sys.rhs(t + delta, y, &mut self.probe);
            stats.rhs_evals += 1;
            for ((ft, &p), &f) in self.f_t.iter_mut().zip(&self.probe).zip(f0) {
                *ft = (p - f) / delta;
            }
        } else {
            self.f_t.fill(0.0);
        }
        self.factored_for = f64::NAN;
    }

    /// Factors `E = I/(hγ) − J` (kept when already factored for `h`). Returns `false` when
    /// `E` is singular to working precision (then the step must shrink).
    pub fn factor(&mut self, h: f64) -> bool {
        if self.factored_for == h {
            return true;
        }
        let n = self.n;
        let alpha = 1.0 / (h * GAMMA);
        let size = match self.structure {
            Structure::Full => {
                for (e, &j) in self.lu.iter_mut().zip(&self.jac) {
                    *e = -j;
                }
                for i in 0..n {
                    self.lu[i * n + i] += alpha;
                }
                n
            }
            Structure::SecondOrder { m } => {
                // Eliminating `x1 = (b1 + x2)/α` from `α x1 − x2 = b1` leaves
                // `(α² I − α B − A) x2 = α b2 + A b1`.
                for i in 0..m {
                    let row = &self.jac[(m + i) * n..(m + i + 1) * n];
                    let (a, b) = row.split_at(m);
                    let s = &mut self.lu[i * m..(i + 1) * m];
                    for l in 0..m {
                        s[l] = -alpha * b[l] - a[l];
                    }
                    s[i] += alpha * alpha;
                }
                m
            }
        };
        if lu_factor(&mut self.lu[..size * size], &mut self.pivots[..size], size) {
            self.factored_for = h;
            true
        } else {
            self.factored_for = f64::NAN;
            false
        }
    }

    /// Solves `E x = b` in place (with the factors of the last [`LinearlyImplicit::factor`]).
    pub fn solve(&self, b: &mut [f64]) {
        let n = self.n;
        match self.structure {
            Structure::Full => lu_solve(&self.lu[..n * n], &self.pivots[..n], n, b),
            Structure::SecondOrder { m } => {
                let alpha = 1.0 / (self.factored_for * GAMMA);
                let (b1, b2) = b.split_at_mut(m);
                for (i, x) in b2.iter_mut().enumerate() {
                    let a = &self.jac[(m + i) * n..(m + i) * n + m];
                    let ab: f64 = a.iter().zip(b1.iter()).map(|(a, v)| a * v).sum();
                    *x = alpha * *x + ab;
                }
                lu_solve(&self.lu[..m * m], &self.pivots[..m], m, b2);
                for (x1, &x2) in b1.iter_mut().zip(b2.iter()) {
                    *x1 = (*x1 + x2) / alpha;
                }
            }
        }
    }

    /// `f_t` at the step start.
    pub fn f_t(&self) -> &[f64] {
        &self.f_t
    }

    /// Whether the last linearisation found the second-order block structure.
    #[cfg(test)]
    pub fn uses_schur_complement(&self) -> bool {
        matches!(self.structure, Structure::SecondOrder { .. })
    }
}

/// [`Structure::SecondOrder`] when the row-major `n × n` Jacobian `jac` is exactly
/// `[[0, I], [A, B]]` (as the models write it), else [`Structure::Full`].
fn second_order_blocks(jac: &[f64], n: usize) -> Structure {
    if n < 2 || !n.is_multiple_of(2) {
        return Structure::Full;
    }
    let m = n / 2;
    let upper_is_zero_identity = (0..m).all(|i| {
        jac[i * n..(i + 1) * n]
            .iter()
            .enumerate()
            .all(|(j, &v)| v == if j == m + i { 1.0 } else { 0.0 })
    });
    if upper_is_zero_identity {
        Structure::SecondOrder { m }
    } else {
        Structure::Full
    }
}

/// Doolittle LU with partial pivoting of the row-major `n × n` matrix `a`, rows swapped in
/// place. `false` when a pivot is zero or not finite (singular to working precision).
fn lu_factor(a: &mut [f64], pivots: &mut [usize], n: usize) -> bool {
    for k in 0..n {
        let mut p = k;
        let mut best = a[k * n + k].abs();
        for i in k + 1..n {
            let v = a[i * n + k].abs();
            if v > best {
                best = v;
                p = i;
            }
        }
        if !(best > 0.0) || !best.is_finite() {
            return false;
        }
        pivots[k] = p;
        if p != k {
            for j in 0..n {
                a.swap(k * n + j, p * n + j);
            }
        }
        let pivot = a[k * n + k];
        let (upper, lower) = a.split_at_mut((k + 1) * n);
        let row_k = &upper[k * n..(k + 1) * n];
        for row in lower.chunks_exact_mut(n) {
            let l = row[k] / pivot;
            row[k] = l;
            if l != 0.0 {
                for j in k + 1..n {
                    row[j] -= l * row_k[j];
                }
            }
        }
    }
    true
}

/// Solves `LU x = P b` in place with the factors of [`lu_factor`].
fn lu_solve(lu: &[f64], pivots: &[usize], n: usize, b: &mut [f64]) {
    for (k, &p) in pivots[..n].iter().enumerate() {
        b.swap(k, p);
    }
    for i in 0..n {
        let row = &lu[i * n..i * n + i];
        let s: f64 = row.iter().zip(&b[..i]).map(|(l, x)| l * x).sum();
        b[i] -= s;
    }
    for i in (0..n).rev() {
        let row = &lu[i * n..(i + 1) * n];
        let s: f64 = row[i + 1..]
            .iter()
            .zip(&b[i + 1..])
            .map(|(u, x)| u * x)
            .sum();
        b[i] = (b[i] - s) / row[i];
    }
}
