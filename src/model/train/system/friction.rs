//! Generalised forces of the tooth friction of a Model-1 mesh ([`crate::model::train::friction`]).

use super::{GearTrain, SlotContact};

impl GearTrain {
    /// Adds `−a_n F_n + Σ_j μ sgn(v_j) N_j (b0 + l_j b1)` of mesh n to the generalised force
    /// `acc` (the normal force, mesh damping included, as in [`GearTrain::rhs`], plus the
    /// friction of every drive-side pair; `N_j` is the pair's elastic force, eq. 4.44).
    pub(super) fn add_friction_mesh_force(&self, n: usize, t: f64, y: &[f64], acc: &mut [f64]) {
        let mesh = &self.meshes[n];
        let fr = mesh.friction.as_ref().expect("a friction mesh");
        let mut slots = self.slot_scratch.borrow_mut();
        slots.clear();
        slots.resize(mesh.flags.len(), 0.0);
        let force = self.mesh_force(n, t, y, Some(&mut slots));
        for (i, a) in mesh.a.iter().enumerate() {
            acc[i] -= a * force;
        }
        let r = mesh.local(mesh.clock.phase_at(t));
        for (j, &normal) in slots.iter().enumerate() {
            if mesh.flags[j] != SlotContact::Drive {
                continue;
            }
            let Some(law) = fr.intervals[mesh.interval][j] else {
                continue;
            };
            let f = law.signed_coefficient * normal;
            let arm = law.arm(r);
            for (i, (b0, b1)) in fr.b0.iter().zip(&fr.b1).enumerate() {
                acc[i] += f * (b0 + arm * b1);
            }
        }
    }

    /// Total friction force of mesh n on the pinion along the sliding direction `ê_s`, N
    /// (`Σ_j μ sgn(v_j) N_j`; 0 for a mesh without friction).
    pub fn friction_force(&self, n: usize, t: f64, y: &[f64]) -> f64 {
        let mesh = &self.meshes[n];
        let Some(fr) = &mesh.friction else {
            return 0.0;
        };
        let mut slots = vec![0.0; mesh.flags.len()];
        self.mesh_force(n, t, y, Some(&mut slots));
        slots
            .iter()
            .enumerate()
            .filter(|(j, _)| mesh.flags[*j] == SlotContact::Drive)
            .filter_map(|(j, &normal)| {
                fr.intervals[mesh.interval][j].map(|l| l.signed_coefficient * normal)
            })
            .sum()
    }
}
