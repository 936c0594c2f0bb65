//! Gauss–Legendre quadrature: `n` points integrate polynomials of degree `2n − 1` exactly and
//! converge exponentially for the analytic tooth-beam integrands.

use std::f64::consts::PI;

/// Nodes and weights on `[−1, 1]`.
#[derive(Debug, Clone, PartialEq)]
pub struct GaussLegendre {
    nodes: Vec<f64>,
    weights: Vec<f64>,
}

impl GaussLegendre {
    /// Nodes by Newton's method on `P_n` from Tricomi's start `cos(π(i − ¼)/(n + ½))`
    /// (Abramowitz & Stegun 25.4.29 weights `2/((1 − x²) P_n'(x)²)`).
    pub fn new(n: usize) -> Self {
        assert!(n >= 1, "at least one Gauss–Legendre point");
        let mut nodes = vec![0.0; n];
        let mut weights = vec![0.0; n];
        for i in 0..n.div_ceil(2) {
            let mut x = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut dp = 1.0;
            for _ in 0..100 {
                let (p, d) = legendre(n, x);
                dp = d;
                let dx = p / d;
                x -= dx;
                if dx.abs() < 1e-16 {
                    break;
                }
            }
            let (_, d) = legendre(n, x);
            dp = if d != 0.0 { d } else { dp };
            let w = 2.0 / ((1.0 - x * x) * dp * dp);
            nodes[i] = -x;
            nodes[n - 1 - i] = x;
            weights[i] = w;
            weights[n - 1 - i] = w;
        }
        GaussLegendre { nodes, weights }
    }

    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// `(node, weight)` on `[−1, 1]`, ascending.
    pub fn points(&self) -> impl Iterator<Item = (f64, f64)> + '_ {
        self.nodes.iter().copied().zip(self.weights.iter().copied())
    }

    /// `∫_a^b f`.
    pub fn integrate<F: FnMut(f64) -> f64>(&self, a: f64, b: f64, mut f: F) -> f64 {
        let half = 0.5 * (b - a);
        let mid = 0.5 * (a + b);
        self.nodes
            .iter()
            .zip(&self.weights)
            .map(|(&x, &w)| w * f(mid + half * x))
            .sum::<f64>()
            * half
    }
}

/// `(P_n(x), P_n'(x))` by the three-term recurrence.
fn legendre(n: usize, x: f64) -> (f64, f64) {
    let (mut p0, mut p1) = (1.0, x);
    for k in 2..=n {
        let k = k as f64;
        let p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
    }
    if n == 0 {
        return (1.0, 0.0);
    }
    let d = n as f64 * (x * p1 - p0) / (x * x - 1.0);
    (p1, d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_for_degree_2n_minus_1() {
        for n in [1usize, 2, 3, 5, 8, 16, 32, 64] {
            let q = GaussLegendre::new(n);
            let deg = 2 * n - 1;
            // ∫_0^2 x^deg dx = 2^(deg+1)/(deg+1)
            let got = q.integrate(0.0, 2.0, |x| x.powi(deg as i32));
            let want = 2f64.powi(deg as i32 + 1) / (deg as f64 + 1.0);
            assert!((got / want - 1.0).abs() < 1e-13, "n = {n}: {got} vs {want}");
            let wsum: f64 = q.weights.iter().sum();
            assert!((wsum - 2.0).abs() < 1e-13);
        }
    }

    #[test]
    fn converges_on_analytic_integrand() {
        // ∫_0^1 e^x = e − 1
        let q = GaussLegendre::new(12);
        assert!((q.integrate(0.0, 1.0, f64::exp) - (1f64.exp() - 1.0)).abs() < 1e-15);
    }
}
