//! Each mesh's response over a recorded stretch of a run ([`MeshResponse`]): the statistics
//! `sweep` and `periodic` report.

use std::f64::consts::TAU;

use super::mesh_response::MeshResponse;
use crate::model::Drivetrain;
use crate::simulation::Driver;

/// Each mesh's response over `duration` seconds from the run's current state, which the run
/// advances to its end. `duration` spans whole periods of the first mesh;
/// `samples_per_period` samples per period of the first mesh; with `poincare` the DTE at the
/// start of every period of the first mesh is kept.
pub fn record<M: Drivetrain>(
    sim: &mut Driver<M>,
    duration: f64,
    samples_per_period: u32,
    poincare: bool,
) -> Result<Vec<MeshResponse>, String> {
    let model = sim.model();
    let meshes = model.mesh_count();
    let f1 = model.mesh_frequency(0);
    let cycles = (duration * f1).round().max(1.0) as usize;
    let per = samples_per_period.max(8) as usize;
    let n = cycles * per;
    let dt = duration / n as f64;
    let frequencies: Vec<f64> = (0..meshes).map(|m| model.mesh_frequency(m)).collect();
    let static_forces = model.static_mesh_forces();
    let t_start = sim.t();
    let mut dte = vec![Vec::with_capacity(n); meshes];
    let mut force = vec![Vec::with_capacity(n); meshes];
    let mut lost = vec![0usize; meshes];
    let mut separation = vec![f64::NAN; meshes];
    let mut was_lost: Vec<bool> = (0..meshes)
        .map(|m| sim.model().mesh_sample(m, sim.t(), sim.y()).lost)
        .collect();
    let mut sections = vec![Vec::new(); meshes];
    for i in 1..=n {
        sim.advance_to(t_start + i as f64 * dt)
            .map_err(|e| e.to_string())?;
        let (t, y) = (sim.t(), sim.y());
        for m in 0..meshes {
            let s = sim.model().mesh_sample(m, t, y);
            dte[m].push(s.dte);
            force[m].push(s.force);
            if s.lost {
                lost[m] += 1;
                if !was_lost[m] && separation[m].is_nan() {
                    separation[m] = s.phase;
                }
            }
            was_lost[m] = s.lost;
            if poincare && i % per == 0 {
                sections[m].push(s.dte);
            }
        }
    }
    Ok((0..meshes)
        .map(|m| {
            let x = &dte[m];
            let (mean, rms) = mean_and_rms(x);
            let (lo, hi) = x
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
                    (lo.min(v), hi.max(v))
                });
            // This mesh's harmonics: its cycles per sample are f_m·dt.
            let cycles_per_sample = frequencies[m] * dt;
            let mut harmonics = [0.0; 3];
            for (h, a) in harmonics.iter_mut().enumerate() {
                let (mut re, mut im) = (0.0, 0.0);
                for (i, v) in x.iter().enumerate() {
                    let angle = TAU * (h + 1) as f64 * cycles_per_sample * (i + 1) as f64;
                    re += v * angle.cos();
                    im -= v * angle.sin();
                }
                *a = 2.0 * (re * re + im * im).sqrt() / n as f64;
            }
            let (_, force_rms) = mean_and_rms(&force[m]);
            let peak = force[m].iter().fold(0.0f64, |a, v| a.max(v.abs()));
            MeshResponse {
                prefix: sim.model().mesh_prefix(m),
                mesh_frequency: frequencies[m],
                dte_mean: mean,
                dte_rms: rms,
                dte_peak_to_peak: hi - lo,
                harmonics,
                contact_loss_fraction: lost[m] as f64 / n as f64,
                separation_phase: separation[m],
                peak_force: peak,
                force_rms,
                dynamic_factor: peak / static_forces[m].abs(),
                poincare: std::mem::take(&mut sections[m]),
            }
        })
        .collect())
}

fn mean_and_rms(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    let rms = (x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt();
    (mean, rms)
}

/// Each mesh's response along a periodic orbit of `scene` (the scene at the orbit's speed),
/// from `orbit.y0` at `t = 0` over one orbit period.
pub fn orbit_responses(
    scene: &crate::model::AnyScene,
    orbit: &super::shooting::PeriodicOrbit,
    samples_per_period: u32,
) -> Result<Vec<MeshResponse>, String> {
    crate::with_drivetrain!(scene.simulation()?, sim => {
        let mut sim = sim;
        let period = crate::model::response_period(sim.model())? * f64::from(orbit.periods);
        sim.set_y(0.0, &orbit.y0);
        record(&mut sim, period, samples_per_period, false)
            .map_err(|e| format!("periodic orbit: {e}"))
    })
}
