//! RODAS4 checks against closed forms: the Rosenbrock order conditions (HW II §IV.7, Table
//! 7.1) of the solution (order 4) and of the embedded solution (order 3), `R(∞) = 0`
//! (L-stability) and `|R(iy)| ≤ 1`; the observed order on a linear non-autonomous problem
//! with a closed-form solution; a very stiff problem (λ = −1e8) at large steps; and the event
//! location through the shared step loop; the reduced (Schur complement) solve of a
//! second-order system's `E` against `E` itself, and a coupled damped oscillator against its
//! modal closed form.

use super::rosenbrock::{LinearlyImplicit, A, C, CIJ, D, GAMMA, M, STAGES};
use super::{Method, RkOptions, RkStepper};
use crate::solve::{HybridSystem, SolverStats};

const S: usize = STAGES;

// Index notation as in HW II (matrices of coefficients).
#[allow(clippy::needless_range_loop)]
/// `(α, Γ)` of the standard form (HW II (7.4)) from the transformed coefficients:
/// `Γ⁻¹ = I/γ − C`, `α = A Γ`, weights `b = m Γ`.
fn standard_form() -> ([[f64; S]; S], [[f64; S]; S]) {
    let mut gamma_inv = [[0.0; S]; S];
    for i in 0..S {
        gamma_inv[i][i] = 1.0 / GAMMA;
        for (j, &c) in CIJ[i].iter().enumerate() {
            gamma_inv[i][j] = -c;
        }
    }
    // Invert the lower triangular Γ⁻¹ by forward substitution, column by column.
    let mut gamma = [[0.0; S]; S];
    for col in 0..S {
        for (i, g_row) in gamma_inv.iter().enumerate().skip(col) {
            let mut rhs = if i == col { 1.0 } else { 0.0 };
            for k in col..i {
                rhs -= g_row[k] * gamma[k][col];
            }
            gamma[i][col] = rhs / g_row[i];
        }
    }
    let mut alpha = [[0.0; S]; S];
    for i in 0..S {
        for j in 0..S {
            alpha[i][j] = A[i].iter().enumerate().map(|(k, a)| a * gamma[k][j]).sum();
        }
    }
    (alpha, gamma)
}

fn weights(m: &[f64; S], gamma: &[[f64; S]; S]) -> [f64; S] {
    let mut b = [0.0; S];
    for (j, bj) in b.iter_mut().enumerate() {
        *bj = (0..S).map(|i| m[i] * gamma[i][j]).sum();
    }
    b
}

/// Residuals of the order conditions of orders 1..=4 (HW II Table 7.1) and one of order 5
/// (`Σ b α⁴ = 1/5`), for weights `b`.
fn residuals(b: &[f64; S], alpha: &[[f64; S]; S], gamma: &[[f64; S]; S]) -> Vec<(u32, f64)> {
    let g = GAMMA;
    // β_ij = α_ij + γ_ij for j < i; β'_i = Σ_{j<i} β_ij; α_i = Σ_j α_ij.
    let beta = |i: usize, j: usize| alpha[i][j] + gamma[i][j];
    let bp: Vec<f64> = (0..S).map(|i| (0..i).map(|j| beta(i, j)).sum()).collect();
    let al: Vec<f64> = (0..S).map(|i| alpha[i].iter().sum()).collect();
    let sum = |f: &dyn Fn(usize) -> f64| (0..S).map(|j| b[j] * f(j)).sum::<f64>();
    vec![
        (1, sum(&|_| 1.0) - 1.0),
        (2, sum(&|j| bp[j]) - (0.5 - g)),
        (3, sum(&|j| al[j] * al[j]) - 1.0 / 3.0),
        (
            3,
            sum(&|j| (0..j).map(|k| beta(j, k) * bp[k]).sum()) - (1.0 / 6.0 - g + g * g),
        ),
        (4, sum(&|j| al[j].powi(3)) - 0.25),
        (
            4,
            sum(&|j| al[j] * (0..j).map(|k| alpha[j][k] * bp[k]).sum::<f64>())
                - (1.0 / 8.0 - g / 3.0),
        ),
        (
            4,
            sum(&|j| (0..j).map(|k| beta(j, k) * al[k] * al[k]).sum()) - (1.0 / 12.0 - g / 3.0),
        ),
        (
            4,
            sum(&|j| {
                (0..j)
                    .map(|k| beta(j, k) * (0..k).map(|l| beta(k, l) * bp[l]).sum::<f64>())
                    .sum()
            }) - (1.0 / 24.0 - g / 2.0 + 1.5 * g * g - g.powi(3)),
        ),
        (5, sum(&|j| al[j].powi(4)) - 0.2),
        // The tall tree: Σ b β β β β' = Σ_i (−γ)^i C(4, i)/(5 − i)!.
        (5, {
            let mut v = bp.clone();
            for _ in 0..3 {
                v = (0..S)
                    .map(|j| (0..j).map(|k| beta(j, k) * v[k]).sum())
                    .collect();
            }
            sum(&|j| v[j]) - (1.0 / 120.0 - g / 6.0 + g * g - 2.0 * g.powi(3) + g.powi(4))
        }),
    ]
}

