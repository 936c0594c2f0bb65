//! The aliasing rule of `simulate`: which mesh harmonics matter, and whether the output
//! interval resolves them (`docs/spectrum.md`, "Aliasing").

use crate::model::Drivetrain;

/// A mesh harmonic matters when its amplitude in the mesh's excitation is at least this
/// fraction of the static mesh force.
pub const HARMONIC_THRESHOLD: f64 = 1e-2;

/// Samples of the excitation over one mesh period (resolves harmonics up to 128).
const SAMPLES: usize = 256;

/// The highest harmonic `h ≥ 1` of mesh `n` that matters: the excitation is the mesh force at
/// the static deflection with zero rate, `g(p) = F(p, δ_s, 0)` (`δ_s = F_static/k̄`), which holds
/// both parametric sources, `k(p)·δ_s` and the STE's `−k(p)·e(p)`; harmonic h matters when
/// `|G_h| ≥ HARMONIC_THRESHOLD · F_static` (at least the fundamental counts).
pub fn highest_mesh_harmonic<M: Drivetrain>(model: &M, n: usize) -> usize {
    let f_static = model.static_mesh_forces()[n].abs();
    let (k_mean, _) = model.mean_mesh_law(n);
    let f_m = model.mesh_frequency(n);
    if !(f_static > 0.0 && k_mean > 0.0 && f_m > 0.0) {
        return 1;
    }
    let s = f_static / k_mean;
    let g: Vec<f64> = (0..SAMPLES)
        .map(|j| {
            model
                .mesh_law(n, j as f64 / (SAMPLES as f64 * f_m), s, 0.0)
                .force[0]
        })
        .collect();
    let Ok(spectrum) = super::exact_dft(&g, 1.0 / f_m) else {
        return 1;
    };
    (1..spectrum.amplitude.len())
        .rev()
        .find(|&h| spectrum.amplitude[h] >= HARMONIC_THRESHOLD * f_static)
        .unwrap_or(1)
}

/// The warning for output interval `interval` (s) when its Nyquist frequency `1/(2·interval)`
/// lies below `frequency` (Hz), harmonic `harmonic` of mesh `mesh` at its highest speed.
pub fn aliasing_warning(
    interval: f64,
    mesh: &str,
    harmonic: usize,
    frequency: f64,
) -> Option<String> {
    let nyquist = 0.5 / interval;
    (frequency > nyquist).then(|| {
        format!(
            "warning: output interval {interval:e} s (Nyquist {nyquist:.1} Hz) aliases harmonic \
             {harmonic} of {mesh} at {frequency:.1} Hz; use an output interval ≤ {:.3e} s",
            0.5 / frequency
        )
    })
}

/// The aliasing warning of a model's outputs sampled every `interval` s, for mesh frequencies
/// scaled by `speed_factor` (the highest speed of the run over the model's current speed; 1
/// at constant speed). The highest-frequency harmonic that matters over all meshes decides.
pub fn model_aliasing_warning<M: Drivetrain>(
    model: &M,
    interval: f64,
    speed_factor: f64,
) -> Option<String> {
    let worst = (0..model.mesh_count())
        .map(|n| {
            let h = highest_mesh_harmonic(model, n);
            (n, h, h as f64 * model.mesh_frequency(n) * speed_factor)
        })
        .max_by(|a, b| a.2.total_cmp(&b.2))?;
    let prefix = model.mesh_prefix(worst.0);
    let mesh = if prefix.is_empty() {
        "the mesh".to_string()
    } else {
        format!("mesh {}", prefix.trim_end_matches('.'))
    };
    aliasing_warning(interval, &mesh, worst.1, worst.2)
}
