//! Static equilibrium at frozen mesh phases, with tooth friction (Liu 2007 eq. 4.40).

use nalgebra::{DMatrix, DVector};

use super::{GearTrain, Stiffness};
use crate::scene::ContactLaw;

/// Static state of the elastic coordinates at frozen mesh phases.
#[derive(Debug, Clone, PartialEq)]
pub struct FrozenStatics {
    /// Elastic coordinates ξ.
    pub xi: Vec<f64>,
    /// Per mesh: total normal force `Σ_j N_j`, N.
    pub mesh_force: Vec<f64>,
    /// Per mesh: friction force on the pinion `Σ_j μ sgn(v_j) N_j`, N.
    pub friction_force: Vec<f64>,
}

/// One engaged slot at the frozen phase: stiffness, gap (STE included), and the column of its
/// generalised force per metre of deflection, `k a_n − (w0 b0 + w1 b1)` (eq. 4.44's `K + L`).
struct FrozenSlot {
    mesh: usize,
    k: f64,
    gap: f64,
    column: DVector<f64>,
    /// Friction force on the pinion per metre of deflection.
    w0: f64,
}

impl GearTrain {
    /// The static equilibrium at the mesh phases of time `t`, held fixed (zero speed):
    /// `K̂_b ξ + Σ_n Σ_j k_j (a_n − μ sgn(v_j) t_j)(a_nᵀξ − e_n − g_j) = F̂`.
    ///
    /// With friction the matrix is not symmetric (the `L` matrix of Liu 2007 eq. 4.44) and is
    /// solved by LU; in single contact on a gear held by the ground it gives eq. (4.40),
    /// `N = T_1/(r_1 − sgn(v) μ l)`. Pairs in contact by active set: start with every engaged
    /// pair, drop those pulling (negative force) unless the contact law is linear, repeat.
    /// Mesh damping does not enter (zero speed).
    pub fn frozen_equilibrium(&self, t: f64) -> Result<FrozenStatics, String> {
        let m = self.m;
        let mut slots = Vec::new();
        for (n, mesh) in self.meshes.iter().enumerate() {
            let p = mesh.clock.phase_at(t);
            let a = DVector::from_column_slice(&mesh.a);
            let e = mesh.ste_free(p).0;
            match &mesh.stiffness {
                Stiffness::Smooth {
                    mean,
                    series,
                    phase,
                } => {
                    let k = mean + series.value(mesh.contact_phase(p).0 + phase);
                    slots.push(FrozenSlot {
                        mesh: n,
                        k,
                        gap: e,
                        column: k * &a,
                        w0: 0.0,
                    })
                }
                Stiffness::Table(table) => {
                    let (index, r) = match mesh.eccentric {
                        None => table.locate(p + mesh.offset),
                        Some(_) => {
                            let (_, index, s) = mesh.locate_free(p);
                            (index, s - table.intervals[index].start)
                        }
                    };
                    let iv = &table.intervals[index];
                    for (j, law) in iv.laws.iter().enumerate() {
                        let Some(law) = law else { continue };
                        let k = law.k(r);
                        let mut column = k * &a;
                        let mut w0 = 0.0;
                        if let Some(fr) = &mesh.friction {
                            if let Some(sf) = fr.intervals[index][j] {
                                let (u0, u1) = sf.weights(r);
                                w0 = u0;
                                for i in 0..m {
                                    column[i] -= u0 * fr.b0[i] + u1 * fr.b1[i];
                                }
                            }
                        }
                        slots.push(FrozenSlot {
                            mesh: n,
                            k,
                            gap: e + law.g(r),
                            column,
                            w0,
                        });
                    }
                }
            }
        }
        let mut active = vec![true; slots.len()];
        for _ in 0..=slots.len() {
            let mut k = DMatrix::from_row_slice(m, m, &self.k_b);
            let mut rhs = DVector::from_column_slice(&self.f_ext);
            for (slot, _) in slots.iter().zip(&active).filter(|(_, &on)| on) {
                let a = DVector::from_column_slice(&self.meshes[slot.mesh].a);
                k += &slot.column * a.transpose();
                rhs += slot.gap * &slot.column;
            }
            let xi = k
                .lu()
                .solve(&rhs)
                .ok_or("no static equilibrium: the stiffness matrix at this phase is singular")?;
            let deflections: Vec<f64> = slots
                .iter()
                .map(|slot| {
                    let a = &self.meshes[slot.mesh].a;
                    let s: f64 = (0..m).map(|i| a[i] * xi[i]).sum();
                    s - slot.gap
                })
                .collect();
            let forces: Vec<f64> = slots
                .iter()
                .zip(&deflections)
                .map(|(slot, d)| slot.k * d)
                .collect();
            let mut changed = false;
            for (i, slot) in slots.iter().enumerate() {
                let linear = self.meshes[slot.mesh].contact == ContactLaw::Linear;
                if active[i] && forces[i] < 0.0 && !linear {
                    active[i] = false;
                    changed = true;
                }
            }
            if !changed {
                let mut mesh_force = vec![0.0; self.meshes.len()];
                let mut friction_force = vec![0.0; self.meshes.len()];
                for (i, slot) in slots.iter().enumerate().filter(|(i, _)| active[*i]) {
                    mesh_force[slot.mesh] += forces[i];
                    friction_force[slot.mesh] += slot.w0 * deflections[i];
                }
                return Ok(FrozenStatics {
                    xi: xi.as_slice().to_vec(),
                    mesh_force,
                    friction_force,
                });
            }
        }
        Err("no static equilibrium: the active set of tooth pairs does not settle".into())
    }
}