#[test]
fn rodas4_satisfies_the_order_conditions() {
    let (alpha, gamma) = standard_form();
    // Nodes and time weights follow from α and Γ: c_i = α_i, d_i = γ_i = Σ_j γ_ij.
    for i in 0..S {
        let ai: f64 = alpha[i].iter().sum();
        let gi: f64 = gamma[i].iter().sum();
        assert!((ai - C[i]).abs() < 1e-12, "c_{i}: {ai} vs {}", C[i]);
        assert!((gi - D[i]).abs() < 1e-12, "d_{i}: {gi} vs {}", D[i]);
    }
    let b = weights(&M, &gamma);
    let mut embedded_m = M;
    embedded_m[5] = 0.0;
    let b_hat = weights(&embedded_m, &gamma);
    let solution = residuals(&b, &alpha, &gamma);
    for &(order, r) in &solution {
        if order <= 4 {
            assert!(r.abs() < 1e-12, "solution: order-{order} residual {r:e}");
        }
    }
    // The check can fail: RODAS4 is not of order 5.
    assert!(
        solution
            .iter()
            .any(|&(order, r)| order == 5 && r.abs() > 1e-6),
        "solution unexpectedly of order 5: {solution:?}"
    );
    let embedded = residuals(&b_hat, &alpha, &gamma);
    for &(order, r) in &embedded {
        if order <= 3 {
            assert!(r.abs() < 1e-12, "embedded: order-{order} residual {r:e}");
        }
    }
    assert!(
        embedded
            .iter()
            .any(|&(order, r)| order == 4 && r.abs() > 1e-6),
        "embedded solution unexpectedly of order 4"
    );
}

/// `R(z) = 1 + z bᵀ (I − z B)⁻¹ 1` with `B = α + Γ` (lower triangular), complex `z`.
fn stability(z: (f64, f64), b: &[f64; S], alpha: &[[f64; S]; S], gamma: &[[f64; S]; S]) -> f64 {
    let mul = |a: (f64, f64), c: (f64, f64)| (a.0 * c.0 - a.1 * c.1, a.0 * c.1 + a.1 * c.0);
    let div = |a: (f64, f64), c: (f64, f64)| {
        let d = c.0 * c.0 + c.1 * c.1;
        ((a.0 * c.0 + a.1 * c.1) / d, (a.1 * c.0 - a.0 * c.1) / d)
    };
    let mut x = [(0.0, 0.0); S];
    for i in 0..S {
        let mut rhs = (1.0, 0.0);
        for (j, xj) in x.iter().enumerate().take(i) {
            let zb = mul(z, (alpha[i][j] + gamma[i][j], 0.0));
            let t = mul(zb, *xj);
            rhs = (rhs.0 + t.0, rhs.1 + t.1);
        }
        let diag = (1.0 - z.0 * gamma[i][i], -z.1 * gamma[i][i]);
        x[i] = div(rhs, diag);
    }
    let mut r = (1.0, 0.0);
    for i in 0..S {
        let t = mul(z, (b[i] * x[i].0, b[i] * x[i].1));
        r = (r.0 + t.0, r.1 + t.1);
    }
    r.0.hypot(r.1)
}

