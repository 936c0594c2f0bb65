//! Tableau checks: row sums, rooted-tree order conditions (HNW I §II.2, Butcher's theorem) of
//! the propagated, embedded and continuous solutions, and the stability polynomial on the
//! imaginary axis. Each check is also shown to fail one order higher, so it can fail at all.

use super::dense;
use super::tableau::{Tableau, DOP853, DOP853_BHH, DOP853_E5, DP5, DP5_E};
use super::Method;

/// Rooted trees up to a given order, each as (order, children indices sorted).
struct Trees {
    order: Vec<usize>,
    children: Vec<Vec<usize>>,
}

impl Trees {
    fn up_to(p: usize) -> Self {
        let mut t = Trees {
            order: vec![1],
            children: vec![vec![]],
        };
        for n in 2..=p {
            let known = t.order.len();
            let mut out = Vec::new();
            let mut cur = Vec::new();
            Self::multisets(&t.order[..known], n - 1, 0, &mut cur, &mut out);
            for ch in out {
                t.order.push(n);
                t.children.push(ch);
            }
        }
        t
    }

    /// Multisets (as nondecreasing index lists) of trees whose orders sum to `rest`.
    fn multisets(
        order: &[usize],
        rest: usize,
        min: usize,
        cur: &mut Vec<usize>,
        out: &mut Vec<Vec<usize>>,
    ) {
        if rest == 0 {
            out.push(cur.clone());
            return;
        }
        for i in min..order.len() {
            if order[i] <= rest {
                cur.push(i);
                Self::multisets(order, rest - order[i], i, cur, out);
                cur.pop();
            }
        }
    }

    fn gamma(&self, t: usize) -> f64 {
        self.order[t] as f64
            * self.children[t]
                .iter()
                .map(|&c| self.gamma(c))
                .product::<f64>()
    }

    /// Stage vector Φ_i(t) of internal weights for the `s × s` matrix `a`.
    fn phi(&self, t: usize, a: &[Vec<f64>]) -> Vec<f64> {
        let s = a.len();
        let mut v = vec![1.0; s];
        for &c in &self.children[t] {
            let pc = self.phi(c, a);
            for i in 0..s {
                v[i] *= (0..s).map(|j| a[i][j] * pc[j]).sum::<f64>();
            }
        }
        v
    }
}

fn dense_a(tab: &Tableau, s: usize) -> Vec<Vec<f64>> {
    (0..s)
        .map(|i| {
            let mut row = vec![0.0; s];
            row[..tab.a[i].len()].copy_from_slice(tab.a[i]);
            row
        })
        .collect()
}

/// Largest |Σ b_i Φ_i(t) - θ^ρ/γ| over trees of order exactly `p`.
fn residual(trees: &Trees, a: &[Vec<f64>], b: &[f64], p: usize, theta: f64) -> f64 {
    (0..trees.order.len())
        .filter(|&t| trees.order[t] == p)
        .map(|t| {
            let phi = trees.phi(t, a);
            let lhs: f64 = b.iter().zip(&phi).map(|(x, y)| x * y).sum();
            (lhs - theta.powi(p as i32) / trees.gamma(t)).abs()
        })
        .fold(0.0, f64::max)
}

fn pad(b: &[f64], s: usize) -> Vec<f64> {
    let mut v = vec![0.0; s];
    v[..b.len()].copy_from_slice(b);
    v
}

#[test]
fn tree_counts_match_oeis_a000081() {
    let t = Trees::up_to(8);
    let counts: Vec<usize> = (1..=8)
        .map(|p| t.order.iter().filter(|&&o| o == p).count())
        .collect();
    assert_eq!(counts, [1, 1, 2, 4, 9, 20, 48, 115]);
}

#[test]
fn row_sums_equal_nodes() {
    for tab in [&DP5, &DOP853] {
        for i in 0..tab.total {
            let s: f64 = tab.a[i].iter().sum();
            assert!(
                (s - tab.c[i]).abs() < 1e-14,
                "row {i}: Σa = {s}, c = {}",
                tab.c[i]
            );
        }
    }
}

