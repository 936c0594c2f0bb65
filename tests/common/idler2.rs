//! An independent implementation of the 2-DOF idler of Liu (2007) Ch. 3, eq. (3.1)–(3.2),
//! written from the notes (`models-liu-parker-2007.md` §2.1) and not from `src/model/train`:
//!
//! `M ẍ + [F_1, F_2]ᵀ = [T, T]ᵀ`,  `M = 1/Σm [[(m2+m3)m1, m1m3], [m1m3, (m1+m2)m3]]`,
//! `F_j = H_j (k_j(p_j) x_j + c_j ẋ_j)`, `H_j = 1` for `x_j > 0` else 0, `m_i = I_i/r_i²`,
//! `T = T_1/r_1`, rectangular `k_j` as specified in `docs/model.md` (low on `[0, 1−f)`,
//! high on `[1−f, 1)` of `s = frac(p)`), `p_1 = f_m t`, `p_2 = φ + f_m t`.

#![allow(dead_code)]

use geardyn::solve::HybridSystem;

#[derive(Debug, Clone)]
pub struct Idler2 {
    pub m: [[f64; 2]; 2],
    pub minv: [[f64; 2]; 2],
    pub force: f64,
    pub f_mesh: f64,
    pub phase: [f64; 2],
    pub k: [(f64, f64, f64); 2], // (frac f, low, high)
    pub c: [f64; 2],
    /// Index of the next boundary of each mesh: boundaries at p = b/2-ish, see `boundary`.
    pub next: [i64; 2],
    pub contact: [bool; 2],
}

impl Idler2 {
    /// `inertia`, `radius`: the three gears; `mean, ratio, c` per mesh; `damping` per mesh.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        inertia: [f64; 3],
        radius: [f64; 3],
        input_torque: f64,
        f_mesh: f64,
        mesh: [(f64, f64, f64); 2],
        damping: [f64; 2],
        phase2: f64,
    ) -> Idler2 {
        let m: Vec<f64> = (0..3).map(|i| inertia[i] / radius[i].powi(2)).collect();
        let sum = m[0] + m[1] + m[2];
        let mm = [
            [(m[1] + m[2]) * m[0] / sum, m[0] * m[2] / sum],
            [m[0] * m[2] / sum, (m[0] + m[1]) * m[2] / sum],
        ];
        let det = mm[0][0] * mm[1][1] - mm[0][1] * mm[1][0];
        let minv = [
            [mm[1][1] / det, -mm[0][1] / det],
            [-mm[1][0] / det, mm[0][0] / det],
        ];
        let k = mesh.map(|(mean, eps, c)| {
            let f = c - c.floor();
            let low = mean * (1.0 - f * eps);
            (f, low, low + eps * mean)
        });
        let mut s = Idler2 {
            m: mm,
            minv,
            force: input_torque / radius[0],
            f_mesh,
            phase: [0.0, phase2],
            k,
            c: damping,
            next: [0, 0],
            contact: [true, true],
        };
        for j in 0..2 {
            // First boundary strictly after p(0).
            let mut b = 2 * s.phase[j].floor() as i64;
            while s.boundary(j, b) <= s.phase[j] {
                b += 1;
            }
            s.next[j] = b;
        }
        s
    }

    /// Boundary b of mesh j in mesh phase: even b → integer cycle start, odd → 1 − f.
    fn boundary(&self, j: usize, b: i64) -> f64 {
        let cycle = b.div_euclid(2) as f64;
        if b.rem_euclid(2) == 0 {
            cycle
        } else {
            cycle + 1.0 - self.k[j].0
        }
    }

    /// Stiffness of mesh j in the segment ending at boundary `next[j]`.
    pub fn stiffness(&self, j: usize) -> f64 {
        // Segment before an odd boundary (1−f) is [cycle, 1−f): low; before an even one: high.
        if self.next[j].rem_euclid(2) == 1 {
            self.k[j].1
        } else {
            self.k[j].2
        }
    }

    /// Static mean state: `diag(k̄) x = [T, T]`.
    pub fn static_state(&self) -> [f64; 4] {
        let mean = |j: usize| {
            let (f, lo, hi) = self.k[j];
            lo * (1.0 - f) + hi * f
        };
        [self.force / mean(0), self.force / mean(1), 0.0, 0.0]
    }

    pub fn mesh_force(&self, j: usize, y: &[f64]) -> f64 {
        if self.contact[j] {
            self.stiffness(j) * y[j] + self.c[j] * y[2 + j]
        } else {
            0.0
        }
    }
}

impl HybridSystem for Idler2 {
    fn dim(&self) -> usize {
        4
    }

    fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) {
        let f = [
            self.force - self.mesh_force(0, y),
            self.force - self.mesh_force(1, y),
        ];
        dy[0] = y[2];
        dy[1] = y[3];
        dy[2] = self.minv[0][0] * f[0] + self.minv[0][1] * f[1];
        dy[3] = self.minv[1][0] * f[0] + self.minv[1][1] * f[1];
    }

    fn guard_count(&self) -> usize {
        2
    }

    fn guards(&self, _t: f64, y: &[f64], g: &mut [f64]) {
        for j in 0..2 {
            g[j] = if self.contact[j] { y[j] } else { -y[j] };
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

    fn on_event(&mut self, _t: f64, y: &mut [f64], index: usize) {
        y[index] = 0.0;
        self.contact[index] = !self.contact[index];
    }
}