#[test]
fn rodas4_is_l_stable() {
    let (alpha, gamma) = standard_form();
    let b = weights(&M, &gamma);
    // R(∞) = 1 − bᵀ B⁻¹ 1 = 0 (stiffly accurate).
    let far = stability((-1e15, 0.0), &b, &alpha, &gamma);
    assert!(far < 1e-12, "|R(-1e15)| = {far:e}");
    for k in -30..=60 {
        let y = 10f64.powf(k as f64 / 10.0);
        let r = stability((0.0, y), &b, &alpha, &gamma);
        assert!(r <= 1.0 + 1e-12, "|R({y}i)| = {r}");
    }
    // The test can fail: an explicit method's |R| grows without bound on the real axis.
    assert!(stability((-10.0, 0.0), &b, &alpha, &gamma) < 1.0);
}

/// `y' = λ (y − cos t) − sin t`: `y = cos t + (y0 − 1) e^{λt}` (Prothero–Robinson).
struct ProtheroRobinson {
    lambda: f64,
    with_jacobian: bool,
}

impl HybridSystem for ProtheroRobinson {
    fn dim(&self) -> usize {
        1
    }
    fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]) {
        dy[0] = self.lambda * (y[0] - t.cos()) - t.sin();
    }
    fn jacobian(&self, _t: f64, _y: &[f64], jac: &mut [f64]) -> bool {
        jac[0] = self.lambda;
        self.with_jacobian
    }
}

fn fixed_steps(sys: &mut ProtheroRobinson, y0: f64, t_end: f64, steps: u32) -> (f64, u64) {
    let h = t_end / steps as f64;
    let opts = RkOptions {
        rtol: 1.0,
        atol: 1e3,
        h_init: Some(h),
        h_max: h,
        ..RkOptions::new(Method::Rodas4)
    };
    let mut st = RkStepper::new(opts, 1).unwrap();
    st.set_state(0.0, &[y0]);
    st.advance_to(sys, t_end).unwrap();
    (st.y()[0], st.stats().steps)
}

#[test]
fn rodas4_converges_with_order_4_on_a_closed_form_problem() {
    // λ = −1: not stiff, the solution has the transient e^{−t}; y0 = 2.
    for with_jacobian in [true, false] {
        let mut sys = ProtheroRobinson {
            lambda: -1.0,
            with_jacobian,
        };
        let exact = 1f64.cos() + (-1f64).exp();
        let errors: Vec<f64> = [4u32, 8, 16, 32]
            .iter()
            .map(|&n| {
                let (y, steps) = fixed_steps(&mut sys, 2.0, 1.0, n);
                assert_eq!(steps, n as u64);
                (y - exact).abs()
            })
            .collect();
        for w in errors.windows(2) {
            let order = (w[0] / w[1]).log2();
            assert!(
                (3.6..4.6).contains(&order),
                "jacobian {with_jacobian}: observed order {order} ({errors:?})"
            );
        }
    }
}

#[test]
fn rodas4_takes_large_steps_on_a_very_stiff_problem() {
    // λ = −1e8: an explicit method is stable only for h < ~3e-8; RODAS4 follows cos t with
    // steps set by accuracy alone.
    let mut sys = ProtheroRobinson {
        lambda: -1e8,
        with_jacobian: true,
    };
    for steps in [10u32, 100] {
        let (y, _) = fixed_steps(&mut sys, 1.0, 10.0, steps);
        let err = (y - 10f64.cos()).abs();
        assert!(
            err < 1e-6,
            "{steps} steps of h = {}: error {err:e}",
            10.0 / steps as f64
        );
    }
    // From off the slow manifold (y0 = 2) the transient is damped in one step (R(∞) = 0).
    let (y, _) = fixed_steps(&mut sys, 2.0, 10.0, 10);
    assert!((y - 10f64.cos()).abs() < 1e-6, "transient not damped: {y}");
    // Adaptive, at rtol 1e-8: few steps, error at the tolerance's scale.
    let mut st = RkStepper::new(
        RkOptions {
            rtol: 1e-8,
            atol: 1e-10,
            ..RkOptions::new(Method::Rodas4)
        },
        1,
    )
    .unwrap();
    st.set_state(0.0, &[1.0]);
    st.advance_to(&mut sys, 10.0).unwrap();
    let err = (st.y()[0] - 10f64.cos()).abs();
    assert!(err < 1e-7, "adaptive error {err:e}");
    assert!(st.stats().steps < 2000, "{} steps", st.stats().steps);
    // DOP853 cannot do this within the same budget (stability-limited steps).
    let mut explicit = RkStepper::new(
        RkOptions {
            rtol: 1e-8,
            atol: 1e-10,
            max_steps: 100_000,
            ..RkOptions::new(Method::Dop853)
        },
        1,
    )
    .unwrap();
    explicit.set_state(0.0, &[1.0]);
    assert!(explicit.advance_to(&mut sys, 10.0).is_err());
}

