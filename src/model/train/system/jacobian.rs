//! The parts of the frozen mode's Jacobian that do not change with the mode, so that
//! [`crate::solve::HybridSystem::jacobian`] (once per RODAS4 step) costs `O(DOF²)` instead of
//! the `O(DOF³)` products `M̂⁻¹K` and `M̂⁻¹C`, which on large trains cost more than the
//! step's LU.
//!
//! `K = K̂_b + Σ_n k_n a_n a_nᵀ` (and `C` alike with `c_n`), so
//! `M̂⁻¹K = M̂⁻¹K̂_b + Σ_n k_n (M̂⁻¹a_n) a_nᵀ`: the first term and each `M̂⁻¹a_n` are formed
//! once, and a mesh adds a rank-one term on the few coordinates its line of action touches
//! (the nonzero entries of `a_n`).
//!
//! On a free train the products are formed through the physical mass instead of `M̂⁻¹`
//! ([`JacobianParts::through_physical_mass`], issue 37), and the exact propagator's segment
//! matrices are built from them too (`lti.rs`).

use nalgebra::{DMatrix, DVector};

use super::super::assembly::Assembly;

/// One mesh: `M̂⁻¹a_n` and the nonzero entries `(l, a_n[l])` of `a_n`.
#[derive(Debug, Clone)]
struct MeshColumn {
    minv_a: Vec<f64>,
    support: Vec<(usize, f64)>,
}

/// `M̂⁻¹K̂_b`, `M̂⁻¹Ĉ` (row-major `m × m`) and the mesh columns.
#[derive(Debug, Clone, Default)]
pub(super) struct JacobianParts {
    m: usize,
    minv_k: Vec<f64>,
    minv_c: Vec<f64>,
    meshes: Vec<MeshColumn>,
    /// Free trains: `M̂⁻¹F̂` per N·m of input and of load torque, formed with the products
    /// above through the physical mass ([`JacobianParts::through_physical_mass`]).
    torque_columns: Option<[Vec<f64>; 2]>,
}

impl JacobianParts {
    /// From `M̂⁻¹`, `K̂_b`, `Ĉ` (row-major `m × m`) and the meshes' `a_n`.
    pub(super) fn new<'a>(
        m: usize,
        minv: &[f64],
        k_b: &[f64],
        c: &[f64],
        mesh_vectors: impl Iterator<Item = &'a [f64]>,
    ) -> Self {
        let times = |b: &[f64]| -> Vec<f64> {
            let mut out = vec![0.0; m * m];
            for i in 0..m {
                let row = &mut out[i * m..(i + 1) * m];
                for q in 0..m {
                    let w = minv[i * m + q];
                    for (o, &v) in row.iter_mut().zip(&b[q * m..(q + 1) * m]) {
                        *o += w * v;
                    }
                }
            }
            out
        };
        let meshes = mesh_vectors
            .map(|a| MeshColumn {
                minv_a: (0..m)
                    .map(|i| (0..m).map(|q| minv[i * m + q] * a[q]).sum())
                    .collect(),
                support: a
                    .iter()
                    .copied()
                    .enumerate()
                    .filter(|&(_, v)| v != 0.0)
                    .collect(),
            })
            .collect();
        JacobianParts {
            m,
            minv_k: times(k_b),
            minv_c: times(c),
            meshes,
            torque_columns: None,
        }
    }

    /// The parts of a free train from `G = M̂⁻¹Qᵀ` formed without `M̂⁻¹`
    /// ([`crate::model::train::Reduction::inverse_mass_rows`]): `M̂⁻¹K̂_b = G K_b Q`,
    /// `M̂⁻¹Ĉ = G C_b Q + M̂⁻¹Ĉ_modal`, `M̂⁻¹a_n = G d_n` and `M̂⁻¹F̂` per N·m of input and
    /// load torque `= G f_in`, `G f_out` (physical `K_b`, `C_b`, `d_n`, `f`); `modal` is
    /// `M̂⁻¹Ĉ_modal = Φ diag(2ζω) ΦᵀM̂` (no inverse either). `physical` are the rows `d_n`
    /// (the meshes', then the back flanks' own), `reduced` the same rows `a_n = Qᵀd_n`.
    pub(super) fn through_physical_mass(
        g: &DMatrix<f64>,
        asm: &Assembly,
        q: &DMatrix<f64>,
        modal: Option<DMatrix<f64>>,
        physical: &[&DVector<f64>],
        reduced: &[&[f64]],
    ) -> Self {
        let m = q.ncols();
        let row_major =
            |x: &DMatrix<f64>| -> Vec<f64> { (0..m * m).map(|k| x[(k / m, k % m)]).collect() };
        let mut minv_c = g * &asm.c_base * q;
        if let Some(modal) = modal {
            minv_c += modal;
        }
        let meshes = (physical.iter().zip(reduced))
            .map(|(&d, a)| MeshColumn {
                minv_a: (g * d).as_slice().to_vec(),
                support: (a.iter().copied().enumerate())
                    .filter(|&(_, v)| v != 0.0)
                    .collect(),
            })
            .collect();
        JacobianParts {
            m,
            minv_k: row_major(&(g * &asm.k_base * q)),
            minv_c: row_major(&minv_c),
            meshes,
            torque_columns: Some([
                (g * &asm.input_load).as_slice().to_vec(),
                (g * &asm.output_load).as_slice().to_vec(),
            ]),
        }
    }

    /// `M̂⁻¹F̂` per N·m of input and of load torque when the parts were formed through the
    /// physical mass (free trains); the segment matrices then take every product from here.
    pub(super) fn torque_columns(&self) -> Option<&[Vec<f64>; 2]> {
        self.torque_columns.as_ref()
    }

    /// `M̂⁻¹K̂_b`, row-major.
    pub(super) fn minv_k(&self) -> &[f64] {
        &self.minv_k
    }

    /// `M̂⁻¹Ĉ`, row-major.
    pub(super) fn minv_c(&self) -> &[f64] {
        &self.minv_c
    }

    /// `M̂⁻¹a_n` of mesh `n`.
    pub(super) fn minv_a(&self, n: usize) -> &[f64] {
        &self.meshes[n].minv_a
    }

    /// `jac = [[0, I], [−M̂⁻¹K, −M̂⁻¹C]]` (row-major `2m × 2m`) with mesh `n` contributing
    /// stiffness and damping `gains[n] = (k_n, c_n)`.
    pub(super) fn fill(&self, gains: impl Iterator<Item = (f64, f64)>, jac: &mut [f64]) {
        let m = self.m;
        let n = 2 * m;
        jac.fill(0.0);
        for i in 0..m {
            jac[i * n + m + i] = 1.0;
            let row = &mut jac[(m + i) * n..(m + i + 1) * n];
            let (dk, dc) = row.split_at_mut(m);
            for (d, &v) in dk.iter_mut().zip(&self.minv_k[i * m..(i + 1) * m]) {
                *d = -v;
            }
            for (d, &v) in dc.iter_mut().zip(&self.minv_c[i * m..(i + 1) * m]) {
                *d = -v;
            }
        }
        for (mesh, (kn, cn)) in self.meshes.iter().zip(gains) {
            if kn == 0.0 && cn == 0.0 {
                continue;
            }
            for (i, &ma) in mesh.minv_a.iter().enumerate() {
                let row = &mut jac[(m + i) * n..(m + i + 1) * n];
                for &(l, al) in &mesh.support {
                    row[l] -= kn * ma * al;
                    row[m + l] -= cn * ma * al;
                }
            }
        }
    }
}
