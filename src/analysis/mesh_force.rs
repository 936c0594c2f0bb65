//! The dynamic mesh force of a steady state, per mesh: its peak, its RMS about the mean and the
//! dynamic factor, peak over the static mesh force (the quantity of ISO 6336-1's `K_v`, here
//! computed, not estimated). One definition for `sweep` and `periodic`; harmonic balance
//! computes the same three from its Fourier coefficients (`analysis::hb`), which is what the
//! tests compare them with.

use super::shooting::PeriodicOrbit;
use crate::model::{response_period, Drivetrain};
use crate::scene::Scene;
use crate::with_drivetrain;

/// Peak, RMS and dynamic factor of one mesh's force.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForceStatistics {
    /// Largest |mesh force| over the samples, N.
    pub peak_force: f64,
    /// RMS of the mesh force with its mean removed, N.
    pub force_rms: f64,
    /// `peak_force / |static mesh force|`.
    pub dynamic_factor: f64,
}

impl ForceStatistics {
    /// Of a mesh force sampled evenly over whole periods of the response (so the mean and the
    /// RMS carry no leakage); `static_force` is the mesh's static force, N.
    pub fn of(force: &[f64], static_force: f64) -> ForceStatistics {
        let n = force.len() as f64;
        let mean = force.iter().sum::<f64>() / n;
        let rms = (force.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt();
        let peak = force.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        ForceStatistics {
            peak_force: peak,
            force_rms: rms,
            dynamic_factor: peak / static_force.abs(),
        }
    }
}

/// One mesh on a periodic orbit.
#[derive(Debug, Clone, PartialEq)]
pub struct OrbitMesh {
    /// Column prefix ([`Drivetrain::mesh_prefix`]; `""` for the single pair).
    pub prefix: String,
    /// Mesh frequency, Hz.
    pub mesh_frequency: f64,
    pub force: ForceStatistics,
}

/// The mesh forces along a periodic orbit of `scene` (the scene at the orbit's speed):
/// integrated from `orbit.y0` at `t = 0` over one orbit period, `samples_per_mesh_period`
/// samples per period of the first mesh.
pub fn orbit_mesh_forces(
    scene: &Scene,
    orbit: &PeriodicOrbit,
    samples_per_mesh_period: u32,
) -> Result<Vec<OrbitMesh>, String> {
    with_drivetrain!(scene.simulation()?, sim => {
        let mut sim = sim;
        let period = response_period(sim.model())? * f64::from(orbit.periods);
        let model = sim.model().clone();
        let meshes = model.mesh_count();
        // Mesh periods of the first mesh per orbit (an integer by construction).
        let cycles = (period * model.mesh_frequency(0)).round().max(1.0) as usize;
        let n = cycles * samples_per_mesh_period.max(8) as usize;
        let dt = period / n as f64;
        sim.set_y(0.0, &orbit.y0);
        let mut force = vec![Vec::with_capacity(n); meshes];
        for i in 1..=n {
            sim.advance_to(i as f64 * dt)
                .map_err(|e| format!("periodic orbit: {e}"))?;
            for (m, f) in force.iter_mut().enumerate() {
                f.push(sim.model().mesh_sample(m, sim.t(), sim.y()).force);
            }
        }
        let statics = model.static_mesh_forces();
        Ok((0..meshes)
            .map(|m| OrbitMesh {
                prefix: model.mesh_prefix(m),
                mesh_frequency: model.mesh_frequency(m),
                force: ForceStatistics::of(&force[m], statics[m]),
            })
            .collect())
    })
}
