//! Generalised forces of the tooth friction of a Model-1 mesh ([`crate::model::train::friction`]).

use super::GearTrain;

impl GearTrain {
    /// Adds `−a_n F_n + Σ_j δ_j (w0_j b0 + w1_j b1)` of mesh n to the generalised force `acc`:
    /// the normal force (mesh damping included) as in [`GearTrain::rhs`], plus the friction of
    /// every pair in drive contact, `δ_j = S − e − g_j` its elastic deflection (eq. 4.44: the
    /// friction is μ times the elastic pair force, `N_i = Γ_i k_i δ`).
    pub(super) fn add_friction_mesh_force(&self, n: usize, t: f64, y: &[f64], acc: &mut [f64]) {
        let force = self.mesh_force(n, t, y, None);
        let mesh = &self.meshes[n];
        for (i, a) in mesh.a.iter().enumerate() {
            acc[i] -= a * force;
        }
        let fr = mesh.friction.as_ref().expect("a friction mesh");
        let p = mesh.clock.phase_at(t);
        let r = mesh.local(p);
        let base = self.deflection(n, y).0 - mesh.ste_at(p).0;
        for (j, flag) in mesh.flags.iter().enumerate() {
            if !flag.touches_drive() {
                continue;
            }
            let (Some(law), Some(sf)) = (mesh.law(j), fr.intervals[mesh.interval][j]) else {
                continue;
            };
            let delta = base - law.g(r);
            let (w0, w1) = sf.weights(r);
            let (f0, f1) = (w0 * delta, w1 * delta);
            for (i, (b0, b1)) in fr.b0.iter().zip(&fr.b1).enumerate() {
                acc[i] += f0 * b0 + f1 * b1;
            }
        }
    }

    /// Total friction force of mesh n on the pinion along the sliding direction `ê_s`, N
    /// (`Σ_j w0_j δ_j`; 0 for a mesh without friction).
    pub fn friction_force(&self, n: usize, t: f64, y: &[f64]) -> f64 {
        let mesh = &self.meshes[n];
        let Some(fr) = &mesh.friction else {
            return 0.0;
        };
        let p = mesh.clock.phase_at(t);
        let r = mesh.local(p);
        let base = self.deflection(n, y).0 - mesh.ste_at(p).0;
        mesh.flags
            .iter()
            .enumerate()
            .filter(|(_, f)| f.touches_drive())
            .filter_map(|(j, _)| {
                let law = mesh.law(j)?;
                let sf = fr.intervals[mesh.interval][j]?;
                Some(sf.weights(r).0 * (base - law.g(r)))
            })
            .sum()
    }
}