/// A stiff linear oscillator with a contact guard: `x'' = −ω² x − 2ζω x' + 1` with a guard
/// `x − x_c`; the crossing time follows from the closed form.
struct Oscillator {
    omega: f64,
    zeta: f64,
    x_c: f64,
    crossed: Option<f64>,
}

impl HybridSystem for Oscillator {
    fn dim(&self) -> usize {
        2
    }
    fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) {
        dy[0] = y[1];
        dy[1] = 1.0 - self.omega * self.omega * y[0] - 2.0 * self.zeta * self.omega * y[1];
    }
    fn guard_count(&self) -> usize {
        usize::from(self.crossed.is_none())
    }
    fn guards(&self, _t: f64, y: &[f64], g: &mut [f64]) {
        g[0] = self.x_c - y[0];
    }
    fn on_event(&mut self, t: f64, _y: &mut [f64], _index: usize) {
        self.crossed = Some(t);
    }
}

#[test]
fn rodas4_locates_events_on_its_dense_output() {
    // Undamped: x = (1 − cos ωt)/ω², crossing x_c = 0.5/ω² at ωt = π/3.
    let omega = 1e3;
    let mut sys = Oscillator {
        omega,
        zeta: 0.0,
        x_c: 0.5 / (omega * omega),
        crossed: None,
    };
    let mut st = RkStepper::new(
        RkOptions {
            rtol: 1e-10,
            atol: 1e-16,
            ..RkOptions::new(Method::Rodas4)
        },
        2,
    )
    .unwrap();
    st.set_state(0.0, &[0.0, 0.0]);
    st.advance_to(&mut sys, 0.01).unwrap();
    let t_c = sys.crossed.expect("the crossing is found");
    let expected = std::f64::consts::FRAC_PI_3 / omega;
    assert!(
        (t_c - expected).abs() < 1e-9 * expected.max(1e-3),
        "event at {t_c:e}, closed form {expected:e}"
    );
    assert_eq!(st.stats().events, 1);
}

/// `y' = J y` with `J = [[0, I], [A, B]]` (or any `J` given), row-major.
struct Linear {
    jac: Vec<f64>,
}

impl HybridSystem for Linear {
    fn dim(&self) -> usize {
        (self.jac.len() as f64).sqrt().round() as usize
    }
    fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) {
        let n = y.len();
        for (i, d) in dy.iter_mut().enumerate() {
            *d = (0..n).map(|j| self.jac[i * n + j] * y[j]).sum();
        }
    }
    fn jacobian(&self, _t: f64, _y: &[f64], jac: &mut [f64]) -> bool {
        jac.copy_from_slice(&self.jac);
        true
    }
}