/// Checks order `p` exactly (all trees ≤ p satisfied, some tree of order p+1 not) and returns
/// the residual table for printing.
fn check_order(name: &str, a: &[Vec<f64>], b: &[f64], p: usize, tol: f64) {
    let trees = Trees::up_to(p + 1);
    for q in 1..=p {
        let r = residual(&trees, a, b, q, 1.0);
        println!("{name}: order {q} residual {r:.2e}");
        assert!(r < tol, "{name}: order-{q} conditions violated by {r:e}");
    }
    let r = residual(&trees, a, b, p + 1, 1.0);
    println!("{name}: order {} residual {r:.2e} (must not vanish)", p + 1);
    assert!(r > 1e-6, "{name} unexpectedly of order {}", p + 1);
}

#[test]
fn dp5_order_conditions() {
    let a = dense_a(&DP5, 7);
    check_order("dp5 b", &a, &pad(DP5.b, 7), 5, 1e-14);
    let bhat: Vec<f64> = pad(DP5.b, 7)
        .iter()
        .zip(DP5_E)
        .map(|(b, e)| b - e)
        .collect();
    check_order("dp5 b̂", &a, &bhat, 4, 1e-14);
}

#[test]
fn dop853_order_conditions() {
    let a = dense_a(&DOP853, 12);
    check_order("dop853 b", &a, DOP853.b, 8, 1e-12);
    let b5: Vec<f64> = DOP853.b.iter().zip(DOP853_E5).map(|(b, e)| b - e).collect();
    check_order("dop853 b̂5", &a, &b5, 5, 1e-12);
    let mut b3 = vec![0.0; 12];
    for (j, w) in DOP853_BHH {
        b3[j] = w;
    }
    check_order("dop853 b̂3", &a, &b3, 3, 1e-12);
}

/// Weights `b_j(θ)` of the continuous extension, read off the (linear) dense-output build by
/// feeding unit stages with `h = 1`, `y0 = 0`.
fn dense_weights(method: Method, theta: f64) -> Vec<f64> {
    let tab = method.tableau().expect("explicit");
    let mut w = vec![0.0; tab.total];
    let mut r = vec![0.0; dense::rows(method)];
    for (j, wj) in w.iter_mut().enumerate() {
        let mut k = vec![0.0; tab.total];
        k[j] = 1.0;
        let y1 = [tab.b.get(j).copied().unwrap_or(0.0)];
        dense::build(method, 1.0, &[0.0], &y1, &k, &mut r);
        let mut out = [0.0];
        dense::eval(method, theta, &r, &mut out);
        *wj = out[0];
    }
    w
}

#[test]
fn dense_output_order_conditions() {
    for method in Method::EXPLICIT {
        let tab = method.tableau().expect("explicit");
        let p = tab.dense_order as usize;
        let a = dense_a(tab, tab.total);
        let trees = Trees::up_to(p + 1);
        let mut worst_next = 0.0f64;
        for &theta in &[0.1, 0.3, 0.5, 0.77, 1.0] {
            let w = dense_weights(method, theta);
            for q in 1..=p {
                let r = residual(&trees, &a, &w, q, theta);
                assert!(
                    r < 1e-11,
                    "{method} θ={theta}: dense order-{q} residual {r:e}"
                );
            }
            if theta < 1.0 {
                worst_next = worst_next.max(residual(&trees, &a, &w, p + 1, theta));
            }
        }
        println!(
            "{method}: dense output satisfies order {p}; order {} residual {worst_next:.2e}",
            p + 1
        );
        assert!(
            worst_next > 1e-8,
            "{method}: dense output unexpectedly of order {}",
            p + 1
        );
        // The interpolant ends on the step: b(1) = b.
        let w1 = dense_weights(method, 1.0);
        for (j, &bj) in tab.b.iter().enumerate() {
            assert!(
                (w1[j] - bj).abs() < 1e-13,
                "{method}: b_{j}(1) = {} != {bj}",
                w1[j]
            );
        }
    }
}

