//! Parametric instability bands of any linear scene over the input speed, from its monodromy
//! ([`super::monodromy`]: closed form for a single pair, exact segment transitions or RK
//! variational equations for a drivetrain; He & Singh 2007 §5: stable at 18,000 rpm, unstable
//! at 19,000 rpm in the primary region f_mesh ≈ 2 f_n).
//!
//! For a 2 × 2 real monodromy `Φ` (a single pair) with `det Φ > 0` both multipliers lie inside
//! the unit circle iff `|tr Φ| < 1 + det Φ` (and `det Φ ≤ 1`, which damping guarantees;
//! undamped, `det Φ = 1` by Liouville and the test is `|tr Φ| < 2`). So `|tr Φ| − (1 + det Φ)`
//! is positive exactly inside a band, changes sign at its edges, and is bisected there; it is
//! smooth across the edges, unlike `|μ|max − 1`. Bands of order `n` sit near
//! `f_mesh = 2 f̄_n / n`; odd orders have a multiplier at −1 (`tr Φ < 0`), even ones at +1. For
//! more DOF (combination resonances near `f_mesh = (f_i + f_j)/n`) the margin is
//! `|μ|max − 1`.

use std::f64::consts::TAU;

use super::monodromy;
use crate::model::SceneSource;
use crate::scene::Scene;

/// One unstable speed interval.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InstabilityBand {
    /// Lower and upper edge, input speed in rad/s.
    pub from_speed: f64,
    pub to_speed: f64,
    /// Order `n` of a single pair's band: the nearest integer to `2 f̄_n / f_mesh` at its
    /// centre (1 is the primary band); `None` for a drivetrain.
    pub order: Option<u32>,
    /// Largest multiplier modulus found on the scan inside the band.
    pub peak_spectral_radius: f64,
}

/// The stability margin (positive inside a band: `|tr Φ| − (1 + det Φ)` for a 2 × 2
/// monodromy, `|μ|max − 1` otherwise) and the spectral radius at an input speed.
pub fn stability_margin(scene: &impl SceneSource, speed: f64) -> Result<(f64, f64), String> {
    let mut s = scene.to_scene();
    s.set_input_speed(speed);
    let floquet = monodromy(&s)?;
    let phi = &floquet.monodromy;
    let radius = floquet.spectral_radius();
    let margin = if phi.nrows() == 2 {
        phi.trace().abs() - (1.0 + phi.determinant())
    } else {
        radius - 1.0
    };
    Ok((margin, radius))
}

/// Mean natural frequency of a single pair `f̄_n = sqrt(k̄/m_e)/2π`, Hz; `None` for a
/// drivetrain (see `geardyn modes`).
pub fn mean_natural_frequency(scene: &impl SceneSource) -> Option<f64> {
    let s = scene.to_scene().pair()?;
    Some((s.mesh.stiffness.mean() / s.equivalent_mass()).sqrt() / TAU)
}

/// Mesh cycles of the first mesh per input revolution.
fn first_mesh_teeth(scene: &Scene) -> f64 {
    scene.meshes[0].cycles_per_input_rev
}

/// Unstable bands between `from_speed` and `to_speed` (rad/s), scanned at `points` evenly
/// spaced speeds and their edges bisected to a relative `1e-10`. Bands narrower than the scan
/// spacing can be missed; an edge at the end of the range is reported as the range end.
pub fn instability_bands(
    scene: &impl SceneSource,
    from_speed: f64,
    to_speed: f64,
    points: usize,
) -> Result<Vec<InstabilityBand>, String> {
    scene
        .to_scene()
        .profiles
        .require_constant("the instability-band scan")?;
    if !(from_speed > 0.0 && to_speed > from_speed && to_speed.is_finite()) {
        return Err(format!(
            "speed range {from_speed}..{to_speed} rad/s: needs 0 < from < to"
        ));
    }
    if points < 2 {
        return Err(format!("points = {points}: at least 2 are needed"));
    }
    if points > crate::units::MAX_SWEEP_POINTS {
        return Err(format!(
            "points = {points}: more than the {} a scan may have",
            crate::units::MAX_SWEEP_POINTS
        ));
    }
    let scene = &scene.to_scene();
    let speed_at = |i: usize| from_speed + (to_speed - from_speed) * i as f64 / (points - 1) as f64;
    let margin = |w: f64| stability_margin(scene, w).map(|m| m.0);
    let edge = |mut lo: f64, mut hi: f64, lo_unstable: bool| -> Result<f64, String> {
        while hi - lo > 1e-10 * hi {
            let mid = 0.5 * (lo + hi);
            if (margin(mid)? > 0.0) == lo_unstable {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        Ok(0.5 * (lo + hi))
    };
    let f_n = mean_natural_frequency(scene);
    let teeth = first_mesh_teeth(scene);
    let mut bands = Vec::new();
    let mut open: Option<(f64, f64)> = None; // (start speed, peak radius)
    let (mut prev_w, mut prev_unstable) = (from_speed, false);
    for i in 0..points {
        let w = speed_at(i);
        let (m, radius) = stability_margin(scene, w)?;
        let unstable = m > 0.0;
        match (&mut open, unstable) {
            (None, true) => {
                let start = if i == 0 {
                    w
                } else {
                    edge(prev_w, w, prev_unstable)?
                };
                open = Some((start, radius));
            }
            (Some((_, peak)), true) => *peak = peak.max(radius),
            (Some((start, peak)), false) => {
                let end = edge(prev_w, w, prev_unstable)?;
                bands.push(band(*start, end, *peak, f_n, teeth));
                open = None;
            }
            (None, false) => {}
        }
        (prev_w, prev_unstable) = (w, unstable);
    }
    if let Some((start, peak)) = open {
        bands.push(band(start, to_speed, peak, f_n, teeth));
    }
    Ok(bands)
}

fn band(from: f64, to: f64, peak: f64, f_n: Option<f64>, teeth: f64) -> InstabilityBand {
    let f_mesh = teeth * 0.5 * (from + to) / TAU;
    InstabilityBand {
        from_speed: from,
        to_speed: to,
        order: f_n.map(|f_n| (2.0 * f_n / f_mesh).round().max(1.0) as u32),
        peak_spectral_radius: peak,
    }
}