/// A deterministic pseudo-random number in `[-1, 1)` (64-bit LCG, Knuth's MMIX constants).
fn uniform(state: &mut u64) -> f64 {
    *state = state
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    (*state >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

/// `‖E x − b‖∞ / (‖E‖∞ ‖x‖∞ + ‖b‖∞)` with `E = I/(hγ) − J` formed explicitly.
fn relative_residual(jac: &[f64], h: f64, x: &[f64], b: &[f64]) -> f64 {
    let n = x.len();
    let (mut worst, mut norm_e) = (0.0f64, 0.0f64);
    for i in 0..n {
        let (mut r, mut row) = (-b[i], 0.0);
        for j in 0..n {
            let e = if i == j { 1.0 / (h * GAMMA) } else { 0.0 } - jac[i * n + j];
            r += e * x[j];
            row += e.abs();
        }
        worst = worst.max(r.abs());
        norm_e = norm_e.max(row);
    }
    let inf = |v: &[f64]| v.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    worst / (norm_e * inf(x) + inf(b))
}

#[test]
fn the_schur_complement_solves_e_of_a_second_order_system() {
    let m = 7;
    let n = 2 * m;
    let mut state = 1u64;
    // `A` ~ −1e6 (stiff: hγ·√|A| ≫ 1 at h = 1e-2), `B` ~ −1e2; random couplings.
    let mut jac = vec![0.0; n * n];
    for i in 0..m {
        jac[i * n + m + i] = 1.0;
        for l in 0..m {
            jac[(m + i) * n + l] = 1e6 * uniform(&mut state) - if i == l { 3e6 } else { 0.0 };
            jac[(m + i) * n + m + l] = 1e2 * uniform(&mut state);
        }
    }
    for (h, reduced) in [(1e-2, true), (1e-7, true)] {
        let sys = Linear { jac: jac.clone() };
        let mut li = LinearlyImplicit::new(n);
        let y = vec![0.0; n];
        li.linearise(&sys, 0.0, &y, &y, 1.0, &mut SolverStats::default());
        assert_eq!(li.uses_schur_complement(), reduced);
        assert!(li.factor(h));
        let b: Vec<f64> = (0..n).map(|_| uniform(&mut state)).collect();
        let mut x = b.clone();
        li.solve(&mut x);
        let r = relative_residual(&jac, h, &x, &b);
        assert!(r < 1e-14, "h = {h:e}: relative residual {r:e}");
    }
    // The test can fail: one entry off the `[0, I]` pattern takes the full LU, and the
    // reduced solve of the Jacobian without that entry does not solve this `E`.
    let mut off = jac.clone();
    off[1] = 1e3;
    let sys = Linear { jac: off.clone() };
    let mut li = LinearlyImplicit::new(n);
    let y = vec![0.0; n];
    li.linearise(&sys, 0.0, &y, &y, 1.0, &mut SolverStats::default());
    assert!(!li.uses_schur_complement());
    assert!(li.factor(1e-2));
    let b: Vec<f64> = (0..n).map(|_| uniform(&mut state)).collect();
    let mut x = b.clone();
    li.solve(&mut x);
    assert!(relative_residual(&off, 1e-2, &x, &b) < 1e-14);
    let mut reduced = LinearlyImplicit::new(n);
    reduced.linearise(
        &Linear { jac },
        0.0,
        &y,
        &y,
        1.0,
        &mut SolverStats::default(),
    );
    assert!(reduced.factor(1e-2));
    let mut x = b.clone();
    reduced.solve(&mut x);
    assert!(relative_residual(&off, 1e-2, &x, &b) > 1e-8);
}

#[test]
fn rodas4_with_the_schur_complement_matches_a_coupled_oscillator() {
    // x'' = −K x − c K x', K = [[2, −1], [−1, 2]]: modes (1, 1)/√2 with λ = 1 and (1, −1)/√2
    // with λ = 3, each q'' + cλ q' + λ q = 0. From x = (1, 0), x' = 0 both modal
    // amplitudes start at 1/√2.
    let c = 0.1;
    let k = [[2.0, -1.0], [-1.0, 2.0]];
    let mut jac = vec![0.0; 16];
    for i in 0..2 {
        jac[i * 4 + 2 + i] = 1.0;
        for l in 0..2 {
            jac[(2 + i) * 4 + l] = -k[i][l];
            jac[(2 + i) * 4 + 2 + l] = -c * k[i][l];
        }
    }
    let mut sys = Linear { jac };
    let modal = |lambda: f64, t: f64| {
        let sigma = 0.5 * c * lambda;
        let wd = (lambda - sigma * sigma).sqrt();
        let q0 = std::f64::consts::FRAC_1_SQRT_2;
        (-sigma * t).exp() * q0 * ((wd * t).cos() + sigma / wd * (wd * t).sin())
    };
    let t_end = 10.0;
    let (q1, q2) = (modal(1.0, t_end), modal(3.0, t_end));
    let exact = [
        (q1 + q2) * std::f64::consts::FRAC_1_SQRT_2,
        (q1 - q2) * std::f64::consts::FRAC_1_SQRT_2,
    ];
    let mut st = RkStepper::new(
        RkOptions {
            rtol: 1e-10,
            atol: 1e-12,
            ..RkOptions::new(Method::Rodas4)
        },
        4,
    )
    .unwrap();
    st.set_state(0.0, &[1.0, 0.0, 0.0, 0.0]);
    st.advance_to(&mut sys, t_end).unwrap();
    for (got, want) in st.y()[..2].iter().zip(exact) {
        assert!((got - want).abs() < 1e-8, "x = {got}, closed form {want}");
    }
}