/// Coefficients of the stability polynomial `R(z) = Σ γ_q z^q`, `γ_q = bᵀ A^{q-1} 1`.
fn stability_polynomial(a: &[Vec<f64>], b: &[f64]) -> Vec<f64> {
    let s = b.len();
    let mut coef = vec![1.0];
    let mut v = vec![1.0; s];
    for _ in 0..s {
        coef.push(b.iter().zip(&v).map(|(x, y)| x * y).sum());
        v = (0..s)
            .map(|i| (0..s).map(|j| a[i][j] * v[j]).sum())
            .collect();
    }
    coef
}

/// |R(iy)|² via Horner in complex arithmetic.
fn abs2_on_imaginary_axis(coef: &[f64], y: f64) -> f64 {
    let (mut re, mut im) = (0.0, 0.0);
    for &c in coef.iter().rev() {
        // (re + i im)(i y) + c
        let (r2, i2) = (-im * y + c, re * y);
        re = r2;
        im = i2;
    }
    re * re + im * im
}

/// End of the imaginary-axis stability interval: first y > 0 where |R(iy)| > 1 (scan, then
/// bisection). Values below 1e-2 would mean "unstable near the origin".
fn imaginary_stability_limit(coef: &[f64]) -> f64 {
    let unstable = |y: f64| abs2_on_imaginary_axis(coef, y) > 1.0 + 1e-13;
    let mut y = 1e-3;
    while !unstable(y) && y < 20.0 {
        y += 1e-3;
    }
    let (mut lo, mut hi) = (y - 1e-3, y);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if unstable(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    lo
}

#[test]
fn imaginary_axis_stability() {
    // Oracle for the procedure: classical RK4 is stable on [-2√2 i, 2√2 i].
    let rk4_a = vec![
        vec![0.0; 4],
        vec![0.5, 0.0, 0.0, 0.0],
        vec![0.0, 0.5, 0.0, 0.0],
        vec![0.0, 0.0, 1.0, 0.0],
    ];
    let rk4 = stability_polynomial(&rk4_a, &[1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0]);
    let lim = imaginary_stability_limit(&rk4);
    println!("rk4: |R(iy)| <= 1 for y <= {lim:.6}");
    assert!((lim - 2.0 * 2f64.sqrt()).abs() < 1e-9);

    // Taylor coefficients up to the order must be 1/q!, a check on the polynomial itself.
    let dp5 = stability_polynomial(&dense_a(&DP5, 6), DP5.b);
    let dop853 = stability_polynomial(&dense_a(&DOP853, 12), DOP853.b);
    let mut fact = 1.0;
    for q in 0..=8 {
        if q > 0 {
            fact *= q as f64;
        }
        if q <= 5 {
            assert!((dp5[q] * fact - 1.0).abs() < 1e-13, "dp5 γ_{q}");
        }
        assert!((dop853[q] * fact - 1.0).abs() < 1e-10, "dop853 γ_{q}");
    }
    let l_dp5 = imaginary_stability_limit(&dp5);
    let l_dop853 = imaginary_stability_limit(&dop853);
    println!("dp5: |R(iy)| <= 1 for y <= {l_dp5:.6}");
    println!("dop853: |R(iy)| <= 1 for y <= {l_dop853:.6}");
    // Recorded values, cross-checked for DP5 against R(z) = Σ_{q≤5} z^q/q! + z^6/600
    // evaluated in numpy; the undamped step limit is h·ω ≤ this bound.
    assert!((l_dp5 - DP5_IMAG_LIMIT).abs() < 1e-5, "dp5 limit {l_dp5}");
    assert!(
        (l_dop853 - DOP853_IMAG_LIMIT).abs() < 1e-5,
        "dop853 limit {l_dop853}"
    );
}

const DP5_IMAG_LIMIT: f64 = 0.997189;
const DOP853_IMAG_LIMIT: f64 = 5.960360;
