//! An independent implementation of the purely rotational idler of Liu (2007) eq. (2.7), with
//! the ground couplings `k_s`, written from the notes (`models-liu-parker-2007.md` §1.2):
//!
//! `M ü + K_b u + [F_1, F_1 − F_2, −F_2]ᵀ = [T_1/r_1, 0, T_3/r_3]ᵀ`, `u_i = r_i θ_i` (Liu's
//! signs), `M = diag(I_i/r_i²)`, `K_b = diag(k_s1/r_1², 0, k_s3/r_3²)`,
//! `z_1 = u_1 + u_2`, `z_2 = −u_2 − u_3`, `F_j = H_j (k_j(p) z_j + c ż_j)`,
//! rectangular `k_j` of `docs/model.md` at the common mesh phase `p = f_m t` (+ φ for mesh 2).

#![allow(dead_code)]

use geardyn::solve::HybridSystem;

#[derive(Debug, Clone)]
pub struct Idler3 {
    pub m: [f64; 3],
    pub kb: [f64; 3],
    pub load: [f64; 3],
    pub f_mesh: f64,
    pub phase: [f64; 2],
    pub k: [(f64, f64, f64); 2],
    pub c: f64,
    pub next: [i64; 2],
    pub contact: [bool; 2],
}

impl Idler3 {
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        inertia: [f64; 3],
        radius: [f64; 3],
        ground: [f64; 3],
        t1: f64,
        f_mesh: f64,
        mesh: [(f64, f64, f64); 2],
        damping: f64,
        phase2: f64,
    ) -> Idler3 {
        let t3 = -t1 * radius[2] / radius[0];
        let mut s = Idler3 {
            m: [0, 1, 2].map(|i| inertia[i] / radius[i].powi(2)),
            kb: [0, 1, 2].map(|i| ground[i] / radius[i].powi(2)),
            load: [t1 / radius[0], 0.0, t3 / radius[2]],
            f_mesh,
            phase: [0.0, phase2],
            k: mesh.map(|(mean, eps, c)| {
                let f = c - c.floor();
                let low = mean * (1.0 - f * eps);
                (f, low, low + eps * mean)
            }),
            c: damping,
            next: [0, 0],
            contact: [true, true],
        };
        for j in 0..2 {
            let mut b = 2 * s.phase[j].floor() as i64;
            while s.boundary(j, b) <= s.phase[j] {
                b += 1;
            }
            s.next[j] = b;
        }
        s
    }

    fn boundary(&self, j: usize, b: i64) -> f64 {
        let cycle = b.div_euclid(2) as f64;
        if b.rem_euclid(2) == 0 {
            cycle
        } else {
            cycle + 1.0 - self.k[j].0
        }
    }

    fn stiffness(&self, j: usize) -> f64 {
        if self.next[j].rem_euclid(2) == 1 {
            self.k[j].1
        } else {
            self.k[j].2
        }
    }

    pub fn dte(y: &[f64]) -> [f64; 2] {
        [y[0] + y[1], -y[1] - y[2]]
    }

    /// Static state with the mean stiffnesses: `(K_b + Σ k̄ d dᵀ) u = F_T` (3 × 3 solve).
    pub fn static_state(&self) -> [f64; 6] {
        let mean = |j: usize| {
            let (f, lo, hi) = self.k[j];
            lo * (1.0 - f) + hi * f
        };
        let (k1, k2) = (mean(0), mean(1));
        let k = nalgebra::Matrix3::new(
            self.kb[0] + k1,
            k1,
            0.0,
            k1,
            k1 + k2,
            k2,
            0.0,
            k2,
            self.kb[2] + k2,
        );
        let u = k.lu().solve(&nalgebra::Vector3::from(self.load)).unwrap();
        [u[0], u[1], u[2], 0.0, 0.0, 0.0]
    }

    fn forces(&self, y: &[f64]) -> [f64; 2] {
        let z = Self::dte(y);
        let zd = Self::dte(&y[3..]);
        [0, 1].map(|j| {
            if self.contact[j] {
                self.stiffness(j) * z[j] + self.c * zd[j]
            } else {
                0.0
            }
        })
    }
}

impl HybridSystem for Idler3 {
    fn dim(&self) -> usize {
        6
    }

    fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) {
        let [f1, f2] = self.forces(y);
        let mesh = [f1, f1 - f2, -f2];
        for i in 0..3 {
            dy[i] = y[3 + i];
            dy[3 + i] = (self.load[i] - self.kb[i] * y[i] - mesh[i]) / self.m[i];
        }
    }

    fn guard_count(&self) -> usize {
        2
    }

    fn guards(&self, _t: f64, y: &[f64], g: &mut [f64]) {
        let z = Self::dte(y);
        for j in 0..2 {
            g[j] = if self.contact[j] { z[j] } else { -z[j] };
        }
    }

    fn next_stop(&self) -> f64 {
        (0..2)
            .map(|j| (self.boundary(j, self.next[j]) - self.phase[j]) / self.f_mesh)
            .fold(f64::INFINITY, f64::min)
    }

    fn on_stop(&mut self, t: f64, _y: &mut [f64]) {
        for j in 0..2 {
            if (self.boundary(j, self.next[j]) - self.phase[j]) / self.f_mesh <= t {
                self.next[j] += 1;
            }
        }
    }

    fn on_event(&mut self, _t: f64, _y: &mut [f64], index: usize) {
        self.contact[index] = !self.contact[index];
    }
}
